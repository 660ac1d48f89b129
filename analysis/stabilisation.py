"""Poles that stay put as the model order grows: the LSCF stabilisation chart and the modes it supports.

**Chart** (:func:`lscf_stabilisation`): sdypy-EMA's LSCF poles at polynomial orders 2, 4, ..., 2P
inside the band. A pole is *stable* when the previous order has one pole within ``freq_tol`` in
frequency and ``damping_tol`` in damping (sdypy-EMA's own defaults, 0.1 % and 5 %) and, with
several responses, whose shape (LSFD modal constants over the responses) has a MAC of at least
``min_mac`` with it.

**Modes** (:func:`select_modes`), judged over the converged orders only (the upper half of the
orders run, above P): for each peak of the mode indicator (``|H|`` of one response; with several,
the root sum of squares over them, the complex mode indicator of one reference) of at least
``min_peak_db`` prominence (3 dB: it has both half-power points), the stable poles whose
half-power band ``fn (1 +- zeta)`` holds the peak, with damping in ``(0, max_damping]``, the one
nearest the peak at each order. The peak is a mode when such a pole exists at half the converged
orders or more and the coherence stays at least ``min_coherence`` over its half-power band (a
resonance is where the response is strongest; a bump between two anti-resonances, where the
response is weak, has low coherence). The mode's frequency and damping ratio are the medians over
those orders (their interquartile ranges are its evidence); peaks are taken by prominence, and a
pole supports one mode only. Stable poles that explain no peak are listed as not reported.

**Order** (:func:`converged_selection`): the selection at highest orders P = 20, 40, 80, 120, 160
(sdypy-EMA's ``pol_order_high``; each judged on its own upper half, polynomial orders P+2..2P);
the first P whose set of modes (by the peaks they explain) the next P repeats is taken: the
result no longer depends on the model order. Where none repeats, the highest is taken and
:func:`rigtools.analysis.modal_id.identify` says so.

**The band decides** (:func:`band_schedule`): the orders and the stability tolerances follow
what the band holds, not where it sits. A band of L lines is fitted at orders P <= L / 10 (a
higher order has more poles than the band's lines can place: on the 300 lines of a 50-200 Hz
band of a 0.5 Hz FRF, orders 82-160 put spurious poles beside every mode and none stayed put);
the tolerances are sdypy-EMA's for 1000 lines or more and grow as 1000 / L below (fewer lines
fix a pole less: its frequency and damping wander more between orders while their medians stay
put). A mode of the whole grid is then found in a band that holds it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy import signal

from rigtools.analysis.frf import FRFKind
from rigtools.sim.threads import single_blas_thread


@dataclass(frozen=True)
class StabilisationChart:
    """Poles of the LSCF estimator at increasing model order, classified.

    Attributes
    ----------
    orders
        (n_poles,) polynomial order of each pole.
    frequency_hz, damping_ratio
        (n_poles,) pole natural frequency and damping ratio.
    stable
        (n_poles,) True when a pole of the previous order lies within the frequency and damping
        tolerances (and, with several responses, its shape has a MAC of at least the threshold):
        "s" in a stabilisation chart.
    mac
        (n_poles,) MAC of the pole's shape with the matched pole of the previous order (several
        responses), else None.
    highest
        The highest polynomial order run (orders 2, 4, ..., ``highest``).
    judged
        ``(lowest, highest)`` polynomial orders the modes were judged over (0, 0 when none).
    mode
        (n_poles,) index into the reported modes of the mode the pole supports, -1 for none;
        None before the selection.
    """

    orders: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    stable: np.ndarray
    mac: np.ndarray | None = None
    highest: int = 0
    judged: tuple[int, int] = (0, 0)
    mode: np.ndarray | None = None


@dataclass(frozen=True)
class StableMode:
    """A peak of the mode indicator explained by stable poles over the converged orders.

    Attributes
    ----------
    frequency_hz, damping_ratio
        Medians over the supporting poles.
    peak_hz, peak_db
        The peak of the mode indicator it explains and its prominence (dB).
    orders_stable, orders_judged
        Converged orders with a supporting pole / converged orders.
    frequency_spread, damping_spread
        Interquartile range over the supporting poles / median.
    coherence
        Lowest coherence over its half-power band (NaN when unknown).
    mac_min
        Lowest MAC of a supporting pole with the previous order (NaN for one response).
    poles
        Indices into the chart of the supporting poles.
    """

    frequency_hz: float
    damping_ratio: float
    peak_hz: float
    peak_db: float
    orders_stable: int
    orders_judged: int
    frequency_spread: float
    damping_spread: float
    coherence: float
    mac_min: float
    poles: np.ndarray


def _mac(a: np.ndarray, b: np.ndarray) -> float:
    den = float(np.real(np.vdot(a, a) * np.vdot(b, b)))
    return float(abs(np.vdot(a, b)) ** 2 / den) if den > 0 else 0.0


def lscf_stabilisation(
    frequency_hz: np.ndarray,
    h: np.ndarray,
    *,
    kind: FRFKind,
    f_min: float,
    f_max: float,
    max_order: int = 40,
    freq_tol: float = 0.001,
    damping_tol: float = 0.05,
    min_mac: float = 0.9,
    max_damping: float = 1.0,
):
    """LSCF poles of ``h`` at orders 2..2*max_order (sdypy-EMA) and their stabilisation chart.

    Parameters
    ----------
    frequency_hz, h
        Grid and FRF, (n_freq,) or (n_responses, n_freq) for one reference.
    kind
        What ``h`` is.
    f_min, f_max
        Band, Hz: poles outside are not charted.
    max_order
        sdypy-EMA's ``pol_order_high``.
    freq_tol, damping_tol, min_mac
        Stability tolerances (relative), see the module docstring.
    max_damping
        Poles with a damping ratio outside ``(0, max_damping)`` are not charted.

    Returns
    -------
    tuple
        ``(model, chart)``: the :class:`sdypy.EMA.Model` and a :class:`StabilisationChart`.

    Examples
    --------
    Two modes, 50 and 120 Hz, 2 % damped: the stable poles up to order 20 are theirs.

    >>> import numpy as np
    >>> from rigtools.analysis.stabilisation import lscf_stabilisation
    >>> f = np.linspace(0.0, 200.0, 801)
    >>> w = 2 * np.pi * f
    >>> def accelerance(fn):  # of a unit-mass oscillator of fn Hz, 2 % damped
    ...     wn = 2 * np.pi * fn
    ...     return -(w**2) / (wn**2 - w**2 + 2j * 0.02 * wn * w)
    >>> h = accelerance(50.0) + accelerance(120.0)
    >>> chart = lscf_stabilisation(f, h, kind="accelerance", f_min=20.0, f_max=180.0, max_order=10)[1]
    >>> chart.highest, sorted({round(float(x), 1) for x in chart.frequency_hz[chart.stable]})
    (20, [50.0, 120.0])
    """
    from sdypy import EMA  # imported here: it loads matplotlib.pyplot and tqdm

    f = np.asarray(frequency_hz, dtype=float)
    h = np.atleast_2d(np.asarray(h, dtype=complex))
    # LSCF leaves out the bins below f_min, but sdypy-EMA transforms the whole FRF first: a
    # receptance or mobility has nan at 0 Hz (divided by i w) and would make every pole nan
    h = np.where((f < f_min) & ~np.isfinite(h), 0.0, h)
    model = EMA.Model(frf=h, freq=f, lower=f_min, upper=f_max, pol_order_high=int(max_order), frf_form=kind)
    several = h.shape[0] > 1
    orders, fr, xi, stable, macs = [], [], [], [], []
    # one BLAS thread: the LSCF matrices are small, and threads contending on a busy machine
    # made a 300-order run 10x slower
    with single_blas_thread():
        model.get_poles(method="lscf", show_progress=False)
        prev_f = prev_x = np.array([])
        prev_shape = np.zeros((h.shape[0], 0), complex)
        for j, (pf, px, poles) in enumerate(
            zip(model.pole_freq, model.pole_xi, model.all_poles, strict=True)
        ):
            pf, px, poles = np.asarray(pf, float), np.asarray(px, float), np.asarray(poles, complex)
            keep = np.isfinite(pf) & (pf >= f_min) & (pf <= f_max) & (px > 0) & (px < max_damping)
            pf, px, poles = pf[keep], px[keep], poles[keep]
            shape = _shapes(model, poles, f_min, f_max) if several and poles.size else None
            for k, (a, b) in enumerate(zip(pf, px, strict=True)):
                near = np.flatnonzero(
                    (np.abs(prev_f - a) <= freq_tol * a) & (np.abs(prev_x - b) <= damping_tol * b)
                )
                mac = float("nan")
                ok = near.size > 0
                if ok and shape is not None:
                    mac = max(_mac(shape[:, k], prev_shape[:, i]) for i in near)
                    ok = mac >= min_mac
                orders.append(2 * (j + 1))
                fr.append(a)
                xi.append(b)
                stable.append(ok)
                macs.append(mac)
            prev_f, prev_x = pf, px
            if shape is not None:
                prev_shape = shape
    chart = StabilisationChart(
        np.array(orders, int),
        np.array(fr),
        np.array(xi),
        np.array(stable, bool),
        np.array(macs) if several else None,
        2 * len(model.all_poles),
    )
    return model, chart


def _shapes(model, poles: np.ndarray, f_min: float, f_max: float) -> np.ndarray:
    """(n_responses, n_poles) LSFD modal constants of ``poles`` (sdypy-EMA), with residuals."""
    from sdypy.EMA.EMA import LSFD

    lo = int(np.argmin(np.abs(model.freq - f_min)))
    hi = int(np.argmin(np.abs(model.freq - f_max)))
    a, *_ = LSFD(poles, model.frf, model.freq, True, True, lo, hi, frf_form=model.frf_form)
    return np.asarray(a)


def mode_indicator(h: np.ndarray) -> np.ndarray:
    """``|H|`` of one response; with several, the root sum of squares over them (the complex
    mode indicator function of one reference)."""
    h = np.atleast_2d(np.asarray(h, dtype=complex))
    return np.sqrt(np.sum(np.abs(h) ** 2, axis=0))


def peaks_of(
    frequency_hz: np.ndarray, magnitude: np.ndarray, f_lo: float, f_hi: float, min_db: float
) -> tuple[np.ndarray, np.ndarray]:
    """Indices and prominences (dB) of the local maxima of ``magnitude`` in the band."""
    f = np.asarray(frequency_hz, dtype=float)
    mag_db = 20.0 * np.log10(np.maximum(np.abs(magnitude), np.finfo(float).tiny))
    band = np.flatnonzero((f >= f_lo) & (f <= f_hi) & np.isfinite(mag_db))
    if band.size < 3:
        return np.array([], int), np.array([])
    idx, props = signal.find_peaks(mag_db[band], prominence=min_db)
    return band[idx], np.asarray(props["prominences"])


def _iqr(x: np.ndarray) -> float:
    q1, q3 = np.percentile(x, [25, 75])
    return float(q3 - q1)


def select_modes(
    chart: StabilisationChart,
    frequency_hz: np.ndarray,
    indicator: np.ndarray,
    coherence: np.ndarray | None,
    band: tuple[float, float],
    top_order: int,
    *,
    max_damping: float = 0.1,
    min_presence: float = 0.5,
    min_coherence: float = 0.9,
    min_peak_db: float = 3.0,
    freq_tol: float = 0.001,
) -> tuple[list[StableMode], list[dict], np.ndarray]:
    """The modes the chart supports over the converged orders ``(top_order / 2, top_order]``
    (polynomial orders), see the module docstring.

    Returns
    -------
    tuple
        ``(modes, dropped, support)``: the modes ascending in frequency; the candidates not
        reported (``{"frequency_hz", "damping_ratio", "reason"}``, the reason starting with a fixed
        phrase); the (n_poles,) index of the mode each pole supports (-1 for none).
    """
    f = np.asarray(frequency_hz, dtype=float)
    df = float(f[1] - f[0])
    lo, hi = band
    judged = (chart.orders > top_order / 2) & (chart.orders <= top_order)
    last = chart.highest or int(chart.orders.max(initial=0))
    n_judged = len([o for o in range(2, min(top_order, last) + 1, 2) if o > top_order / 2])
    fn, zeta = chart.frequency_hz, chart.damping_ratio
    cand = chart.stable & judged & (fn >= lo) & (fn <= hi) & (zeta > 0) & (zeta <= max_damping)
    peaks, prom = peaks_of(f, indicator, lo, hi, min_peak_db)
    used = np.zeros(fn.size, bool)
    found: list[StableMode] = []
    dropped: list[dict] = []
    need = max(1, int(np.ceil(min_presence * n_judged)))
    for p in np.argsort(prom)[::-1]:
        fp = float(f[peaks[p]])
        ok = np.flatnonzero(cand & ~used & (np.abs(fn - fp) <= np.maximum(zeta * fn, df)))
        pick = []
        for order in np.unique(chart.orders[ok]):
            at = ok[chart.orders[ok] == order]
            pick.append(int(at[np.argmin(np.abs(fn[at] - fp))]))
        if len(pick) < need:
            dropped.append(
                {
                    "frequency_hz": fp,
                    "damping_ratio": float("nan"),
                    "reason": f"no stable pole: the peak ({prom[p]:.1f} dB) is in the half-power band of a "
                    f"stable pole with damping in (0, {max_damping:g}] at {len(pick)} of {n_judged} converged "
                    f"orders (need {need})",
                }
            )
            continue
        sel = np.array(pick)
        f_m, z_m = float(np.median(fn[sel])), float(np.median(zeta[sel]))
        coh = float("nan")
        if coherence is not None:
            near = (f >= f_m * (1 - z_m) - df) & (f <= f_m * (1 + z_m) + df)
            coh = float(np.nanmin(coherence[near])) if np.any(near) else float("nan")
        if np.isfinite(coh) and coh < min_coherence:
            dropped.append(
                {
                    "frequency_hz": f_m,
                    "damping_ratio": z_m,
                    "reason": f"incoherent: coherence down to {coh:.2f} over its half-power band (< {min_coherence:g})",
                }
            )
            continue
        used[sel] = True
        mac_min = float(np.nanmin(chart.mac[sel])) if chart.mac is not None else float("nan")
        found.append(
            StableMode(
                f_m,
                z_m,
                fp,
                float(prom[p]),
                len(pick),
                n_judged,
                _iqr(fn[sel]) / f_m,
                _iqr(zeta[sel]) / z_m,
                coh,
                mac_min,
                sel,
            )
        )
    found.sort(key=lambda m: m.frequency_hz)
    support = np.full(fn.size, -1)
    for i, m in enumerate(found):
        support[m.poles] = i
    for c in _columns(chart, cand & ~used, freq_tol, need):
        dropped.append(
            {
                "frequency_hz": float(np.median(fn[c])),
                "damping_ratio": float(np.median(zeta[c])),
                "reason": f"no peak of |H|: stable at {np.unique(chart.orders[c]).size} of {n_judged} converged "
                f"orders, explains no peak of {min_peak_db:g} dB",
            }
        )
    return found, dropped, support


def _columns(chart: StabilisationChart, mask: np.ndarray, freq_tol: float, need: int) -> list[np.ndarray]:
    """Groups of the poles in ``mask``: sorted by frequency, a new group starts where the gap to the
    next exceeds ``freq_tol`` (relative); a group counts with poles at ``need`` or more orders."""
    idx = np.flatnonzero(mask)
    idx = idx[np.argsort(chart.frequency_hz[idx])]
    groups: list[list[int]] = []
    for i in idx:
        if groups and chart.frequency_hz[i] <= chart.frequency_hz[groups[-1][-1]] * (1 + freq_tol):
            groups[-1].append(int(i))
        else:
            groups.append([int(i)])
    return [np.array(g) for g in groups if np.unique(chart.orders[g]).size >= need]


#: sdypy-EMA ``pol_order_high`` values tried for a band that holds enough lines.
ORDERS = (20, 40, 80, 120, 160)
#: Lines of the band per unit of ``pol_order_high`` (2 poles): more poles than the band's lines
#: can place wander between orders (see the module docstring).
LINES_PER_ORDER = 10
#: Lowest ``pol_order_high`` tried: its converged half (orders P+2..2P) holds two orders.
MIN_ORDER = 4
#: Band lines at and above which the stability tolerances are sdypy-EMA's own (0.1 %, 5 %).
TOLERANCE_LINES = 1000
#: Largest widening of the tolerances (1 % in frequency, 50 % in damping: a pole that moves
#: more between orders is not one pole).
MAX_TOLERANCE_SCALE = 10.0


@dataclass(frozen=True)
class BandSchedule:
    """What :func:`converged_selection` tries in a band.

    Attributes
    ----------
    lines
        FRF lines in the band.
    peaks
        Peaks of the mode indicator in the band (prominence ``min_peak_db``).
    orders
        sdypy-EMA ``pol_order_high`` values tried, increasing.
    freq_tol, damping_tol
        Stability tolerances (relative) between consecutive orders.
    """

    lines: int
    peaks: int
    orders: tuple[int, ...]
    freq_tol: float
    damping_tol: float


def band_schedule(
    frequency_hz: np.ndarray,
    indicator: np.ndarray,
    band: tuple[float, float],
    *,
    orders: Sequence[int] | None = None,
    freq_tol: float = 0.001,
    damping_tol: float = 0.05,
    min_peak_db: float = 3.0,
    lines_per_order: float = LINES_PER_ORDER,
) -> BandSchedule:
    """The orders and stability tolerances for ``band`` from the lines it holds (module docstring).

    ``orders`` (default :data:`ORDERS`) are capped at ``lines / LINES_PER_ORDER`` (rounded, at least
    :data:`MIN_ORDER`); ``freq_tol`` and ``damping_tol`` are multiplied by
    ``TOLERANCE_LINES / lines``, between 1 and :data:`MAX_TOLERANCE_SCALE`.

    Examples
    --------
    >>> f = np.arange(1600) * 0.5
    >>> s = band_schedule(f, np.ones(f.size), (50.0, 200.0))
    >>> s.lines, s.orders, round(s.freq_tol, 5), round(s.damping_tol, 4)
    (301, (20, 30), 0.00332, 0.1661)
    >>> band_schedule(f, np.ones(f.size), (0.5, 799.5)).orders
    (20, 40, 80, 120, 160)
    """
    f = np.asarray(frequency_hz, dtype=float)
    lines = int(np.count_nonzero((f >= band[0]) & (f <= band[1])))
    cap = max(MIN_ORDER, round(lines / lines_per_order))
    tried = tuple(sorted({min(int(p), cap) for p in (ORDERS if orders is None else orders)}))
    scale = min(max(1.0, TOLERANCE_LINES / max(lines, 1)), MAX_TOLERANCE_SCALE)
    peaks = peaks_of(f, indicator, band[0], band[1], min_peak_db)[0].size
    return BandSchedule(lines, peaks, tried, freq_tol * scale, damping_tol * scale)


@dataclass(frozen=True)
class ConvergedSelection:
    """Result of :func:`converged_selection`.

    Attributes
    ----------
    model
        The :class:`sdypy.EMA.Model` of the highest order run.
    chart
        Its chart, with ``judged`` and ``mode`` set for the selection taken.
    modes, dropped
        See :func:`select_modes`.
    order
        The highest order (sdypy-EMA ``pol_order_high``) of the selection taken.
    converged
        Whether the next order of ``orders`` repeated its set of modes.
    """

    model: object
    chart: StabilisationChart
    modes: list[StableMode]
    dropped: list[dict]
    order: int
    converged: bool
    schedule: BandSchedule | None = None


def converged_selection(
    frequency_hz: np.ndarray,
    h: np.ndarray,
    *,
    kind: FRFKind,
    band: tuple[float, float],
    coherence: np.ndarray | None = None,
    orders: Sequence[int] | None = None,
    freq_tol: float = 0.001,
    damping_tol: float = 0.05,
    min_mac: float = 0.9,
    max_damping: float = 0.1,
    min_presence: float = 0.5,
    min_coherence: float = 0.9,
    min_peak_db: float = 3.0,
    lines_per_order: float = LINES_PER_ORDER,
) -> ConvergedSelection:
    """Modes from the lowest highest-order in ``orders`` whose set of modes the next one repeats.

    Where the band's lines cap the orders (:func:`band_schedule`) and no peak of the band is held
    by a stable pole, the selection is tried once more with twice the cap: a pole at the border of
    the stability tolerances at the capped order settles at a higher one (issue 30's property test
    found a band, 81.12-126.24 Hz of a 0.25 Hz grid, capped at order 18, losing its 120 Hz mode
    that 82-126.24 Hz kept).

    Parameters
    ----------
    frequency_hz, h
        Grid and FRF, (n_freq,) or (n_responses, n_freq) for one reference.
    kind, band
        What ``h`` is; the band, Hz.
    coherence
        (n_freq,) or (n_responses, n_freq); with several responses a bin counts with the best.
    orders
        sdypy-EMA ``pol_order_high`` values tried (default :data:`ORDERS`); with ``freq_tol``
        and ``damping_tol`` (:func:`lscf_stabilisation`) fitted to the band by
        :func:`band_schedule`.
    min_mac
        :func:`lscf_stabilisation`.
    max_damping, min_presence, min_coherence, min_peak_db
        :func:`select_modes`.
    """
    f = np.asarray(frequency_hz, dtype=float)
    h = np.atleast_2d(np.asarray(h, dtype=complex))
    coh = None if coherence is None else np.max(np.atleast_2d(np.asarray(coherence, float)), axis=0)
    indicator = mode_indicator(h)
    schedule = band_schedule(
        f,
        indicator,
        band,
        orders=orders,
        freq_tol=freq_tol,
        damping_tol=damping_tol,
        min_peak_db=min_peak_db,
        lines_per_order=lines_per_order,
    )
    requested = ORDERS if orders is None else orders
    capped = max(requested) > schedule.orders[-1]
    keywords: dict[str, Any] = dict(
        kind=kind,
        band=band,
        coherence=coherence,
        orders=orders,
        freq_tol=freq_tol,
        damping_tol=damping_tol,
        min_mac=min_mac,
        max_damping=max_damping,
        min_presence=min_presence,
        min_coherence=min_coherence,
        min_peak_db=min_peak_db,
    )
    orders = list(schedule.orders)
    freq_tol, damping_tol = schedule.freq_tol, schedule.damping_tol
    # sdypy-EMA's LSCF of order P transforms the FRF from 0 Hz to the band's top: it needs more
    # than P + 2 lines there (a coarse FRF under a low band has too few: an IndexError inside)
    lines = int(np.floor(band[1] / (f[1] - f[0]) + 1e-9)) + 1
    if orders[0] >= lines - 2:
        raise ValueError(
            f"the FRF has {lines} lines from 0 Hz to the band's top {band[1]:g} Hz (every "
            f"{f[1] - f[0]:g} Hz), too few for LSCF orders from {orders[0]} (over {orders[0] + 2}): "
            "a finer FRF (longer frames) or a band reaching higher"
        )
    orders = [p for p in orders if p < lines - 2]
    runs = sorted({orders[min(1, len(orders) - 1)], orders[min(2, len(orders) - 1)], orders[-1]})
    run_to = 0
    model = chart = None
    previous: set[float] = set()

    def select(top: int) -> tuple[list[StableMode], list[dict], np.ndarray]:
        assert chart is not None
        return select_modes(
            chart,
            f,
            indicator,
            coh,
            band,
            2 * top,
            max_damping=max_damping,
            min_presence=min_presence,
            min_coherence=min_coherence,
            min_peak_db=min_peak_db,
            freq_tol=freq_tol,
        )

    for i, top in enumerate(orders):
        if run_to < top:
            # LSCF runs up to the second order (most FRFs settle there), then the third, then the
            # highest: a run costs about the cube of its order (poles at one order do not depend on
            # the highest, so a longer run repeats the shorter one's)
            run_to = next(r for r in runs if r >= top)
            model, chart = lscf_stabilisation(
                f,
                h,
                kind=kind,
                f_min=band[0],
                f_max=band[1],
                max_order=run_to,
                freq_tol=freq_tol,
                damping_tol=damping_tol,
                min_mac=min_mac,
            )
        peaks = {m.peak_hz for m in select(top)[0]}
        if i > 0 and peaks == previous:
            result = _taken(model, chart, select(orders[i - 1]), orders[i - 1], True, schedule)
            break
        previous = peaks
    else:
        result = _taken(model, chart, select(orders[-1]), orders[-1], len(orders) == 1, schedule)
    if not result.modes and schedule.peaks and capped and lines_per_order == LINES_PER_ORDER:
        retry = converged_selection(frequency_hz, h, **keywords, lines_per_order=lines_per_order / 2)
        if retry.modes:
            return retry
    return result


def _taken(model, chart, sel, top: int, converged: bool, schedule: BandSchedule) -> ConvergedSelection:
    modes, dropped, support = sel
    chart = replace(chart, judged=(top + 2, 2 * top), mode=support)
    return ConvergedSelection(model, chart, modes, dropped, top, converged, schedule)
