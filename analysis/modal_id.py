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

The FRF convention is that of :mod:`rigtools.analysis.frf` (``exp(+i w t)``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, signal

from rigtools.analysis.frf import FRFKind

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
        Minimum prominence of a peak in dB (``20 log10 |h|``).
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

    This does not check that the data can carry modes: on the FRF of a sine dwell it returns
    peaks of noise over leakage. For measured data use :func:`identify`, which checks the
    excitation and coherence first and says why it reports nothing.
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


# ---------------------------------------------------------------------------------------------
# Identification with a data check and a stabilisation chart (LSCF poles, LSFD constants)
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ExcitationSupport:
    """Whether an FRF estimate can carry modal identification in a band.

    A bin is *supported* when the excitation auto spectrum there is within ``dynamic_range_db``
    of its largest value in the band and the coherence is at least ``min_coherence``. A sine dwell
    (or any narrow-band force) supports a handful of bins around ``fe`` only: the FRF elsewhere is
    the ratio of noise to leakage, and peaks in it are not modes.

    Attributes
    ----------
    fraction
        Supported bins / bins in the band.
    supported
        (n_freq,) bool mask over the whole grid.
    ok
        ``fraction >= min_fraction``.
    reason
        Empty if ``ok``; otherwise one sentence saying why identification was refused.
    """

    fraction: float
    supported: np.ndarray
    ok: bool
    reason: str


def excitation_support(
    frequency_hz: np.ndarray,
    excitation_psd: np.ndarray,
    coherence: np.ndarray | None = None,
    *,
    f_min: float | None = None,
    f_max: float | None = None,
    dynamic_range_db: float = 40.0,
    min_coherence: float = 0.5,
    min_fraction: float = 0.5,
) -> ExcitationSupport:
    """Check that the excitation is broadband and coherent in ``[f_min, f_max]``.

    Parameters
    ----------
    frequency_hz, excitation_psd
        The grid and the force auto spectrum ``Sxx`` of the estimate (any scaling).
    coherence
        Ordinary coherence on the same grid (optional; without it only ``Sxx`` is judged).
    f_min, f_max
        Band, Hz (default the whole grid above 0 Hz).
    dynamic_range_db, min_coherence, min_fraction
        Thresholds, see :class:`ExcitationSupport`.
    """
    f = np.asarray(frequency_hz, dtype=float)
    sxx = np.abs(np.asarray(excitation_psd, dtype=float))
    band = (f > 0 if f_min is None else f >= f_min) & (np.ones_like(f, bool) if f_max is None else f <= f_max)
    if not np.any(band):
        return ExcitationSupport(0.0, np.zeros_like(f, bool), False, "no frequency bins in the band")
    top = float(np.max(sxx[band]))
    mask = band & (sxx >= top * 10 ** (-dynamic_range_db / 10.0)) & (top > 0)
    if coherence is not None:
        mask &= np.asarray(coherence, dtype=float) >= min_coherence
    fraction = float(np.count_nonzero(mask) / np.count_nonzero(band))
    ok = fraction >= min_fraction
    reason = (
        ""
        if ok
        else (
            f"the excitation covers {fraction:.1%} of the {f[band][0]:g}-{f[band][-1]:g} Hz band "
            f"(force spectrum within {dynamic_range_db:g} dB of its peak"
            + (f" and coherence >= {min_coherence:g}" if coherence is not None else "")
            + f", need {min_fraction:.0%}): a sine dwell or narrow-band force does not determine modes"
        )
    )
    return ExcitationSupport(fraction, mask, ok, reason)


@dataclass(frozen=True)
class StabilisationChart:
    """Poles of the LSCF estimator at increasing model order, classified.

    Attributes
    ----------
    orders
        (n_poles,) model order of each pole.
    frequency_hz, damping_ratio
        (n_poles,) pole natural frequency and damping ratio.
    stable
        (n_poles,) True when a pole of the previous order lies within ``freq_tol`` (relative) in
        frequency and ``damping_tol`` (relative) in damping: "s" in a stabilisation chart.
    """

    orders: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    stable: np.ndarray


@dataclass(frozen=True)
class ModalIdentification:
    """Result of :func:`identify`.

    Attributes
    ----------
    modes
        The modes the data support, ascending in frequency (possibly empty).
    method
        ``"lscf"`` (sdypy-EMA LSCF poles, stabilisation check, LSFD constants) or ``"peak"``
        (peak picking, half-power damping refined by a local SDOF fit).
    notes
        Sentences saying why nothing or less was reported (empty when everything found was kept).
    chart
        The stabilisation chart (LSCF only).
    reconstruction
        (n_freq,) FRF rebuilt from the modes (LSCF: with LSFD lower/upper residuals), or None.
    """

    modes: list[IdentifiedMode]
    method: str
    notes: list[str]
    chart: StabilisationChart | None = None
    reconstruction: np.ndarray | None = None


def lscf_stabilisation(
    frequency_hz: np.ndarray,
    h: np.ndarray,
    *,
    kind: FRFKind,
    f_min: float,
    f_max: float,
    max_order: int = 40,
    freq_tol: float = 0.005,
    damping_tol: float = 0.05,
    max_damping: float = 0.2,
):
    """LSCF poles of ``h`` at orders 2..2*max_order (sdypy-EMA) and their stabilisation chart.

    Returns ``(model, chart)``: the :class:`sdypy.EMA.Model` (for LSFD) and a
    :class:`StabilisationChart` of the poles inside ``[f_min, f_max]`` with
    ``0 < zeta < max_damping``.
    """
    from sdypy import EMA  # imported here: it loads matplotlib.pyplot and tqdm

    f = np.asarray(frequency_hz, dtype=float)
    h = np.atleast_2d(np.asarray(h, dtype=complex))
    # LSCF leaves out the bins below f_min, but sdypy-EMA transforms the whole FRF first: a
    # receptance or mobility has nan at 0 Hz (divided by i w) and would make every pole nan
    h = np.where((f < f_min) & ~np.isfinite(h), 0.0, h)
    model = EMA.Model(frf=h, freq=f, lower=f_min, upper=f_max, pol_order_high=int(max_order), frf_form=kind)
    model.get_poles(method="lscf", show_progress=False)
    orders, fr, xi, stable = [], [], [], []
    prev_f = prev_x = np.array([])
    for j, (pf, px) in enumerate(zip(model.pole_freq, model.pole_xi, strict=True)):
        pf, px = np.asarray(pf, float), np.asarray(px, float)
        keep = np.isfinite(pf) & (pf >= f_min) & (pf <= f_max) & (px > 0) & (px < max_damping)
        pf, px = pf[keep], px[keep]
        for a, b in zip(pf, px, strict=True):
            near = (np.abs(prev_f - a) <= freq_tol * a) & (np.abs(prev_x - b) <= damping_tol * b)
            orders.append(2 * (j + 1))
            fr.append(a)
            xi.append(b)
            stable.append(bool(np.any(near)))
        prev_f, prev_x = pf, px
    chart = StabilisationChart(np.array(orders, int), np.array(fr), np.array(xi), np.array(stable, bool))
    return model, chart


def _stable_clusters(chart: StabilisationChart, freq_tol: float, min_stable: int) -> list[np.ndarray]:
    """Groups of stable poles within ``freq_tol`` of each other, with at least ``min_stable``
    members at distinct orders."""
    idx = np.flatnonzero(chart.stable)
    idx = idx[np.argsort(chart.frequency_hz[idx])]
    clusters: list[np.ndarray] = []
    current: list[int] = []
    for i in idx:
        if current and chart.frequency_hz[i] > chart.frequency_hz[current[0]] * (1 + 2 * freq_tol):
            clusters.append(np.array(current))
            current = []
        current.append(int(i))
    if current:
        clusters.append(np.array(current))
    return [c for c in clusters if np.unique(chart.orders[c]).size >= min_stable]


def identify(
    frequency_hz: np.ndarray,
    h: np.ndarray,
    *,
    kind: FRFKind = "accelerance",
    excitation_psd: np.ndarray | None = None,
    coherence: np.ndarray | None = None,
    f_min: float | None = None,
    f_max: float | None = None,
    method: str = "lscf",
    n_modes: int | None = None,
    max_order: int = 40,
    min_stable: int = 5,
    freq_tol: float = 0.005,
    damping_tol: float = 0.05,
    min_coherence: float = 0.5,
    dynamic_range_db: float = 40.0,
) -> ModalIdentification:
    """Natural frequencies and damping ratios the data support, with the reason for what is not.

    Steps:

    1. **Data check** (when ``excitation_psd`` is given, as it should be for measured FRFs):
       :func:`excitation_support`. A dwell or other narrow-band force returns no mode and a note.
    2. ``method="lscf"``: poles of sdypy-EMA's LSCF at orders 2..2*max_order;
       a pole is *stable* when the previous order has one within ``freq_tol`` in frequency and
       ``damping_tol`` in damping; a *mode* is a group of stable poles (within 2 ``freq_tol``) at
       ``min_stable`` or more orders; its frequency and damping are the medians over the group.
       LSFD (sdypy-EMA) then gives the modal constants and a reconstruction with residual terms.
       ``method="peak"``: :func:`identify_modes` (quick; no stabilisation).
    3. **Per-mode check**: a mode whose half-power band (``f (1 +- zeta)``) holds no supported bin
       (see :func:`excitation_support`) is dropped with a note.

    Parameters
    ----------
    frequency_hz, h
        One-sided grid (uniform, starting at 0 Hz or above) and complex FRF (e.g.
        :attr:`rigtools.analysis.frf.FRFEstimate.h1`).
    kind
        What ``h`` is (receptance, mobility, accelerance).
    excitation_psd, coherence
        ``FRFEstimate.sxx`` and ``.coherence`` of the estimate.
    f_min, f_max
        Band, Hz (default: the grid without 0 Hz).
    n_modes
        Keep at most this many (the most strongly stable for LSCF, the most prominent peaks
        otherwise).

    Returns
    -------
    ModalIdentification
    """
    f = np.asarray(frequency_hz, dtype=float)
    h = np.asarray(h, dtype=complex)
    f_lo = float(f[f > 0][0]) if f_min is None else float(f_min)
    f_hi = float(f[-1]) if f_max is None else float(f_max)
    notes: list[str] = []
    support = None
    if excitation_psd is not None:
        support = excitation_support(
            f,
            excitation_psd,
            coherence,
            f_min=f_lo,
            f_max=f_hi,
            dynamic_range_db=dynamic_range_db,
            min_coherence=min_coherence,
        )
        if not support.ok:
            return ModalIdentification([], method, [f"no modes identified: {support.reason}"])
    if method == "peak":
        modes = identify_modes(f, h, kind=kind, f_min=f_lo, f_max=f_hi, n_modes=n_modes)
        chart, rec = None, None
    elif method == "lscf":
        model, chart = lscf_stabilisation(
            f,
            h,
            kind=kind,
            f_min=f_lo,
            f_max=f_hi,
            max_order=max_order,
            freq_tol=freq_tol,
            damping_tol=damping_tol,
        )
        clusters = _stable_clusters(chart, freq_tol, min_stable)
        if n_modes is not None and len(clusters) > n_modes:
            clusters = sorted(
                sorted(clusters, key=len, reverse=True)[:n_modes], key=lambda c: chart.frequency_hz[c[0]]
            )
        modes, rec = _lsfd(model, chart, clusters, f, h, kind, f_lo, f_hi)
        if not clusters:
            notes.append(f"no pole stable over {min_stable} model orders between {f_lo:g} and {f_hi:g} Hz")
    else:
        raise ValueError(f"method must be 'lscf' or 'peak', got {method!r}")
    if support is not None:
        kept = []
        for m in modes:
            half = max(m.damping_ratio * m.frequency_hz, 0.5 * float(f[1] - f[0]))
            near = (f >= m.frequency_hz - half) & (f <= m.frequency_hz + half)
            if np.any(support.supported & near):
                kept.append(m)
            else:
                notes.append(
                    f"dropped {m.frequency_hz:.4g} Hz: no bin of its half-power band has coherent excitation"
                )
        modes = kept
    return ModalIdentification(modes, method, notes, chart, rec)


def _lsfd(model, chart, clusters, f, h, kind, f_lo, f_hi):
    """Modal constants of the chosen poles by sdypy-EMA's LSFD; one IdentifiedMode per cluster."""
    if not clusters:
        return [], None
    pole_ind, medians = [], []
    for c in clusters:
        fn = float(np.median(chart.frequency_hz[c]))
        zeta = float(np.median(chart.damping_ratio[c]))
        medians.append((fn, zeta))
        top = int(chart.orders[c].max())
        j = top // 2 - 1
        pf = np.asarray(model.pole_freq[j])
        i = int(np.nanargmin(np.abs(pf - chart.frequency_hz[c][chart.orders[c] == top][0])))
        pole_ind.append([j, i])
    model.pole_ind = np.asarray(pole_ind, dtype=int)
    rec, consts = model.get_constants(method="lsfd", f_lower=f_lo, f_upper=min(f_hi, float(model.freq[-1])))
    rec = np.asarray(rec)[0]
    band = (f >= f_lo) & (f <= f_hi)
    n = min(rec.size, f.size)
    err = float(np.linalg.norm(rec[:n][band[:n]] - h[:n][band[:n]]) / np.linalg.norm(h[:n][band[:n]]))
    modes = []
    for (fn, zeta), (j, i), a in zip(medians, pole_ind, np.asarray(consts)[0], strict=True):
        pole = model.all_poles[j][i]
        wd = abs(pole.imag)
        # sdypy's term A / (i w - s) + conj: the single-mode form (i w)^k R / (wn^2 - w^2 + 2 i zeta wn w)
        # has R = 2 i w_d A
        modes.append(IdentifiedMode(fn, zeta, complex(2j * wd * a), float(fn), err, "lscf"))
    return modes, rec
