"""Floquet multipliers from a transient (rigtools.analysis.floquet) on signals of known
multipliers: sums of Floquet solutions ``Re(a exp(lambda t) p(t))`` with ``p`` periodic, whose
multipliers are ``exp(lambda T)`` exactly (Floquet's theorem), on two channels. The rig-based
check against the model's monodromy matrix is in tests/drivers/test_realtime_loop.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigtools.analysis.floquet import (
    TransientPiece,
    floquet_multipliers,
    periodic_reference,
    pooled_floquet_multipliers,
)

FE = 64.0
TRUE = np.array([1.1, 0.9 * np.exp(1j * 1.2), 0.9 * np.exp(-1j * 1.2), 0.6])


def _transient(fs: float, periods: int, seed: int = 0, start: int | None = None) -> np.ndarray:
    """Two channels; each multiplier's Floquet solution with a random periodic shape of three
    harmonics (the complex pair as one real solution); ``start`` (a seed): the same system
    (shapes of ``seed``) from other random amplitudes of its solutions."""
    rng = np.random.default_rng(seed)
    weights = np.random.default_rng(start)
    t = np.arange(round(periods * fs / FE)) / fs
    w = 2 * math.pi * FE
    out = np.zeros((2, t.size))
    for mu in (TRUE[0], TRUE[1], TRUE[3]):
        lam = np.log(complex(mu)) * FE
        mode = complex(*weights.normal(size=2))  # with ``start``: the solution's one amplitude
        for c in range(2):
            shape = sum(complex(*rng.normal(size=2)) * np.exp(1j * h * w * t) for h in range(-3, 4))
            a = complex(*rng.normal(size=2))
            if start is not None:  # the same system: this channel's part of the solution's shape
                a *= mode
            out[c] += (1e-6 * a * np.exp(lam * t) * shape).real
    return out


@pytest.mark.parametrize("fs", [FE * 800, 51_200.0 * 0.99])  # whole and fractional samples per period
@pytest.mark.parametrize("harmonics", [None, 3])
def test_the_multipliers_of_a_known_floquet_transient_come_back(fs, harmonics):
    """All four within 1e-3 (relative), with each period's vector its 8 instants or its mean and
    harmonics 1-3 (the shapes' band: exact): the interpolation of the instants at a fractional
    number of samples per period (linear, 790 samples a period) is the error left."""
    measured = floquet_multipliers(_transient(fs, 30), fs, FE, harmonics=harmonics)
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


def test_pooled_short_transients_give_the_multipliers_of_their_orbit():
    """Four transients of the same orbit from different starting deviations, six periods
    each (as the short releases of a controller that must catch the orbit again): pooled, the
    pairs of all four fit the four multipliers within 1e-3, with the pairs counted (5 a piece;
    none straddles two pieces: the pieces joined end to end leave a residual 100 times as large)."""
    fs = FE * 800
    pieces = [TransientPiece(_transient(fs, 6, 0, start)) for start in range(4)]
    measured = pooled_floquet_multipliers(pieces, fs, FE, harmonics=3)
    for mu in TRUE:
        assert np.min(np.abs(measured.multipliers - mu)) < 1e-3 * abs(mu), measured.multipliers
    assert measured.periods == (0, 4 * 4)  # periods 0..4 of each (the last whole one ends the record)
    joined = floquet_multipliers(np.concatenate([p.deviation for p in pieces], axis=1), fs, FE)
    assert joined.residual > 100 * measured.residual  # pairs straddling the joins fit no map


def test_pooled_pieces_with_too_few_pairs_is_one_line():
    short = TransientPiece(_transient(FE * 800, 3), 0, 1)
    with pytest.raises(ValueError, match="1 pairs of periods to fit in 2 pieces"):
        pooled_floquet_multipliers([short, TransientPiece(np.zeros((2, 10)))], FE * 800, FE)
