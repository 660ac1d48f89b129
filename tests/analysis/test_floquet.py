"""Floquet multipliers from a transient (rigtools.analysis.floquet) on signals of known
multipliers: sums of Floquet solutions ``Re(a exp(lambda t) p(t))`` with ``p`` periodic, whose
multipliers are ``exp(lambda T)`` exactly (Floquet's theorem), on two channels. The rig-based
check against the model's monodromy matrix is in tests/drivers/test_realtime_loop.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigtools.analysis.floquet import floquet_multipliers, periodic_reference

FE = 64.0
TRUE = np.array([1.1, 0.9 * np.exp(1j * 1.2), 0.9 * np.exp(-1j * 1.2), 0.6])


def _transient(fs: float, periods: int, seed: int = 0) -> np.ndarray:
    """Two channels; each multiplier's Floquet solution with a random periodic shape of three
    harmonics (the complex pair as one real solution)."""
    rng = np.random.default_rng(seed)
    t = np.arange(round(periods * fs / FE)) / fs
    w = 2 * math.pi * FE
    out = np.zeros((2, t.size))
    for mu in (TRUE[0], TRUE[1], TRUE[3]):
        lam = np.log(complex(mu)) * FE
        for c in range(2):
            shape = sum(complex(*rng.normal(size=2)) * np.exp(1j * h * w * t) for h in range(-3, 4))
            out[c] += (1e-6 * complex(*rng.normal(size=2)) * np.exp(lam * t) * shape).real
    return out


@pytest.mark.parametrize("fs", [FE * 800, 51_200.0 * 0.99])  # whole and fractional samples per period
def test_the_multipliers_of_a_known_floquet_transient_come_back(fs):
    """All four within 1e-3 (relative): the interpolation of the instants at a fractional
    number of samples per period (linear, 790 samples a period) is the error left."""
    measured = floquet_multipliers(_transient(fs, 30), fs, FE)
    for mu in TRUE:
        assert np.min(np.abs(measured.multipliers - mu)) < 1e-3 * abs(mu), measured.multipliers
    assert measured.max_modulus == pytest.approx(1.1, rel=1e-3)


def test_limit_ends_the_fit_where_the_growth_leaves_the_linear_range():
    """The fit stops before the first period whose deviation passes ``limit``."""
    d = _transient(FE * 800, 40)
    peak = [np.max(np.abs(d[:, p * 800 : (p + 1) * 800])) for p in range(40)]
    limit = peak[20]
    measured = floquet_multipliers(d, FE * 800, FE, limit=limit * 0.999)
    assert measured.periods == (0, 19)


def test_periodic_reference_is_exact_for_whole_periods():
    """With a whole number of samples per period the orbit is the periods' average: a periodic
    signal with a jump every period (all harmonics) comes back to round-off."""
    p = 800
    one = np.where(np.arange(p) < 300, 1.0, -2.0) + np.sin(2 * np.pi * np.arange(p) / p)
    x = np.tile(one, 10)
    ref = periodic_reference(x, FE * p, FE, 2 * p, 10 * p)
    assert np.max(np.abs(ref - x)) < 1e-12


def test_too_few_periods_is_one_line():
    with pytest.raises(ValueError, match="give at least 3"):
        floquet_multipliers(np.ones(1700), 800 * FE, FE)
