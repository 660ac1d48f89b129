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

from dataclasses import dataclass, field, replace

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
        ``"sdof-fit"``, ``"parabolic"`` or ``"lscf"``.
    orders_stable
        LSCF: number of model orders at which the pole is stable (frequency and damping).
    frequency_spread, damping_spread
        LSCF: relative spread (max - min) / median over those orders.
    coherence
        Coherence at the peak the mode explains (NaN when unknown).
    peak_db
        Prominence of that peak of ``|H|`` in dB (NaN when unknown).
    """

    frequency_hz: float
    damping_ratio: float
    residue: complex
    peak_frequency_hz: float
    fit_error: float
    method: str
    orders_stable: int = 0
    frequency_spread: float = float("nan")
    damping_spread: float = float("nan")
    coherence: float = float("nan")
    peak_db: float = float("nan")

    def evidence(self) -> dict:
        """The evidence for this mode, plain Python (``--json``)."""
        return {
            "orders_stable": self.orders_stable,
            "frequency_spread": self.frequency_spread,
            "damping_spread": self.damping_spread,
            "peak_hz": self.peak_frequency_hz,
            "peak_prominence_db": self.peak_db,
            "coherence": self.coherence,
        }


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
        The modes the data support, ascending in frequency (possibly empty); each carries its
        evidence (:meth:`IdentifiedMode.evidence`).
    method
        ``"lscf"`` (sdypy-EMA LSCF poles, stabilisation check, LSFD constants) or ``"peak"``
        (peak picking, half-power damping refined by a local SDOF fit).
    notes
        Sentences saying why nothing or less was reported (at most one line on what was dropped).
    chart
        The stabilisation chart (LSCF only).
    reconstruction
        (n_freq,) FRF rebuilt from the modes (LSCF: with LSFD lower/upper residuals), or None.
    band
        ``(f_min, f_max)`` identified in, Hz.
    dropped
        Candidates not reported: ``{"frequency_hz", "damping_ratio", "reason"}`` each.
    """

    modes: list[IdentifiedMode]
    method: str
    notes: list[str]
    chart: StabilisationChart | None = None
    reconstruction: np.ndarray | None = None
    band: tuple[float, float] | None = None
    dropped: list[dict] = field(default_factory=list)


def excitation_band(
    frequency_hz: np.ndarray, excitation_psd: np.ndarray, *, drop_db: float = 20.0
) -> tuple[float, float]:
    """The band where the force has energy: where its auto spectrum (smoothed over 1 % of the
    bins) is within ``drop_db`` of its plateau (the 90th percentile of the level) and above its
    noise floor (the 5th percentile) by 6 dB or more. The band is the contiguous run of such
    bins around the plateau's strongest bin, never below the second bin (the first above 0 Hz).

    A hammer's spectrum rolls off above about 1 / pulse duration; a shaker's random or chirp
    signal stops at its programmed band: either way the FRF outside is noise over noise.
    """
    f = np.asarray(frequency_hz, dtype=float)
    sxx = np.abs(np.asarray(excitation_psd, dtype=float))
    pos = np.flatnonzero(f > 0)
    if pos.size < 3:
        return float(f[0]), float(f[-1])
    level = 10.0 * np.log10(np.maximum(sxx[pos], np.finfo(float).tiny))
    k = max(1, pos.size // 100)
    smooth = np.convolve(level, np.ones(k) / k, mode="same")
    plateau, floor = np.percentile(smooth, 90), np.percentile(smooth, 5)
    threshold = max(plateau - drop_db, floor + 6.0) if plateau - floor > 6.0 else -np.inf
    good = smooth >= threshold
    top = int(np.argmax(np.where(good, smooth, -np.inf)))
    lo = top
    while lo > 0 and good[lo - 1]:
        lo -= 1
    hi = top
    while hi < pos.size - 1 and good[hi + 1]:
        hi += 1
    lo = max(lo, 1) if pos.size > 2 else lo
    return float(f[pos[lo]]), float(f[pos[hi]])


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
    """Groups of stable poles: sorted by frequency, a new group starts where the gap to the next
    stable pole exceeds ``freq_tol`` (relative); a group counts with poles at ``min_stable`` or
    more distinct orders."""
    idx = np.flatnonzero(chart.stable)
    idx = idx[np.argsort(chart.frequency_hz[idx])]
    clusters: list[np.ndarray] = []
    current: list[int] = []
    for i in idx:
        if current and chart.frequency_hz[i] > chart.frequency_hz[current[-1]] * (1 + freq_tol):
            clusters.append(np.array(current))
            current = []
        current.append(int(i))
    if current:
        clusters.append(np.array(current))
    return [c for c in clusters if np.unique(chart.orders[c]).size >= min_stable]


def _peaks(
    f: np.ndarray, h: np.ndarray, f_lo: float, f_hi: float, min_db: float
) -> tuple[np.ndarray, np.ndarray]:
    """Indices and prominences (dB) of the local maxima of ``|h|`` in the band."""
    mag_db = 20.0 * np.log10(np.maximum(np.abs(h), np.finfo(float).tiny))
    band = np.flatnonzero((f >= f_lo) & (f <= f_hi) & np.isfinite(mag_db))
    if band.size < 3:
        return np.array([], int), np.array([])
    idx, props = signal.find_peaks(mag_db[band], prominence=min_db)
    return band[idx], np.asarray(props["prominences"])


def _explained_peak(f: np.ndarray, peaks: np.ndarray, prom: np.ndarray, fn: float, zeta: float) -> int | None:
    """Position in ``peaks`` of the peak a mode at ``fn`` explains: the most prominent peak within
    its half-power band (at least two bins either side), else None."""
    df = float(f[1] - f[0])
    half = max(2.0 * zeta * fn, 2.0 * df)
    near = np.flatnonzero(np.abs(f[peaks] - fn) <= half)
    return None if near.size == 0 else int(near[np.argmax(prom[near])])


def _judge(
    candidates: list[IdentifiedMode],
    f: np.ndarray,
    h: np.ndarray,
    coherence: np.ndarray | None,
    f_lo: float,
    f_hi: float,
    *,
    max_damping: float,
    min_coherence: float,
    min_peak_db: float,
    max_frequency_spread: float,
) -> tuple[list[IdentifiedMode], list[dict]]:
    """Keep the candidates with physical damping, inside the band, that explain a peak of |h| with
    coherent excitation (one candidate per peak: the one stable at most orders)."""
    peaks, prom = _peaks(f, h, f_lo, f_hi, min_peak_db)
    kept: dict[int, IdentifiedMode] = {}
    dropped: list[dict] = []

    def drop(m: IdentifiedMode, reason: str) -> None:
        dropped.append({"frequency_hz": m.frequency_hz, "damping_ratio": m.damping_ratio, "reason": reason})

    # reasons start with a fixed phrase (the summary counts by it), details follow after ": "

    for m in candidates:
        if not f_lo <= m.frequency_hz <= f_hi:
            drop(m, "outside the band")
            continue
        if not 0.0 < m.damping_ratio <= max_damping:
            drop(m, f"damping out of bounds: {m.damping_ratio:.3g} not in (0, {max_damping:g}]")
            continue
        if m.frequency_spread > max_frequency_spread:
            drop(
                m,
                f"frequency not steady: {m.frequency_spread:.2%} over the orders (> {max_frequency_spread:.2%})",
            )
            continue
        j = _explained_peak(f, peaks, prom, m.frequency_hz, m.damping_ratio)
        if j is None:
            drop(m, f"no peak of |H|: none of {min_peak_db:g} dB prominence within its half-power band")
            continue
        i = int(peaks[j])
        coh = float(coherence[i]) if coherence is not None else float("nan")
        if coherence is not None and np.isfinite(coh) and coh < min_coherence:
            drop(m, f"incoherent: coherence {coh:.2f} at its peak (< {min_coherence:g})")
            continue
        m = replace(m, peak_frequency_hz=float(f[i]), coherence=coh, peak_db=float(prom[j]))
        other = kept.get(j)
        if other is not None:
            loser = m if other.orders_stable >= m.orders_stable else other
            drop(loser, f"second pole of a peak: {f[i]:.4g} Hz")
            if loser is other:
                kept[j] = m
            continue
        kept[j] = m
    modes = sorted(kept.values(), key=lambda m: m.frequency_hz)
    return modes, dropped


def _dropped_summary(dropped: list[dict]) -> str:
    """At most one line on the candidates not reported."""
    if not dropped:
        return ""
    counts: dict[str, int] = {}
    for d in dropped:
        key = d["reason"].split(":")[0]
        counts[key] = counts.get(key, 0) + 1
    parts = ", ".join(f"{n} {k}" for k, n in sorted(counts.items(), key=lambda kv: -kv[1]))
    return f"{len(dropped)} candidate(s) not reported ({parts}); details with --json"


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
    max_damping: float = 0.1,
    min_coherence: float = 0.5,
    min_peak_db: float = 3.0,
    max_frequency_spread: float = 0.002,
    dynamic_range_db: float = 40.0,
) -> ModalIdentification:
    """Natural frequencies and damping ratios the data support, with the reason for what is not.

    Steps:

    1. **Band**: ``[f_min, f_max]`` when given; else, with ``excitation_psd``, where the force
       has energy (:func:`excitation_band`); else the grid above 0 Hz.
    2. **Data check** (when ``excitation_psd`` is given, as it should be for measured FRFs):
       :func:`excitation_support`. A dwell or other narrow-band force returns no mode and a note.
    3. **Candidates**. ``method="lscf"``: poles of sdypy-EMA's LSCF at orders 2..2*max_order;
       a pole is *stable* when the previous order has one within ``freq_tol`` in frequency and
       ``damping_tol`` in damping; a candidate is a group of stable poles (no gap over ``freq_tol``)
       at ``min_stable`` or more orders; its frequency and damping are those of its pole at the
       highest order (the spreads over the group are its evidence).
       LSFD (sdypy-EMA) gives the modal constants of the modes kept. ``method="peak"``:
       :func:`identify_modes` (peak picking and local SDOF fits; no stabilisation).
    4. **Judgement** of each candidate: damping ratio in ``(0, max_damping]``, inside the band,
       frequency steady over the stable orders (spread at most ``max_frequency_spread``),
       explaining a peak of ``|H|`` (prominence ``min_peak_db``, within its half-power band) whose
       coherence is at least ``min_coherence``; one mode per peak. Dropped candidates are listed
       in :attr:`ModalIdentification.dropped` and summarised in one note.

    Parameters
    ----------
    frequency_hz, h
        One-sided grid (uniform, starting at 0 Hz or above) and complex FRF (e.g.
        :attr:`rigtools.analysis.frf.FRFEstimate.h1`).
    kind
        What ``h`` is (receptance, mobility, accelerance).
    excitation_psd, coherence
        ``FRFEstimate.sxx`` and ``.coherence`` of the estimate (coherence None for one average).
    f_min, f_max
        Band, Hz.
    n_modes
        Keep at most this many (the most strongly stable for LSCF, the most prominent peaks
        otherwise).

    Returns
    -------
    ModalIdentification
    """
    f = np.asarray(frequency_hz, dtype=float)
    h = np.asarray(h, dtype=complex)
    if coherence is not None and not np.any(np.isfinite(coherence)):
        coherence = None
    auto_lo, auto_hi = float(f[f > 0][0]), float(f[-1])
    if excitation_psd is not None and (f_min is None or f_max is None):
        auto_lo, auto_hi = excitation_band(f, excitation_psd)
    f_lo = auto_lo if f_min is None else float(f_min)
    f_hi = auto_hi if f_max is None else float(f_max)
    if not f_hi > f_lo:
        raise ValueError(f"band {f_lo:g}-{f_hi:g} Hz is empty")
    band = (f_lo, f_hi)
    notes: list[str] = []
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
            return ModalIdentification([], method, [f"no modes identified: {support.reason}"], band=band)
    chart, rec, model = None, None, None
    if method == "peak":
        candidates = identify_modes(f, h, kind=kind, f_min=f_lo, f_max=f_hi, min_prominence_db=min_peak_db)
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
            max_damping=1.0,
        )
        candidates = []
        for c in _stable_clusters(chart, freq_tol, min_stable):
            fr, xi = chart.frequency_hz[c], chart.damping_ratio[c]
            # the pole of the highest stable order: the most converged model (the spreads below
            # say how much the lower orders differ)
            top = int(np.argmax(chart.orders[c]))
            fn, zeta = float(fr[top]), float(xi[top])
            candidates.append(
                IdentifiedMode(
                    fn,
                    zeta,
                    complex("nan"),
                    fn,
                    float("nan"),
                    "lscf",
                    orders_stable=int(np.unique(chart.orders[c]).size),
                    frequency_spread=float(np.ptp(fr) / np.median(fr)),
                    damping_spread=float(np.ptp(xi) / np.median(xi)) if np.median(xi) > 0 else float("nan"),
                )
            )
        if not candidates:
            notes.append(f"no pole stable over {min_stable} model orders between {f_lo:g} and {f_hi:g} Hz")
    else:
        raise ValueError(f"method must be 'lscf' or 'peak', got {method!r}")
    modes, dropped = _judge(
        candidates,
        f,
        h,
        coherence,
        f_lo,
        f_hi,
        max_damping=max_damping,
        min_coherence=min_coherence,
        min_peak_db=min_peak_db,
        max_frequency_spread=max_frequency_spread,
    )
    if n_modes is not None and len(modes) > n_modes:
        key = (lambda m: m.orders_stable) if method == "lscf" else (lambda m: m.peak_db)
        keep = sorted(modes, key=key, reverse=True)[:n_modes]
        for m in modes:
            if m not in keep:
                dropped.append(
                    {
                        "frequency_hz": m.frequency_hz,
                        "damping_ratio": m.damping_ratio,
                        "reason": f"beyond n_modes: {n_modes}",
                    }
                )
        modes = sorted(keep, key=lambda m: m.frequency_hz)
    if model is not None and chart is not None and modes:
        modes, rec = _lsfd(model, modes, f, h, f_lo, f_hi)
    summary = _dropped_summary(dropped)
    if summary:
        notes.append(summary)
    return ModalIdentification(modes, method, notes, chart, rec, band, dropped)


def _lsfd(model, modes: list[IdentifiedMode], f, h, f_lo, f_hi):
    """Modal constants of the kept modes by sdypy-EMA's LSFD (the pole of the highest order
    closest to each mode)."""
    pole_ind = []
    for m in modes:
        best = None
        for j in range(len(model.all_poles) - 1, -1, -1):
            pf = np.asarray(model.pole_freq[j], dtype=float)
            if pf.size and np.any(np.isfinite(pf)):
                i = int(np.nanargmin(np.abs(pf - m.frequency_hz)))
                if abs(pf[i] - m.frequency_hz) <= 0.01 * m.frequency_hz:
                    best = [j, i]
                    break
        if best is None:
            return modes, None
        pole_ind.append(best)
    model.pole_ind = np.asarray(pole_ind, dtype=int)
    rec, consts = model.get_constants(method="lsfd", f_lower=f_lo, f_upper=min(f_hi, float(model.freq[-1])))
    rec = np.asarray(rec)[0]
    band = (f >= f_lo) & (f <= f_hi)
    n = min(rec.size, f.size)
    err = float(np.linalg.norm(rec[:n][band[:n]] - h[:n][band[:n]]) / np.linalg.norm(h[:n][band[:n]]))
    out = []
    for m, (j, i), a in zip(modes, pole_ind, np.asarray(consts)[0], strict=True):
        wd = abs(model.all_poles[j][i].imag)
        # sdypy's term A / (i w - s) + conj: the single-mode form (i w)^k R / (wn^2 - w^2 + 2 i zeta wn w)
        # has R = 2 i w_d A
        out.append(replace(m, residue=complex(2j * wd * a), fit_error=err))
    return out, rec
