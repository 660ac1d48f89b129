"""Harmonic tones in response-only records: a rotor's or a drive's lines are not modes.

An operating machine puts sharp lines into its own response (the rotor harmonics 1P, 3P, 6P of a
wind turbine, a motor's shaft order, mains hum). Subspace and frequency-domain identification
explain each such line with a pole of near-zero damping, stable at every model order and with a
rank-one shape: to a stabilisation chart it looks like the best mode of all. The OMA literature
separates them by what a resonance driven by random forces is and a tone is not (Brincker,
Andersen and Møller 2000, "An indicator for separation of structural and harmonic modes in
output-only modal testing"; Jacobsen, Andersen and Brincker 2006; Mohanty and Rixen 2004):

- **probability density** (:func:`band_kurtosis`): the response of a mode to broadband random
  load, band-pass filtered around its frequency, is Gaussian (kurtosis 3); a sine of steady
  amplitude is not (kurtosis 1.5; a sine of power ``P`` in Gaussian noise of power ``s``:
  ``(1.5 P^2 + 6 P s + 3 s^2) / (P + s)^2``).
- **damping**: a tone's pole has a damping ratio near zero (the line is as sharp as the record
  allows), a mode's that of the structure;
- **harmonic family** (:func:`harmonic_family`): tones of one shaft fall on integer multiples of
  one fundamental (the shaft speed; given as ``fe``, or found from the sharp lines themselves).

These tests use arrays only; :mod:`rigtools.analysis.oma` applies them to its candidate modes.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import signal

GAUSSIAN_KURTOSIS = 3.0
SINE_KURTOSIS = 1.5
MIN_BT = 25.0  # bandwidth x seconds below which the kurtosis is not judged


def band_kurtosis(x: np.ndarray, sample_rate: float, f_lo: float, f_hi: float) -> tuple[float, float]:
    """Kurtosis (3 for a Gaussian signal, 1.5 for a sine) of ``x`` band-pass filtered to
    ``[f_lo, f_hi]`` Hz, and its standard error for a Gaussian signal of that bandwidth.

    The filter is a zero-phase 4th-order Butterworth band-pass; the first and last
    ``4 / (f_hi - f_lo)`` seconds (the filter's settling) are left out. The kurtosis of a
    narrow-band signal depends on its envelope alone, which changes over ``1 / B`` seconds
    (``B = f_hi - f_lo``), so the estimate's spread for Gaussian data falls as ``1 / sqrt(B T)``
    over the ``T`` seconds kept: the standard error returned is ``sqrt(8 / (B T))``, fitted to
    simulated band-limited white noise (200 records at each of ``B T`` = 30, 60, 200, 600: the
    measured spread 0.45, 0.36, 0.18, 0.09 against 0.52, 0.37, 0.20, 0.12 returned).

    Parameters
    ----------
    x
        (N,) samples.
    sample_rate
        Hz.
    f_lo, f_hi
        Band edges, Hz, ``0 < f_lo < f_hi < sample_rate / 2``.

    Returns
    -------
    (kurtosis, standard error)
        NaN, NaN when ``B T`` is below :data:`MIN_BT` (the estimate is biased low there: its
        mean is 2.83 at ``B T = 30``).
    """
    nyq = sample_rate / 2
    if not 0 < f_lo < f_hi < nyq:
        raise ValueError(f"band {f_lo:g}-{f_hi:g} Hz must lie inside 0-{nyq:g} Hz")
    sos = signal.butter(4, [f_lo / nyq, f_hi / nyq], btype="bandpass", output="sos")
    z = signal.sosfiltfilt(sos, np.asarray(x, dtype=float))
    edge = int(np.ceil(4.0 / (f_hi - f_lo) * sample_rate))
    z = z[edge : z.size - edge]
    bt = (f_hi - f_lo) * z.size / sample_rate
    if bt < MIN_BT:
        return float("nan"), float("nan")
    z = z - z.mean()
    m2 = float(np.mean(z**2))
    if m2 <= 0:
        return float("nan"), float("nan")
    return float(np.mean(z**4) / m2**2), float(np.sqrt(8.0 / bt))


def harmonic_family(
    frequencies_hz: Sequence[float],
    tolerance_hz: float,
    *,
    fundamental_hz: float | None = None,
    min_members: int = 3,
) -> tuple[float | None, list[int | None]]:
    """Integer multiples of one fundamental among ``frequencies_hz``.

    Parameters
    ----------
    frequencies_hz
        Candidate line frequencies (the sharp ones).
    tolerance_hz
        How far a line may sit from ``k f0`` (half a line of the averaged spectrum), the same
        for every ``k`` (a tolerance growing with ``k`` lets a low sub-multiple explain any
        line).
    fundamental_hz
        The shaft or drive frequency when known (``fe``); else each line and its integer
        fractions ``f / 2 .. f / 6`` are tried, and the one that puts the most lines on its
        multiples (at least ``min_members``; the highest fundamental among equals: 3P rather
        than 1P when only 3P's multiples are there) is taken.
    min_members
        Lines a found fundamental must explain.

    Returns
    -------
    (f0, k)
        The fundamental (None when none explains ``min_members`` lines) and, per line, its
        multiple ``k`` (None for a line off the family).
    """
    f = np.asarray(frequencies_hz, dtype=float)
    if f.size == 0:
        return fundamental_hz, []

    def multiples(f0: float) -> list[int | None]:
        k = np.rint(f / f0)
        ok = (k >= 1) & (np.abs(f - k * f0) <= tolerance_hz)
        return [int(j) if o else None for j, o in zip(k, ok, strict=True)]

    if fundamental_hz is not None:
        return fundamental_hz, multiples(fundamental_hz)
    best: tuple[int, float] = (0, 0.0)
    for line in f:
        for div in range(1, 7):
            f0 = line / div
            if f0 <= 2 * tolerance_hz:
                continue
            count = sum(k is not None for k in multiples(f0))
            if count > best[0] or (count == best[0] and f0 > best[1]):
                best = (count, f0)
    if best[0] < min_members:
        return None, [None] * f.size
    # refine the fundamental on its members (least squares of f = k f0)
    ks = multiples(best[1])
    kk = np.array([k for k in ks if k is not None], dtype=float)
    ff = np.array([x for x, k in zip(f, ks, strict=True) if k is not None])
    f0 = float(kk @ ff / (kk @ kk))
    return f0, multiples(f0)
