"""The part of a steady record that is read must not change its answer (issue 29, item 7).

A sine dwell on the simulated rig at 60 Hz, 15 N (40 periods recorded after the dwell settles),
without contact (gap 5 mm) and with one impact per period (gap 0.5 mm, the paper's regime). Any
two windows of whole periods of its record window -- its first and second half, or windows drawn
by hypothesis -- give the same force fundamental, the same harmonics of the active shroud and the
same impacts per period, as ``rig analyze`` reads them (:func:`rigtools.analysis.point.analyze_dwell`).

Tolerance of a harmonic amplitude: six standard deviations of the difference of two independent
estimates, ``6 sqrt(2) r sqrt(2 / n)`` with ``r`` the larger residual RMS of the two fits (the
noise, and any periodic content above the harmonics fitted, which is the same in both windows if
the record is steady) and ``n`` the samples per window; a drift of the steady state (a dwell
recorded before it settled) exceeds it. Impacts per period: the same count (their difference
below half an impact over the window).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import rigtools
from rigtools.analysis.point import analyze_dwell
from rigtools.recording import open_recording

FE, PERIODS, K = 60.0, 40, 5
CHANNELS = ("force", "active_shroud_accel", "passive_shroud_accel")


@pytest.fixture(scope="module", params=["5 mm", "0.5 mm"])
def record(request, tmp_path_factory):
    """``(channels over the record window, sample rate, gap)`` of one settled dwell."""
    out = tmp_path_factory.mktemp("half") / "dwell.h5"
    run = rigtools.dwell(
        f"{FE} Hz", "15 N", out, gap=request.param, record_periods=PERIODS, backend="sim", seed=1
    )
    assert run.points[0].settled
    with open_recording(out) as rec:
        p = rec.points[0]
        start, n = p.record_window
        chans = {c: np.asarray(p.channels[c][start : start + n], float) for c in CHANNELS}
        return chans, float(p.sample_rate), request.param


def _window(record, first_period: int, periods: int):
    chans, rate, _ = record
    a, n = round(first_period * rate / FE), round(periods * rate / FE)
    return analyze_dwell({c: v[a : a + n] for c, v in chans.items()}, rate, FE, k_max=K), n


def _same(one, two, n: int) -> None:
    for name in ("force", "active_shroud_accel"):
        f1, f2 = one.harmonics[name], two.harmonics[name]
        r = max(f1.residual_rms, f2.residual_rms)
        bound = 6 * np.sqrt(2) * r * np.sqrt(2 / n) + 1e-9 * f1.amplitude
        assert np.all(np.abs(f1.amplitude - f2.amplitude) <= bound), (name, f1.amplitude, f2.amplitude, bound)
    ipp1, ipp2 = one.impacts.impacts_per_period, two.impacts.impacts_per_period
    periods = n * FE / one.sample_rate
    assert abs(ipp1 - ipp2) * periods < 0.5, (ipp1, ipp2)


def test_the_two_halves_of_a_steady_dwell_give_the_same_answer(record):
    first, n = _window(record, 0, PERIODS // 2)
    second, _ = _window(record, PERIODS // 2, PERIODS // 2)
    _same(first, second, n)
    expected = 0.0 if record[2] == "5 mm" else 1.0  # no contact at 5 mm; one impact at 0.5 mm
    assert (
        round(first.impacts.impacts_per_period, 2) == round(second.impacts.impacts_per_period, 2) == expected
    )


@settings(max_examples=10, deadline=None)
@given(data=st.data())
def test_any_two_windows_of_a_steady_dwell_give_the_same_answer(record, data):
    """Two windows of the same length (10 to 20 whole periods) anywhere in the record window."""
    periods = data.draw(st.integers(min_value=10, max_value=PERIODS // 2), label="periods")
    a = data.draw(st.integers(min_value=0, max_value=PERIODS - periods), label="first start")
    b = data.draw(st.integers(min_value=0, max_value=PERIODS - periods), label="second start")
    one, n = _window(record, a, periods)
    two, _ = _window(record, b, periods)
    _same(one, two, n)
