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

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import optimize, signal

from rigtools.analysis.frf import FRFKind
from rigtools.analysis.stabilisation import StabilisationChart, converged_selection
from rigtools.sim.threads import single_blas_thread

_ORDER = {"receptance": 0, "mobility": 1, "accelerance": 2}
#: Fewest FRF lines in an identification band (with 3 the LSCF's least squares are singular).
MIN_BAND_LINES = 5


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
    orders_stable, orders_judged
        LSCF: converged model orders with a stable pole that explains the peak / converged
        orders judged (:mod:`rigtools.analysis.stabilisation`).
    frequency_spread, damping_spread
        LSCF: interquartile range / median over those poles.
    coherence
        LSCF: lowest coherence over its half-power band (NaN when unknown).
    peak_db
        Prominence of the peak of ``|H|`` it explains, dB (NaN when unknown).
    mac_min
        LSCF with several responses: lowest MAC of its poles' shapes between consecutive orders.
    shape
        LSCF: the residue (as ``residue``) at every response, in the order of the FRF's rows.
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
    orders_judged: int = 0
    mac_min: float = float("nan")
    shape: tuple[complex, ...] = ()

    def evidence(self) -> dict:
        """The evidence for this mode, plain Python (``--json``)."""
        return {
            "orders_stable": self.orders_stable,
            "orders_judged": self.orders_judged,
            "frequency_spread": self.frequency_spread,
            "damping_spread": self.damping_spread,
            "peak_hz": self.peak_frequency_hz,
            "peak_prominence_db": self.peak_db,
            "coherence": self.coherence,
            "mac_min": self.mac_min,
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

    Examples
    --------
    The accelerance of a unit-mass oscillator of 80 Hz, 2 % damped:

    >>> import numpy as np
    >>> from rigtools.analysis.modal_id import identify_modes
    >>> f = np.linspace(0.0, 200.0, 2001)
    >>> w, wn, zeta = 2 * np.pi * f, 2 * np.pi * 80.0, 0.02
    >>> h = -(w**2) / (wn**2 - w**2 + 2j * zeta * wn * w)
    >>> (mode,) = identify_modes(f, h, kind="accelerance")
    >>> round(mode.frequency_hz, 3), round(mode.damping_ratio, 5)
    (80.0, 0.02)
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
    no_mode
        Empty when a mode was found; else one sentence: what was tried and what would help
        (``--json`` carries it, so a script can test for an empty result).
    tried
        What the identification tried (LSCF: the band's lines and peaks, the orders and the
        stability tolerances, :class:`rigtools.analysis.stabilisation.BandSchedule`), plain Python.
    """

    modes: list[IdentifiedMode]
    method: str
    notes: list[str]
    chart: StabilisationChart | None = None
    reconstruction: np.ndarray | None = None
    band: tuple[float, float] | None = None
    dropped: list[dict] = field(default_factory=list)
    no_mode: str = ""
    tried: dict = field(default_factory=dict)


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
    orders: Sequence[int] | None = None,
    freq_tol: float = 0.001,
    damping_tol: float = 0.05,
    min_mac: float = 0.9,
    max_damping: float = 0.1,
    min_coherence: float = 0.9,
    min_peak_db: float = 3.0,
    dynamic_range_db: float = 40.0,
) -> ModalIdentification:
    """Natural frequencies and damping ratios the data support, with the reason for what is not.

    Steps:

    1. **Band**: ``[f_min, f_max]`` when given; else, with ``excitation_psd``, where the force
       has energy (:func:`excitation_band`); else the grid above 0 Hz.
    2. **Data check** (when ``excitation_psd`` is given, as it should be for measured FRFs):
       :func:`excitation_support`. A dwell or other narrow-band force returns no mode and a note.
    3. ``method="lscf"``: :func:`rigtools.analysis.stabilisation.converged_selection`. Poles of
       sdypy-EMA's LSCF are *stable* when the previous order has one within ``freq_tol`` in
       frequency and ``damping_tol`` in damping (and, with several responses, a shape with a MAC
       of at least ``min_mac``); over the converged orders (the upper half of each highest order
       in ``orders``, the first whose set of modes the next repeats), a peak of ``|H|`` (prominence
       ``min_peak_db``) is a mode when a stable pole with damping in ``(0, max_damping]`` has it
       in its half-power band at half those orders or more and the coherence over its
       half-power band is at least ``min_coherence``; frequency and damping are the medians over
       those orders. LSFD (sdypy-EMA) gives the modal constants of the modes kept.
       ``method="peak"``: :func:`identify_modes` (peak picking and local SDOF fits), kept with
       damping in ``(0, max_damping]`` and the same coherence check.
    4. Candidates not reported are listed in :attr:`ModalIdentification.dropped` with the reason
       and summarised in one note.

    Parameters
    ----------
    frequency_hz, h
        One-sided grid (uniform, starting at 0 Hz or above) and complex FRF (e.g.
        :attr:`rigtools.analysis.frf.FRFEstimate.h1`): (n_freq,), or (n_responses, n_freq) of
        one reference identified together (LSCF; a mode's ``shape`` holds its residue at each).
    kind
        What ``h`` is (receptance, mobility, accelerance).
    excitation_psd, coherence
        ``FRFEstimate.sxx`` and ``.coherence`` of the estimate (coherence None for one average).
    f_min, f_max
        Band, Hz.
    n_modes
        Keep at most this many (the most strongly stable for LSCF, the most prominent peaks
        otherwise).
    orders
        Highest LSCF orders tried (sdypy-EMA ``pol_order_high``); default
        :data:`rigtools.analysis.stabilisation.ORDERS`. They and ``freq_tol``, ``damping_tol``
        follow the band's lines (:func:`rigtools.analysis.stabilisation.band_schedule`).

    Returns
    -------
    ModalIdentification
    """
    f = np.asarray(frequency_hz, dtype=float)
    h2 = np.atleast_2d(np.asarray(h, dtype=complex))
    if coherence is not None and not np.any(np.isfinite(coherence)):
        coherence = None
    coh2 = None if coherence is None else np.atleast_2d(np.asarray(coherence, dtype=float))
    band, lines = _checked_band(f, f_min, f_max, excitation_psd)
    f_lo, f_hi = band
    if excitation_psd is not None:
        support = excitation_support(
            f,
            excitation_psd,
            None if coh2 is None else np.max(coh2, axis=0),
            f_min=f_lo,
            f_max=f_hi,
            dynamic_range_db=dynamic_range_db,
        )
        if not support.ok:
            reason = f"no modes identified: {support.reason}"
            return ModalIdentification([], method, [reason], band=band, no_mode=reason)
    chart, rec = None, None
    notes: list[str] = []
    tried: dict = {"lines": lines}
    if method == "peak":
        if h2.shape[0] != 1:
            raise ValueError("method 'peak' identifies one FRF at a time")
        modes, dropped = _judge_peaks(
            identify_modes(f, h2[0], kind=kind, f_min=f_lo, f_max=f_hi, min_prominence_db=min_peak_db),
            f,
            None if coh2 is None else coh2[0],
            max_damping=max_damping,
            min_coherence=min_coherence,
        )
    elif method == "lscf":
        sel = converged_selection(
            f,
            h2,
            kind=kind,
            band=band,
            coherence=coh2,
            orders=orders,
            freq_tol=freq_tol,
            damping_tol=damping_tol,
            min_mac=min_mac,
            max_damping=max_damping,
            min_coherence=min_coherence,
            min_peak_db=min_peak_db,
        )
        modes, dropped, chart, tried, notes = _lscf_modes(sel, tried)
    else:
        raise ValueError(f"method must be 'lscf' or 'peak', got {method!r}")
    if n_modes is not None and len(modes) > n_modes:
        modes, chart = _keep_strongest(modes, dropped, chart, n_modes, method)
    if method == "lscf" and modes:
        modes, rec = _lsfd(modes, f, h2, kind, f_lo, f_hi)
    no_mode = "" if modes else no_mode_reason(method, band, tried, dropped, chart)
    if no_mode:
        notes.append(no_mode)
    summary = _dropped_summary(dropped)
    if summary:
        notes.append(summary)
    return ModalIdentification(modes, method, notes, chart, rec, band, dropped, no_mode, tried)


def _checked_band(
    f: np.ndarray, f_min: float | None, f_max: float | None, excitation_psd: np.ndarray | None
) -> tuple[tuple[float, float], int]:
    """``((f_lo, f_hi), lines)``: the band identified over (given, else where the force has energy,
    else the grid above 0 Hz), cut to the grid, and its number of lines; a ``ValueError`` for an
    empty band or one of fewer than :data:`MIN_BAND_LINES` lines."""
    auto_lo, auto_hi = float(f[f > 0][0]), float(f[-1])
    if excitation_psd is not None and (f_min is None or f_max is None):
        auto_lo, auto_hi = excitation_band(f, excitation_psd)
    f_lo = auto_lo if f_min is None else float(f_min)
    f_hi = auto_hi if f_max is None else float(f_max)
    if not f_hi > f_lo:
        raise ValueError(f"band {f_lo:g}-{f_hi:g} Hz is empty")
    # a band reaching past the grid is the grid's part of it; one holding too few lines is
    # refused (the LSCF's least squares are singular on it)
    f_lo, f_hi = max(f_lo, float(f[f > 0][0])), min(f_hi, float(f[-1]))
    lines = int(np.count_nonzero((f >= f_lo) & (f <= f_hi)))
    if lines < MIN_BAND_LINES:
        asked = f"{f_min if f_min is not None else f_lo:g}-{f_max if f_max is not None else f_hi:g} Hz"
        raise ValueError(
            f"band {asked} holds {lines} of the FRF's lines ({f[0]:g}-{f[-1]:g} Hz, every "
            f"{f[1] - f[0]:g} Hz): give one over at least {MIN_BAND_LINES} lines"
        )
    return (f_lo, f_hi), lines


def _lscf_modes(
    sel, tried: dict
) -> tuple[list[IdentifiedMode], list[dict], StabilisationChart, dict, list[str]]:
    """``(modes, dropped, chart, tried, notes)`` of a
    :func:`~rigtools.analysis.stabilisation.converged_selection` (modal constants still to fit)."""
    notes: list[str] = []
    if sel.schedule is not None:
        tried = {
            "lines": sel.schedule.lines,
            "peaks": sel.schedule.peaks,
            "orders": list(sel.schedule.orders),
            "freq_tol": sel.schedule.freq_tol,
            "damping_tol": sel.schedule.damping_tol,
        }
    modes = [
        IdentifiedMode(
            m.frequency_hz,
            m.damping_ratio,
            complex("nan"),
            m.peak_hz,
            float("nan"),
            "lscf",
            orders_stable=m.orders_stable,
            frequency_spread=m.frequency_spread,
            damping_spread=m.damping_spread,
            coherence=m.coherence,
            peak_db=m.peak_db,
            orders_judged=m.orders_judged,
            mac_min=m.mac_min,
        )
        for m in sel.modes
    ]
    if not sel.converged:
        notes.append(
            f"the set of modes still changed at LSCF order {2 * sel.order} (the highest tried): "
            f"modes from orders {sel.chart.judged[0]}-{sel.chart.judged[1]}"
        )
    return modes, sel.dropped, sel.chart, tried, notes


def _keep_strongest(
    modes: list[IdentifiedMode],
    dropped: list[dict],
    chart: StabilisationChart | None,
    n_modes: int,
    method: str,
) -> tuple[list[IdentifiedMode], StabilisationChart | None]:
    """The ``n_modes`` most strongly stable (LSCF) or most prominent (peak) modes in ascending
    frequency, the others added to ``dropped``; the chart renumbered to the modes kept."""
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
    kept = sorted(keep, key=lambda m: m.frequency_hz)
    if chart is not None and chart.mode is not None:
        # the chart marks the poles of the modes reported, numbered as reported
        index = {i: kept.index(m) for i, m in enumerate(modes) if m in keep}
        chart = replace(chart, mode=np.array([index.get(int(k), -1) for k in chart.mode], int))
    return kept, chart


def no_mode_reason(
    method: str,
    band: tuple[float, float],
    tried: dict,
    dropped: list[dict],
    chart: StabilisationChart | None,
) -> str:
    """One sentence for an identification that found no mode: what was tried, why nothing
    passed and what would help.

    Examples
    --------
    >>> no_mode_reason("lscf", (50.0, 60.0), {"lines": 21, "peaks": 0}, [], None)
    'no mode between 50 and 60 Hz: the band (21 lines) holds no peak of |H| of 3 dB; a band around a resonance peak would help'
    """
    where = f"no mode between {band[0]:g} and {band[1]:g} Hz"
    lines = tried.get("lines")
    if tried.get("peaks") == 0 or (method == "peak" and not dropped):
        return f"{where}: the band ({lines} lines) holds no peak of |H| of 3 dB; a band around a resonance peak would help"
    if dropped and all(d["reason"].startswith("incoherent") for d in dropped):
        return (
            f"{where}: every candidate's coherence is too low over its half-power band; more averages "
            "(or a cleaner force) would help"
        )
    if method == "peak":
        return f"{where}: no peak with damping in bounds and coherent data; --method lscf or a finer FRF would help"
    orders = ", ".join(str(p) for p in tried.get("orders", []))
    judged = f"judged over polynomial orders {chart.judged[0]}-{chart.judged[1]}" if chart is not None else ""
    return (
        f"{where}: {tried.get('peaks')} peak(s) of |H| over {lines} lines, none held by a stable LSCF pole "
        f"(pol_order_high {orders}, {judged}, stable within {100 * tried.get('freq_tol', 0):.2g} % in "
        f"frequency and {100 * tried.get('damping_tol', 0):.2g} % in damping); a band holding each peak "
        "with a few half-power bandwidths to spare, a finer FRF (more lines) or --method peak would help"
    )


def _judge_peaks(
    candidates: list[IdentifiedMode],
    f: np.ndarray,
    coherence: np.ndarray | None,
    *,
    max_damping: float,
    min_coherence: float,
) -> tuple[list[IdentifiedMode], list[dict]]:
    """Peak picking's modes with damping in ``(0, max_damping]`` and coherent data over their
    half-power band (the check :mod:`rigtools.analysis.stabilisation` makes)."""
    kept: list[IdentifiedMode] = []
    dropped: list[dict] = []
    df = float(f[1] - f[0])
    for m in candidates:
        reason = ""
        if not 0.0 < m.damping_ratio <= max_damping:
            reason = f"damping out of bounds: {m.damping_ratio:.3g} not in (0, {max_damping:g}]"
        elif coherence is not None:
            near = (f >= m.frequency_hz * (1 - m.damping_ratio) - df) & (
                f <= m.frequency_hz * (1 + m.damping_ratio) + df
            )
            coh = float(np.nanmin(coherence[near]))
            m = replace(m, coherence=coh)
            if coh < min_coherence:
                reason = (
                    f"incoherent: coherence down to {coh:.2f} over its half-power band (< {min_coherence:g})"
                )
        if reason:
            dropped.append(
                {"frequency_hz": m.frequency_hz, "damping_ratio": m.damping_ratio, "reason": reason}
            )
        else:
            kept.append(m)
    return kept, dropped


def _lsfd(modes: list[IdentifiedMode], f: np.ndarray, h: np.ndarray, kind: FRFKind, f_lo: float, f_hi: float):
    """Modal constants of the kept modes by sdypy-EMA's LSFD (with lower and upper residuals) on
    their poles; returns the modes with ``residue``, ``shape`` and ``fit_error``, and the first
    response's reconstruction."""
    from sdypy.EMA.EMA import LSFD  # imported here: sdypy loads matplotlib.pyplot and tqdm

    wn = 2.0 * np.pi * np.array([m.frequency_hz for m in modes])
    zeta = np.array([m.damping_ratio for m in modes])
    wd = wn * np.sqrt(1.0 - zeta**2)
    poles = -zeta * wn + 1j * wd
    sel = f <= f_hi
    lo = int(np.argmin(np.abs(f[sel] - f_lo)))
    hi = int(np.count_nonzero(sel))
    hb = np.where(np.isfinite(h[:, sel]), h[:, sel], 0.0)
    with single_blas_thread(), np.errstate(divide="ignore", invalid="ignore"):
        consts, rec, *_ = LSFD(poles, hb, f[sel], True, True, lo, hi, frf_form=kind)
    consts, rec = np.asarray(consts), np.asarray(rec)
    band = slice(lo, hi)
    err = float(np.linalg.norm(rec[0, band] - hb[0, band]) / np.linalg.norm(hb[0, band]))
    out = []
    for j, m in enumerate(modes):
        # sdypy's term A / (i w - s) + conj: the single-mode form (i w)^k R / (wn^2 - w^2 + 2 i zeta wn w)
        # has R = 2 i w_d A
        shape = tuple(complex(2j * wd[j] * a) for a in consts[:, j])
        out.append(replace(m, residue=shape[0], shape=shape, fit_error=err))
    full = np.full(f.size, np.nan, dtype=complex)
    full[: rec.shape[1]] = rec[0]
    return out, full
