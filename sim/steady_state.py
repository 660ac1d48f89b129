"""Detect a periodic steady state by comparing consecutive excitation periods.

A response is steady with period ``m*T`` (``T = 1/fe``) when, for each monitored signal, the last
``n_compare`` periods match the ones ``m`` periods earlier sample by sample to a relative
tolerance (relative to the signal's peak-to-peak over the compared window). ``m = 1`` is the
ordinary periodic response; ``m > 1`` a subharmonic one (period doubling and so on).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

SUBHARMONIC_DISTINCT = 1e-2  # period-1 mismatch above which a lag-m match counts as period m


@dataclass(frozen=True)
class Periodicity:
    """Outcome of :func:`check_periodic`.

    Attributes
    ----------
    steady
        True when some ``m <= max_multiple`` meets the tolerance.
    period_multiple
        That ``m`` (1 = period of the excitation); 0 when not steady.
    mismatch
        Relative mismatch for ``m = period_multiple`` (or the smallest found when not steady).
    """

    steady: bool
    period_multiple: int
    mismatch: float


def period_mismatch(
    signals: np.ndarray,
    samples_per_period: int,
    lag: int = 1,
    n_compare: int = 3,
    scale: np.ndarray | None = None,
) -> float:
    """Largest relative difference between the last ``n_compare`` periods and those ``lag``
    periods earlier.

    Parameters
    ----------
    signals
        (n_signals, n_samples) or (n_samples,), uniformly sampled, ``samples_per_period`` samples
        per excitation period.
    samples_per_period
        Integer samples per excitation period.
    lag
        Compare with ``lag`` periods earlier.
    n_compare
        Number of trailing periods compared.
    scale
        Per-signal reference magnitude (default: each signal's peak-to-peak over the window).
        Give a common scale to signals of one kind so that one that barely moves (a blade the
        other no longer hits) is not judged on its own round-off-sized residue.

    Returns
    -------
    float
        ``max |x(t) - x(t - lag T)| / ptp(x)`` over the window, worst signal; ``inf`` if the
        record is too short.
    """
    x = np.atleast_2d(np.asarray(signals, dtype=float))
    n = int(samples_per_period)
    w = n * n_compare
    if x.shape[1] < w + lag * n:
        return float("inf")
    now = x[:, -w:]
    before = x[:, -w - lag * n : x.shape[1] - lag * n]
    span = np.ptp(now, axis=1) if scale is None else np.asarray(scale, dtype=float)
    span = np.where(span > 0, span, 1.0)
    diff = _max_abs_difference(now, before) if now.size else np.zeros(x.shape[0])
    return float(np.max(diff / span))


@njit(cache=True)
def _max_abs_difference(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``max(|a - b|, axis=1)`` without the temporaries (records of many periods are large);
    NaN propagates as in numpy."""
    out = np.zeros(a.shape[0])
    for r in range(a.shape[0]):
        worst = 0.0
        for k in range(a.shape[1]):
            d = abs(a[r, k] - b[r, k])
            if math.isnan(d):
                worst = d
                break
            worst = max(worst, d)
        out[r] = worst
    return out


def check_periodic(
    signals: np.ndarray,
    samples_per_period: int,
    tol: float = 1e-5,
    n_compare: int = 3,
    max_multiple: int = 4,
    scale: np.ndarray | None = None,
) -> Periodicity:
    """Is the tail of ``signals`` periodic with a period of ``m`` excitation periods?

    Tries ``m = 1 .. max_multiple`` in that order and returns the first that matches within
    ``tol`` (see :func:`period_mismatch`, which also explains ``scale``).
    """
    best = float("inf")
    first = float("inf")
    for m in range(1, max_multiple + 1):
        mis = period_mismatch(signals, samples_per_period, m, n_compare, scale)
        if m == 1:
            first = mis
        # a subharmonic must differ clearly from period 1: a decaying transient whose own
        # frequency is nearly commensurate with m*fe can otherwise pass the lag-m test first
        if mis <= tol and (m == 1 or first > SUBHARMONIC_DISTINCT):
            return Periodicity(True, m, mis)
        best = min(best, mis)
    return Periodicity(False, 0, best)
