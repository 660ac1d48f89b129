"""The order of a recording's channels must not change its analysis (issue 29, item 7).

A foreign broadband record (a force and two accelerations under their own names, as another
tool's file imports) of an exactly known system -- the viscously damped 2-DOF of
``tests/analysis/_reference.py`` driven by a periodic random force, its responses computed exactly
at every bin -- is written with its channels in each of the six orders. ``rig analyze``'s
answers (the FRF of each response, its modes) are the same for every order, and equal the exact
accelerance and the system's natural frequencies.

Tolerances: the FRFs of two orders are the same arithmetic on the same samples: 1e-12 relative.
Against the exact FRF: a periodic force over whole periods (``--excitation periodic``, one period a
frame) gives H1 = H at every excited bin, to round-off of the FFTs: 1e-8 relative. The modes: the
same between orders to 1e-9 (the same identification on the same FRF), and within 0.5 % of the
exact natural frequencies (an LSCF fit over the discrete 1 Hz grid of a 2.6 %-damped system).
"""

from __future__ import annotations

import itertools
import sys
from pathlib import Path

import numpy as np
import pytest

from rigtools.config import load_rig
from rigtools.recording import ChannelSpec, RecordingWriter
from rigtools.recording_analysis.dispatch import analyze_recording
from rigtools.recording_analysis.frf_estimate import FRFOptions

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "analysis"))
from _reference import modes, periodic_response, receptance

RATE, FRAME, PERIODS = 1024.0, 1024, 8
NAMES = {"Force": ("N", "force"), "acc_a": ("m/s^2", "acceleration"), "acc_b": ("m/s^2", "acceleration")}
ORDERS = list(itertools.permutations(NAMES))


def _signals() -> dict[str, np.ndarray]:
    """One period of a band-limited random force (20-400 Hz, flat amplitude, random phases) and
    the exact periodic accelerations of both masses, repeated PERIODS times."""
    rng = np.random.default_rng(4)
    f = np.fft.rfftfreq(FRAME, 1 / RATE)
    spec = np.where((f >= 20) & (f <= 400), np.exp(2j * np.pi * rng.uniform(size=f.size)), 0.0)
    force = np.fft.irfft(spec, n=FRAME) * FRAME
    out = {"Force": force}
    out["acc_a"] = periodic_response(force, RATE, out=0, kind="accelerance")
    out["acc_b"] = periodic_response(force, RATE, out=1, kind="accelerance")
    return {k: np.tile(v, PERIODS) for k, v in out.items()}


@pytest.fixture(scope="module")
def analyses(tmp_path_factory):
    folder = tmp_path_factory.mktemp("order")
    signals = _signals()
    options = FRFOptions(excitation="periodic", frame_samples=FRAME)
    out = {}
    for order in ORDERS:
        path = folder / ("-".join(order) + ".h5")
        rig = load_rig(None).to_json()
        with RecordingWriter(path, backend="import", rig=rig, experiment={"procedure": "import"}) as rec:
            specs = [ChannelSpec(n, *NAMES[n], RATE) for n in order]
            point = rec.begin_point({}, specs)
            point.append(np.vstack([signals[n] for n in order]))
            point.end()
        out[order] = analyze_recording(path, options=options).broadband[0].frf
    return out


def _by_response(frf) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    est = frf.estimate
    return {name: (est.frequency_hz, est.h1[i]) for i, name in enumerate(frf.responses)}


def test_every_channel_order_gives_the_same_frfs(analyses):
    first = _by_response(analyses[ORDERS[0]])
    assert sorted(first) == ["acc_a", "acc_b"]
    for order in ORDERS[1:]:
        got = _by_response(analyses[order])
        assert sorted(got) == sorted(first), order
        for name, (f, h) in got.items():
            np.testing.assert_array_equal(f, first[name][0])
            np.testing.assert_allclose(h, first[name][1], rtol=1e-12, atol=0, err_msg=f"{order} {name}")


def test_the_frfs_equal_the_exact_accelerance(analyses):
    for name, (f, h) in _by_response(analyses[ORDERS[0]]).items():
        excited = (f >= 20) & (f <= 400)
        exact = receptance(f[excited], out={"acc_a": 0, "acc_b": 1}[name]) * (2j * np.pi * f[excited]) ** 2
        np.testing.assert_allclose(h[excited], exact, rtol=1e-8, err_msg=name)


def test_every_channel_order_gives_the_same_modes(analyses):
    fn_exact, _ = modes()
    first = {
        name: np.array([m.frequency_hz for m in analyses[ORDERS[0]].modes[name].modes])
        for name in ("acc_a", "acc_b")
    }
    for name, fn in first.items():
        assert fn.size == 2, (name, fn)
        np.testing.assert_allclose(fn, fn_exact, rtol=5e-3, err_msg=name)
    for order in ORDERS[1:]:
        for name, fn_first in first.items():
            fn = np.array([m.frequency_hz for m in analyses[order].modes[name].modes])
            np.testing.assert_allclose(fn, fn_first, rtol=1e-9, err_msg=f"{order} {name}")
