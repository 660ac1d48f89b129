"""Steady-state detection on synthetic signals with known periodicity."""

import numpy as np

from rigtools.sim.steady_state import check_periodic, period_mismatch

N = 200  # samples per excitation period


def _t(periods):
    return np.arange(periods * N) / N  # time in excitation periods


def test_periodic_signal_is_steady_with_period_one():
    t = _t(10)
    x = np.sin(2 * np.pi * t) + 0.3 * np.cos(2 * np.pi * 6 * t)
    res = check_periodic(x, N, tol=1e-9)
    assert res.steady and res.period_multiple == 1 and res.mismatch < 1e-12


def test_period_doubling_is_found():
    t = _t(12)
    x = np.sin(2 * np.pi * t) + 0.2 * np.sin(np.pi * t)  # fe/2 subharmonic
    res = check_periodic(x, N, tol=1e-9)
    assert res.steady and res.period_multiple == 2


def test_decaying_transient_is_not_steady_until_small():
    """A free decay at 0.7 fe on top of the forced response: mismatch tracks its size."""
    t = _t(12)
    forced = np.sin(2 * np.pi * t)
    for amp, steady in ((1e-2, False), (1e-7, True)):
        x = forced + amp * np.exp(-0.05 * t) * np.sin(2 * np.pi * 0.7 * t)
        assert check_periodic(x, N, tol=1e-6).steady is steady


def test_near_commensurate_transient_is_not_taken_for_a_subharmonic():
    """A transient at 2.04 fe/3 nearly repeats after 3 periods; it must not pass as period 3."""
    t = _t(14)
    x = np.sin(2 * np.pi * t) + 1e-4 * np.sin(2 * np.pi * (2.04 / 3) * t)
    res = check_periodic(x, N, tol=1e-4)
    assert not (res.steady and res.period_multiple == 3)


def test_common_scale_ignores_a_blade_at_rest():
    """The second signal barely moves; with a common scale its residue does not block."""
    t = _t(8)
    a = np.sin(2 * np.pi * t)
    b = 1e-9 * np.sin(2 * np.pi * 0.77 * t)
    sig = np.vstack([a, b])
    assert period_mismatch(sig, N) > 0.1
    assert check_periodic(sig, N, tol=1e-6, scale=np.array([2.0, 2.0])).steady
