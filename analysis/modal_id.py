"""Natural frequencies and damping ratios from an FRF: peak picking refined by a local SDOF fit.

Steps for each resonance (see :func:`identify_modes`):

1. **Peak picking** on ``|H|`` (:func:`pick_peaks`): local maxima whose prominence exceeds a
   threshold in dB, within an optional band.
2. **First estimates**: a parabola through ``log|H|`` at the three bins around the peak
   (:func:`parabolic_peak`) and the half-power bandwidth (:func:`half_power_damping`).
3. **Local fit** (:func:`fit_sdof`): over a few half-power bandwidths around the peak, the data are
   fitted by least squares with one mode plus a complex constant that stands for the other modes::

       H(w) = (i w)**k * A / (wn**2 - w**2 + 2 i zeta wn w) + C

   with ``k = 0, 1, 2`` for receptance, mobility, accelerance. ``A`` and ``C`` enter linearly and
   are solved for exactly at every trial ``(fn, zeta)`` (variable projection); ``fn`` and ``zeta``
   by :func:`scipy.optimize.least_squares`. The fit interpolates between grid bins, so it recovers
   a natural frequency well inside the frequency resolution.

The FRF convention is that of :mod:`analysis.frf` (``exp(+i w t)``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, signal

from analysis.frf import FRFKind

_ORDER = {"receptance": 0, "mobility": 1, "accelerance": 2}


@dataclass(frozen=True)
class IdentifiedMode:
    """One identified resonance.

    Attributes
    ----------
    frequency_hz
        Undamped natural frequency from the local fit (or the parabolic peak if the fit failed).
    damping_ratio
        Viscous damping ratio from the fit (half-power estimate if the fit failed).
    residue
        Modal constant ``A`` of the fitted term ``(i w)**k A / (wn**2 - w**2 + 2 i zeta wn w)``
        (for a receptance in m/N, ``A`` is in 1/kg: ``phi_in * phi_out`` of mass-normalised
        shapes); its sign gives the relative phase of the mode at the two points.
    peak_frequency_hz
        The grid frequency of the picked peak (before refinement).
    fit_error
        Relative RMS misfit of the local fit, ``|H - H_fit| / |H|`` over the fitted band.
    method
        ``"sdof-fit"`` or ``"parabolic"``.
    """

    frequency_hz: float
    damping_ratio: float
    residue: complex
    peak_frequency_hz: float
    fit_error: float
    method: str


def pick_peaks(
    frequency_hz: np.ndarray,
    h: np.ndarray,
    *,
    f_min: float | None = None,
    f_max: float | None = None,
    min_prominence_db: float = 6.0,
    n_peaks: int | None = None,
) -> np.ndarray:
    """Indices of resonance peaks of ``|h|``, ascending in frequency.

    Parameters
    ----------
    frequency_hz, h
        The FRF grid and values (complex or magnitude).
    f_min, f_max
        Band to search, Hz (inclusive); default the whole grid except 0 Hz.
    min_prominence_db
        Minimum prominence of a peak in dB (20 log10 |h|).
    n_peaks
        Keep only the ``n_peaks`` most prominent, then sort them by frequency.
    """
    f = np.asarray(frequency_hz, dtype=float)
    mag_db = 20.0 * np.log10(np.maximum(np.abs(h), np.finfo(float).tiny))
    lo = f > 0 if f_min is None else f >= f_min
    hi = np.ones_like(lo) if f_max is None else f <= f_max
    band = np.flatnonzero(lo & hi)
    if band.size < 3:
        return np.array([], dtype=int)
    seg = mag_db[band]
    peaks, props = signal.find_peaks(seg, prominence=min_prominence_db)
    if n_peaks is not None and peaks.size > n_peaks:
        keep = np.argsort(props["prominences"])[::-1][:n_peaks]
        peaks = np.sort(peaks[keep])
    return band[peaks]


def parabolic_peak(frequency_hz: np.ndarray, h: np.ndarray, index: int) -> float:
    """Peak frequency from a parabola through ``log|h|`` at ``index - 1, index, index + 1``."""
    f = np.asarray(frequency_hz, dtype=float)
    if index <= 0 or index >= f.size - 1:
        return float(f[index])
    ym, y0, yp = np.log(np.abs(h[index - 1 : index + 2]))
    denom = ym - 2.0 * y0 + yp
    if denom >= 0:
        return float(f[index])
    delta = 0.5 * (ym - yp) / denom
    return float(f[index] + delta * (f[index + 1] - f[index]))


def half_power_damping(frequency_hz: np.ndarray, h: np.ndarray, index: int) -> float:
    """Damping ratio from the half-power (-3 dB) bandwidth around the peak at ``index``.

    ``zeta = (f2 - f1) / (2 f_peak)`` with ``f1, f2`` linearly interpolated where ``|h|`` falls
    to ``|h_peak| / sqrt(2)``. If a side does not fall that far (too coarse a grid), the bandwidth
    is taken as one bin, a lower bound on the resolution.
    """
    f = np.asarray(frequency_hz, dtype=float)
    mag = np.abs(h)
    level = mag[index] / np.sqrt(2.0)

    def crossing(step: int) -> float | None:
        i = index
        while 0 < i < f.size - 1 and mag[i + step] > level:
            i += step
        j = i + step
        if not 0 <= j < f.size or mag[j] > level:
            return None
        frac = (mag[i] - level) / (mag[i] - mag[j])
        return float(f[i] + frac * (f[j] - f[i]))

    f1, f2 = crossing(-1), crossing(+1)
    df = float(f[1] - f[0])
    if f1 is None or f2 is None:
        width = 2.0 * (f2 - f[index]) if f2 is not None else (2.0 * (f[index] - f1) if f1 is not None else df)
    else:
        width = f2 - f1
    return max(width, df) / (2.0 * f[index])


def _sdof_basis(w: np.ndarray, wn: float, zeta: float, order: int) -> np.ndarray:
    term = (1j * w) ** order / (wn**2 - w**2 + 2j * zeta * wn * w)
    return np.column_stack([term, np.ones_like(term)])


def _solve_linear(basis: np.ndarray, h: np.ndarray, weight: np.ndarray) -> np.ndarray:
    coef, *_ = np.linalg.lstsq(basis * weight[:, None], h * weight, rcond=None)
    return coef


def fit_sdof(
    frequency_hz: np.ndarray,
    h: np.ndarray,
    index: int,
    *,
    kind: FRFKind = "accelerance",
    bandwidths: float = 2.0,
    min_bins: int = 3,
    limits: tuple[int, int] | None = None,
) -> IdentifiedMode:
    """Refine the resonance near grid ``index`` by a local single-mode fit (see module docstring).

    Parameters
    ----------
    frequency_hz, h
        The complex FRF and its grid.
    index
        Grid index of the picked peak.
    kind
        What ``h`` is: receptance, mobility or accelerance.
    bandwidths
        Half-width of the fitted band in half-power bandwidths (at least ``min_bins`` bins).
    limits
        Optional (lo, hi) index bounds the band must stay within (e.g. troughs to the neighbours).
    """
    f = np.asarray(frequency_hz, dtype=float)
    h = np.asarray(h, dtype=complex)
    order = _ORDER[kind]
    f_par = parabolic_peak(f, h, index)
    zeta0 = half_power_damping(f, h, index)
    df = f[1] - f[0]
    half = max(min_bins, int(np.ceil(bandwidths * 2.0 * zeta0 * f_par / df)))
    lo, hi = max(index - half, 1), min(index + half, f.size - 1)
    if limits is not None:
        lo, hi = max(lo, limits[0]), min(hi, limits[1])
    sel = slice(lo, hi + 1)
    w, hb = 2.0 * np.pi * f[sel], h[sel]
    # uniform absolute weights: the bins near the peak, where one mode dominates, count most
    weight = np.ones(hb.size)
    scale = np.max(np.abs(hb))

    def residual(p: np.ndarray) -> np.ndarray:
        wn, zeta = 2.0 * np.pi * p[0], np.exp(p[1])
        basis = _sdof_basis(w, wn, zeta, order)
        r = (basis @ _solve_linear(basis, hb, weight) - hb) / scale
        return np.concatenate([r.real, r.imag])

    p0 = np.array([f_par, np.log(max(zeta0, 1e-5))])
    bounds = ([f[lo], np.log(1e-6)], [f[hi], np.log(0.5)])
    p0[0] = np.clip(p0[0], f[lo] + 1e-9 * df, f[hi] - 1e-9 * df)
    if hb.size < 4:
        return IdentifiedMode(f_par, zeta0, complex("nan"), float(f[index]), float("nan"), "parabolic")
    sol = optimize.least_squares(residual, p0, bounds=bounds, x_scale=[df, 1.0])
    fn, zeta = float(sol.x[0]), float(np.exp(sol.x[1]))
    basis = _sdof_basis(w, 2.0 * np.pi * fn, zeta, order)
    coef = _solve_linear(basis, hb, weight)
    misfit = float(np.linalg.norm(basis @ coef - hb) / np.linalg.norm(hb))
    return IdentifiedMode(fn, zeta, complex(coef[0]), float(f[index]), misfit, "sdof-fit")


def identify_modes(
    frequency_hz: np.ndarray,
    h: np.ndarray,
    *,
    kind: FRFKind = "accelerance",
    f_min: float | None = None,
    f_max: float | None = None,
    min_prominence_db: float = 6.0,
    n_modes: int | None = None,
    bandwidths: float = 2.0,
) -> list[IdentifiedMode]:
    """Identify the resonances of an FRF: :func:`pick_peaks`, then :func:`fit_sdof` on each.

    Returns the modes ascending in frequency. Each local fit stays between the minima of ``|h|``
    that separate its peak from the neighbouring peaks.
    """
    f = np.asarray(frequency_hz, dtype=float)
    h = np.asarray(h, dtype=complex)
    peaks = pick_peaks(f, h, f_min=f_min, f_max=f_max, min_prominence_db=min_prominence_db, n_peaks=n_modes)
    mag = np.abs(h)
    modes = []
    for j, p in enumerate(peaks):
        lo = peaks[j - 1] + int(np.argmin(mag[peaks[j - 1] : p + 1])) if j > 0 else 1
        hi = p + int(np.argmin(mag[p : peaks[j + 1] + 1])) if j + 1 < peaks.size else f.size - 1
        modes.append(fit_sdof(f, h, int(p), kind=kind, bandwidths=bandwidths, limits=(lo, hi)))
    return modes
