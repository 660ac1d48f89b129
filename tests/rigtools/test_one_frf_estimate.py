"""One recording, one FRF estimate everywhere (issue 18, step 1).

A simulated burst-random and a periodic-chirp ``rig acquire frf`` test: the FRF at each mode's
peak that ``rig analyze --json`` reports equals the one ``rig compare --json`` shows for its EM
modes, the one ``rig export uff`` writes (read back with pyuff), the front door's
(``rigtools.analyze_recording``, ``rigtools.compare_with_model``), the FRF test's quick check
(``rig acquire frf --json``) and the modes ``rig update`` takes: relative difference < 1e-9; and
all of them equal scipy.signal's H1 (csd / welch) on the recorded frames, < 1e-9.
Overrides of the estimate that would be ignored are refused in one line (exit 2).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import pyuff
from cli_helpers import run_cli

import rigtools
from rigtools.config import default_rig_text
from rigtools.recording import ChannelSpec, RecordingWriter, open_recording

ACTIVE = "active_shroud_accel"
FRF = ["acquire", "frf", "--backend", "sim", "--band", "20 Hz:1500 Hz", "--level", "0.3 V"]
FRF += ["--frame", "0.25 s", "--averages", "3", "--gap", "5 mm", "--seed", "3"]
RATE = 4096.0


def _dwell(path, backend: str) -> None:
    """One 60 Hz sine point (1 s) on force and both shrouds: the EM or model side of rig compare."""
    t = np.arange(int(RATE)) / RATE
    channels = [
        ChannelSpec("force", "N", "force", RATE),
        ChannelSpec(ACTIVE, "m/s^2", "acceleration", RATE),
        ChannelSpec("passive_shroud_accel", "m/s^2", "acceleration", RATE),
    ]
    with RecordingWriter(path, backend, default_rig_text(), {"procedure": "sine dwell"}) as rec:
        point = rec.begin_point({"fe": 60.0, "gap": 5e-3, "force_amplitude": 5.0}, channels)
        point.append(np.vstack([5 * np.sin(2 * np.pi * 60 * t), 40 * np.sin(2 * np.pi * 60 * t + 1), 0 * t]))
        point.end()


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("one-frf")
    out = {"folder": folder}
    for signal in ("burst", "chirp"):
        path = folder / f"{signal}.h5"
        code, js, err = run_cli([*FRF, "--signal", signal, "--out", path, "--json"])
        assert code == 0, err
        out[signal], out[f"{signal}-check"] = path, json.loads(js)["check"]
    _dwell(folder / "em.h5", "simulated")
    _dwell(folder / "fem.h5", "fem")
    return out


def _peaks(frf: dict) -> dict[float, complex]:
    """``{peak_hz: H1 at the peak}`` of the active shroud's modes in an ``"frf"`` JSON block."""
    modes = frf["modes"][ACTIVE]["modes"]
    return {m["evidence"]["peak_hz"]: complex(m["frf_at_peak"]["re"], m["frf_at_peak"]["im"]) for m in modes}


def _same(a: complex, b: complex) -> float:
    return abs(a - b) / abs(a)


def _scipy_h1(path, frame: int) -> tuple[np.ndarray, np.ndarray]:
    """``(f, H1)`` of the active shroud over the force by scipy.signal, written here: csd/welch
    over the record window, contiguous ``frame``-sample frames, rectangular window, no overlap,
    no detrend (the burst and periodic-chirp estimator of the field, H1 = Gxy / Gxx)."""
    from scipy import signal

    with open_recording(path) as rec:
        point = rec.points[0]
        start, n = point.record_window
        stop = start + (n // frame) * frame
        x = np.asarray(point.channels["force"][start:stop], dtype=float)
        y = np.asarray(point.channels[ACTIVE][start:stop], dtype=float)
        rate = float(point.sample_rate)
    opts = {"fs": rate, "window": "boxcar", "nperseg": frame, "noverlap": 0, "detrend": False}
    f, gxy = signal.csd(x, y, **opts)
    _, gxx = signal.welch(x, **opts)
    return f, gxy / gxx


@pytest.mark.parametrize("signal", ["burst", "chirp"])
def test_every_reader_reports_the_same_frf_at_the_peaks(files, signal, tmp_path):
    path = files[signal]
    code, js, err = run_cli(["analyze", path, "--json"])
    assert code == 0, err
    frf = json.loads(js)["points"][0]["frf"]
    assert frf["frf_method"]["excitation"] == {"burst": "burst", "chirp": "periodic"}[signal]
    analyzed = _peaks(frf)
    assert len(analyzed) == 3  # the active blade's three flexural modes in 20-1500 Hz
    # the independent reference: scipy.signal's H1 on the same frames; 1e-9 relative (the same
    # estimator in exact arithmetic: only the order of the sums differs, at |H| peaks)
    f_ref, h_ref = _scipy_h1(path, frf["frf_method"]["frame_samples"])
    for f, h in analyzed.items():
        j = int(np.argmin(np.abs(f_ref - f)))
        assert abs(f_ref[j] - f) < 1e-9 and _same(h_ref[j], h) < 1e-9, (f, h, h_ref[j])

    # rig compare --json: the EM modes' FRF
    em, fem = files["folder"] / "em.h5", files["folder"] / "fem.h5"
    code, js, err = run_cli(["compare", em, fem, "--frf", path, "--json"])
    assert code == 0, err
    compared = json.loads(js)["em_frf"]
    assert compared["file"] == str(path) and compared["frf_method"] == frf["frf_method"]
    assert _peaks(compared).keys() == analyzed.keys()

    # rig export uff, read back with pyuff
    uff = tmp_path / "out.uff"
    code, _, err = run_cli(["export", "uff", path, uff, "--what", "frf"])
    assert code == 0, err
    (record,) = [
        s for s in pyuff.UFF(str(uff)).read_sets() if s.get("func_type") == 4 and f" {ACTIVE}/" in s["id1"]
    ]

    # the front door
    front = rigtools.analyze_recording(path).broadband[0]
    row = front.frf.responses.index(ACTIVE)
    door_compare = rigtools.compare_with_model(em, fem, frf=path).em_frf

    check = {p["frequency_hz"]: p["h1"] for p in files[f"{signal}-check"]["peaks"]}
    for f, h in analyzed.items():
        assert _same(h, _peaks(compared)[f]) < 1e-9
        assert _same(h, complex(record["data"][np.argmin(np.abs(record["x"] - f))])) < 1e-9
        assert _same(h, front.frf_at(row, f)) < 1e-9
        assert _same(h, _peaks(door_compare)[f]) < 1e-9
        if f in check:  # the quick check's peaks (|H1|), among its five most prominent
            assert abs(check[f] - abs(h)) / abs(h) < 1e-9
    assert len(set(check) & set(analyzed)) >= 2

    # rig update's targets come from the same modes
    from rigtools.update_modes import identify_recording

    (active,) = [s for s in identify_recording(path).sets if s.response == ACTIVE]
    ident = front.frf.modes[ACTIVE].modes
    assert active.frequencies_hz == sorted(m.frequency_hz for m in ident)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (
            ["--frame-samples", "4096"],
            "--frame-samples would be ignored: its FRF is the recorded burst test's",
        ),
        (["--excitation", "burst", "--force-window", "0.5"], "--force-window apply to impact tests"),
    ],
)
def test_an_override_that_would_be_ignored_is_refused(files, extra, message):
    for command in (
        ["analyze", files["burst"]],
        ["export", "uff", files["burst"], files["folder"] / "x.uff"],
    ):
        if command[0] == "export" and "--force-window" in extra:
            continue  # rig export takes no impact windows
        code, _, err = run_cli([*command, *extra])
        assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize("frame", ["3", "63"])
def test_a_frame_too_short_for_an_frf_is_refused(files, frame):
    """``--excitation burst --frame-samples 3`` wrote a 2-line FRF before; now one line naming
    the minimum (analysis.frf.MIN_FRAME_SAMPLES, the acquisition's --frame rule too), exit 2,
    nothing written. 64 samples are taken."""
    out = files["folder"] / f"short-{frame}.uff"
    for command in (["analyze", files["burst"]], ["export", "uff", files["burst"], out, "--what", "frf"]):
        code, stdout, err = run_cli([*command, "--excitation", "burst", "--frame-samples", frame])
        assert (code, stdout, err.strip().splitlines()) == (
            2,
            "",
            [
                (
                    f"rig {command[0]}: error: --frame-samples = {frame}: an FRF frame needs at least 64 "
                    "samples (N samples give N/2 + 1 lines from 0 Hz to half the sample rate)"
                )
            ],
        )
        assert not out.exists()
    code, _, err = run_cli(
        [
            "export",
            "uff",
            files["burst"],
            out,
            "--what",
            "frf",
            "--excitation",
            "burst",
            "--frame-samples",
            "64",
        ]
    )
    assert code == 0, err
    (record, *_) = [s for s in pyuff.UFF(str(out)).read_sets() if s["type"] == 58]
    assert record["num_pts"] == 33
