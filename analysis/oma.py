"""Operational modal analysis: natural frequencies and damping of a response-only record.

A record without a measured force (an operating machine, a structure under wind, traffic or
people) still holds the modes: the responses to broadband random loads are the system's impulse
responses averaged over the loads, so their covariances decay as the modes do.
:func:`operational_modes` finds them in four steps.

1. **Band and rate.** The band is ``band`` or the whole record up to 80 % of the Nyquist
   frequency. Every channel is scaled to unit RMS (the identification weighs channels by their
   covariances; shapes are scaled back). The record is decimated (anti-alias filtered, zero
   phase) so the band's top sits at 60 % or less of the new Nyquist frequency. A band too wide
   for one Hankel matrix to lag one period of its lowest peak at that rate
   (:func:`sub_bands`) is identified in parts of equal frequency ratio (each overlapping its
   neighbours by 15 %, each keeping the poles of its own part), each decimated for its own top.
2. **Averaged spectra.** The cross-spectral matrix of all channels (Welch, Hann, 50 % overlap,
   16 averages or more) and its singular values; the peaks of the first (at least
   :data:`PEAK_PROMINENCE_DB` prominent) are the record's spectral peaks. One averaged spectrum
   of all channels gives one peak per resonance, where one unaveraged spectrum per channel
   gives several noise spikes.
3. **SSI-cov** (:mod:`rigtools.analysis.ssi`) at model orders 2, 4, ... up to
   ``4 x peaks + 20`` (what the band holds sets the order), with block rows spanning one
   period of the lowest peak (at least 30); poles stable in frequency (1 %), damping (25 %) and shape (MAC
   0.95), with damping below 20 %, are grouped by frequency and shape (relative frequency
   difference + 1 - MAC below 0.03, average linkage), one pole per order. A group stable at
   :data:`MIN_STABLE_FRACTION` of the converged orders (the upper half of the orders run) or
   more is a candidate; its frequency, damping and shape are medians over those orders.
4. **Tones, not modes** (:mod:`rigtools.analysis.oma_select`): a candidate whose modal
   coordinate is a steady sine (kurtosis well below the 3 of a random resonance) with damping
   below 1 %, or that sits on a multiple of ``fe`` or of such a tone with damping below 1 %, is
   a *harmonic*, listed with the reason and never among the modes; candidates that are noise
   (their modal coordinate's spectrum is flat) are dropped with the reason.

Each mode comes with its spread (the model-order scatter and the record's statistical spread):
two halves of a record give the same modes within it.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import signal
from scipy.cluster.hierarchy import fcluster, linkage
from scipy.spatial.distance import squareform

from rigtools.analysis.oma_select import (
    Candidate,
    Harmonic,
    OMAMode,
    label_peaks,
    measure,
    select,
)
from rigtools.analysis.ssi import SSIPoles, mac_matrix, ssi_cov_poles
from rigtools.analysis.stabilisation import StabilisationChart

__all__ = ["Harmonic", "OMAMode", "OMAResult", "averaged_spectra", "decimate_to", "operational_modes"]

PEAK_PROMINENCE_DB = 3.0  # a peak of the averaged spectrum: both half-power points
MAX_DAMPING = 0.2
MIN_DAMPING = -0.002  # a tone's pole may come out a hair unstable; it is judged, not dropped
CLUSTER_DISTANCE = 0.03
MIN_STABLE_FRACTION = 0.5  # of the converged orders, for a group to be a candidate (as the FRF path)
MAX_HANKEL_ROWS = 640  # block rows x channels: the SVD's size
MIN_BLOCK_ROWS = 30
LOW_LINES = 10  # the lowest peak of interest sits this many lines of the averaged spectrum above 0 Hz
MAX_ORDER = 160
MIN_SAMPLES = 200  # after decimation: 16 Welch averages of 24 samples at the least
MIN_ORDER = 40  # at least 10 converged orders to judge stability over
MAX_BAND_RATIO = 12.0  # top / lowest peak of one part of a split band
OVERLAP = 1.15


@dataclass(frozen=True)
class SubBand:
    """One SSI-cov run: the part of the band it reports (``band``), its settings."""

    band: tuple[float, float]
    sample_rate: float
    decimation: int
    block_rows: int
    max_order: int
    judged: tuple[int, int]

    def to_dict(self) -> dict:
        return {
            "band_hz": list(self.band),
            "sample_rate": self.sample_rate,
            "decimation": self.decimation,
            "block_rows": self.block_rows,
            "model_orders": [2, self.max_order],
            "orders_judged": list(self.judged),
        }


@dataclass(frozen=True)
class OMAResult:
    """What :func:`operational_modes` found.

    Attributes
    ----------
    modes
        Modes (:class:`rigtools.analysis.oma_select.OMAMode`), ascending in frequency.
    harmonics
        Tones flagged (:class:`rigtools.analysis.oma_select.Harmonic`), never modes, ascending.
    peaks
        Peaks of the averaged spectrum (first singular value of the cross-spectral matrix) in
        the band: ``{"frequency_hz", "level", "explained_by"}``, ``explained_by`` one of
        ``"mode"``, ``"harmonic"``, ``"none"``.
    band
        ``(f_min, f_max)`` Hz.
    runs
        The SSI-cov runs (one per sub-band) and their settings.
    fundamental_hz
        ``fe`` or the fundamental of the tones found (None: no harmonic).
    frequency_hz, singular_values
        The averaged spectra over the band: (F,) and (F, min(channels, 3)) singular values of
        the cross-spectral matrix of the channels scaled to unit RMS (1/Hz).
    chart
        The SSI stabilisation chart in the band
        (:class:`rigtools.analysis.stabilisation.StabilisationChart`; ``mode`` marks the poles
        of each mode).
    channels
        Names of the channels (the shapes' order).
    dropped
        Candidates not reported and why: ``{"frequency_hz", "damping_ratio", "reason"}``.
    notes
        What was done, and what would help when nothing was found.
    """

    modes: list[OMAMode]
    harmonics: list[Harmonic]
    peaks: list[dict]
    band: tuple[float, float]
    runs: list[SubBand]
    fundamental_hz: float | None
    frequency_hz: np.ndarray
    singular_values: np.ndarray
    chart: StabilisationChart
    channels: list[str] = field(default_factory=list)
    dropped: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        """Plain-Python summary (the spectra and chart are for figures); ``found`` is False
        when no mode was identified (``notes`` say what was tried and what would help)."""
        return {
            "method": "SSI-cov (covariance-driven stochastic subspace identification)",
            "band_hz": list(self.band),
            "runs": [r.to_dict() for r in self.runs],
            "fundamental_hz": self.fundamental_hz,
            "found": bool(self.modes),
            "modes": [m.to_dict(self.channels or None) for m in self.modes],
            "harmonics": [h.to_dict() for h in self.harmonics],
            "peaks": list(self.peaks),
            "dropped": list(self.dropped),
            "notes": list(self.notes),
        }


def decimate_to(y: np.ndarray, sample_rate: float, f_max: float) -> tuple[np.ndarray, float, int]:
    """``(y decimated, new rate, factor)``: the largest integer factor that keeps ``f_max`` at
    60 % or less of the new Nyquist frequency (scipy's order-8 Chebyshev anti-alias filter,
    zero phase, in stages of at most 10)."""
    q = max(1, int(np.floor(0.3 * sample_rate / f_max)))
    out, left = y, q
    while left > 1:
        step = next(d for d in range(min(left, 10), 1, -1) if left % d == 0)
        out = signal.decimate(out, step, axis=-1, zero_phase=True)
        left //= step
    return out, sample_rate / q, q


def averaged_spectra(y: np.ndarray, sample_rate: float, nperseg: int) -> tuple[np.ndarray, np.ndarray]:
    """``(f, s)``: frequencies and the singular values (descending, at most 3) of the Welch
    cross-spectral matrix of the channels of ``y`` (Hann, 50 % overlap, segment means removed,
    one-sided density: ``scipy.signal.csd``'s scaling)."""
    win = signal.get_window("hann", nperseg)
    seg = np.lib.stride_tricks.sliding_window_view(y, nperseg, axis=1)[:, :: nperseg // 2]
    seg = seg - seg.mean(axis=-1, keepdims=True)
    z = np.fft.rfft(seg * win, axis=-1)  # (channels, segments, F)
    g = np.einsum("isf,jsf->fij", z, np.conj(z)) / (z.shape[1] * sample_rate * np.sum(win**2))
    g[1 : nperseg // 2 + (nperseg % 2)] *= 2.0  # one-sided: DC (and Nyquist) once
    s = np.linalg.svd(g, compute_uv=False)[:, :3]
    return np.fft.rfftfreq(nperseg, 1.0 / sample_rate), s


def welch_segment(n: int) -> int:
    """A power of two giving 16 or more averages (50 % overlap), at least 64 samples."""
    return int(max(64, min(2 ** np.floor(np.log2(max(n / 8.5, 2))), 1 << 16)))


def _peaks(f: np.ndarray, s1: np.ndarray, lo: float, hi: float) -> np.ndarray:
    db = 10 * np.log10(np.maximum(s1, np.finfo(float).tiny))
    idx, _ = signal.find_peaks(db, prominence=PEAK_PROMINENCE_DB)
    return idx[(f[idx] >= lo) & (f[idx] <= hi) & (f[idx] > 0)]


def _clusters(poles: SSIPoles, keep: np.ndarray) -> list[np.ndarray]:
    """Groups of the kept poles by frequency and shape (average linkage on relative frequency
    difference + 1 - MAC, cut at :data:`CLUSTER_DISTANCE`), each as pole indices."""
    idx = np.flatnonzero(keep)
    if idx.size < 2:
        return [idx] if idx.size else []
    f = poles.frequency_hz[idx]
    d = np.abs(f[:, None] - f[None, :]) / np.maximum(f[:, None], f[None, :])
    if poles.shapes.shape[1] > 1:
        d = d + (1.0 - mac_matrix(poles.shapes[idx], poles.shapes[idx]))
    np.fill_diagonal(d, 0.0)
    tree = linkage(squareform(np.clip((d + d.T) / 2, 0, None), checks=False), "average")
    labels = fcluster(tree, CLUSTER_DISTANCE, "distance")
    return [idx[labels == k] for k in np.unique(labels)]


def _one_per_order(poles: SSIPoles, members: np.ndarray) -> np.ndarray:
    """The member nearest the group's median frequency at each order."""
    fmed = np.median(poles.frequency_hz[members])
    out = []
    for n in np.unique(poles.orders[members]):
        at = members[poles.orders[members] == n]
        out.append(at[np.argmin(np.abs(poles.frequency_hz[at] - fmed))])
    return np.array(out, dtype=int)


def _block_rows(sample_rate: float, f_low: float, channels: int, max_order: int, n: int) -> int:
    """Lags spanning one period of ``f_low`` and at least :data:`MIN_BLOCK_ROWS`, within
    :data:`MAX_HANKEL_ROWS` and a twentieth of the record, and enough for ``max_order``
    (longer lags add the noise of the covariances' tails: two periods lost the turbine's
    tower modes, 80 block rows the footbridge's first mode)."""
    br = max(int(np.ceil(sample_rate / f_low)), MIN_BLOCK_ROWS)
    br = min(br, MAX_HANKEL_ROWS // channels, n // 20)
    return max(br, int(np.ceil((max_order + channels) / channels)), 4)


def sub_bands(lo: float, hi: float, f_low: float, channels: int) -> list[tuple[float, float]]:
    """The band split into parts of equal frequency ratio when one block Hankel matrix of at
    most :data:`MAX_HANKEL_ROWS` rows cannot lag one period of ``f_low`` at the rate the top
    needs (``hi / f_low`` above ``0.3 MAX_HANKEL_ROWS / channels``, with
    :data:`MAX_BAND_RATIO` the most a part spans)."""
    start = max(lo, f_low)
    ratio = min(MAX_BAND_RATIO, 0.3 * MAX_HANKEL_ROWS / channels)
    if hi <= 0.3 * MAX_HANKEL_ROWS / channels * start:
        return [(lo, hi)]
    k = int(np.ceil(np.log(hi / start) / np.log(ratio)))
    edges = start * (hi / start) ** (np.arange(k + 1) / k)
    edges[0], edges[-1] = lo, hi
    return [(float(a), float(b)) for a, b in itertools.pairwise(edges)]


@dataclass
class _Run:
    settings: SubBand
    poles: SSIPoles  # the run's poles within its own part of the band
    candidates: list[Candidate]
    groups: list[np.ndarray]  # per candidate: indices into ``poles``
    dropped: list[dict]


def _identify_part(
    ys: np.ndarray,
    scale: np.ndarray,
    sample_rate: float,
    part: tuple[float, float],
    nyq: float,
    *,
    max_order: int | None,
    block_rows: int | None,
) -> _Run:
    """One SSI-cov run over ``part`` (widened by :data:`OVERLAP` each side), its candidates."""
    lo, hi = part
    top = min(hi * OVERLAP, nyq)
    yd, fs, q = decimate_to(ys, sample_rate, top)
    l, n = yd.shape
    nper = welch_segment(n)
    f, sv = averaged_spectra(yd, fs, nper)
    peak_idx = _peaks(f, sv[:, 0], lo / OVERLAP, top)
    low = peak_idx[f[peak_idx] >= LOW_LINES * f[1]]
    f_low = max(lo / OVERLAP, LOW_LINES * f[1], f[low[0]] if low.size else 0.0)
    order = max_order or int(min(MAX_ORDER, max(MIN_ORDER, 4 * peak_idx.size + 20)))
    order += order % 2
    br = block_rows or _block_rows(fs, f_low, l, order, n)
    order = min(order, (br * l) // 2 * 2)
    poles = ssi_cov_poles(yd, fs, block_rows=br, max_order=order)
    mine = (poles.frequency_hz >= lo) & (poles.frequency_hz < hi if hi < nyq else poles.frequency_hz <= hi)
    poles = replace(
        poles,
        **{
            k: getattr(poles, k)[mine]
            for k in ("orders", "frequency_hz", "damping_ratio", "shapes", "stable")
        },
        mac=poles.mac[mine],
        mpc=poles.mpc[mine],
    )
    phys = poles.shapes * scale[None, :]
    phys = phys / np.maximum(np.linalg.norm(phys, axis=1, keepdims=True), np.finfo(float).tiny)
    judged_from = order // 2 + 2
    judged = max(1, (order - judged_from) // 2 + 1)
    admissible = (
        poles.stable
        & (poles.orders >= judged_from)
        & (poles.damping_ratio > MIN_DAMPING)
        & (poles.damping_ratio <= MAX_DAMPING)
    )
    candidates, groups, dropped = [], [], []
    for members in _clusters(poles, admissible):
        members = _one_per_order(poles, members)
        fr, z = poles.frequency_hz[members], poles.damping_ratio[members]
        if members.size < MIN_STABLE_FRACTION * judged:
            if members.size >= 3:
                dropped.append(
                    {
                        "frequency_hz": float(np.median(fr)),
                        "damping_ratio": float(np.median(z)),
                        "reason": f"stable at {members.size} of {judged} converged orders "
                        f"({MIN_STABLE_FRACTION:.0%} needed)",
                    }
                )
            continue
        rep = int(members[np.argmin(np.abs(fr - np.median(fr)))])
        k = int(np.argmin(np.abs(f - np.median(fr))))
        rank_db = float(10 * np.log10(sv[k, 0] / sv[k, 1])) if l > 1 and sv[k, 1] > 0 else float("nan")
        shape, mpc = poles.shapes[rep], float(poles.mpc[rep])
        candidates.append(measure(members, fr, z, shape, phys[rep], mpc, yd, fs, nper, rank_db, judged))
        groups.append(members)
    settings = SubBand((float(lo), float(hi)), float(fs), q, br, order, (judged_from, order))
    return _Run(settings, poles, candidates, groups, dropped)


def _chart(runs: list[_Run], mode_of: list[int]) -> StabilisationChart:
    """The runs' charts as one (each run's poles within its own part), ``mode`` marking the
    poles of each mode."""
    marks, k = [], 0
    for r in runs:
        m = np.full(r.poles.orders.size, -1)
        for g in r.groups:
            m[g] = mode_of[k]
            k += 1
        marks.append(m)

    def cat(name: str) -> np.ndarray:
        return np.concatenate([getattr(r.poles, name) for r in runs])

    highest = max(r.settings.max_order for r in runs)
    judged = (min(r.settings.judged[0] for r in runs), highest)
    return StabilisationChart(
        cat("orders"),
        cat("frequency_hz"),
        cat("damping_ratio"),
        cat("stable"),
        cat("mac"),
        highest=highest,
        judged=judged,
        mode=np.concatenate(marks),
    )


def operational_modes(
    y: np.ndarray,
    sample_rate: float,
    *,
    band: tuple[float, float] | None = None,
    fe: float | None = None,
    channels: list[str] | None = None,
    max_order: int | None = None,
    block_rows: int | None = None,
) -> OMAResult:
    """Modes and harmonic tones of a response-only record (see the module docstring).

    Parameters
    ----------
    y
        (channels, N) samples of the responses (any motion quantity; mixed units are fine,
        each channel is scaled to unit RMS for the identification).
    sample_rate
        Hz.
    band
        ``(f_min, f_max)`` Hz to report modes in; default 0 to 80 % of the Nyquist frequency.
    fe
        The drive's or shaft's frequency when known: sharp lines on its multiples are flagged
        as harmonics.
    channels
        Names of the rows of ``y`` (for the shapes in :meth:`OMAResult.to_dict`).
    max_order, block_rows
        Override the SSI-cov settings (default: from the peaks each part of the band holds).

    Returns
    -------
    OMAResult

    Raises
    ------
    ValueError
        A band outside the record's, a record too short for the band, a constant channel,
        non-finite samples.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(1)
    >>> fs, fn, zeta = 50.0, 3.0, 0.02
    >>> wn = 2 * np.pi * fn
    >>> b, a = signal.cont2discrete(([wn**2], [1, 2 * zeta * wn, wn**2]), 1 / fs)[:2]
    >>> y = signal.lfilter(b[0], a, rng.normal(size=30000))
    >>> res = operational_modes(y, fs, band=(1.0, 6.0))
    >>> [round(m.frequency_hz, 1) for m in res.modes], res.harmonics
    ([3.0], [])
    """
    y = np.asarray(y, dtype=float)
    if y.ndim == 1:
        y = y[None, :]
    if not np.all(np.isfinite(y)):
        raise ValueError("the record holds NaN or infinite samples")
    nyq = sample_rate / 2
    lo, hi = band if band is not None else (0.0, 0.8 * nyq)
    if not (0 <= lo < hi <= nyq):
        raise ValueError(f"band {lo:g}-{hi:g} Hz must lie inside 0-{nyq:g} Hz (half the sample rate)")
    y = y - y.mean(axis=1, keepdims=True)
    scale = y.std(axis=1)
    if np.any(scale == 0):
        bad = [channels[i] if channels else str(i) for i in np.flatnonzero(scale == 0)]
        raise ValueError(f"constant channel(s) {', '.join(bad)}: nothing to identify from")
    ys = y / scale[:, None]
    yd, fs, _ = decimate_to(ys, sample_rate, hi)
    seconds = y.shape[1] / sample_rate
    if yd.shape[1] < MIN_SAMPLES:
        raise ValueError(
            f"{y.shape[1]} samples ({seconds:.3g} s) are too few for modes in {lo:g}-{hi:g} Hz "
            f"(at least {MIN_SAMPLES} at {fs:.4g} S/s)"
        )
    nper = welch_segment(yd.shape[1])
    f, sv = averaged_spectra(yd, fs, nper)
    if (hi - lo) < 4 * f[1]:
        raise ValueError(
            f"band {lo:g}-{hi:g} Hz holds fewer than 4 lines of the averaged spectrum "
            f"({f[1]:.3g} Hz apart from {seconds:.3g} s): widen the band or give a longer record"
        )
    peak_idx = _peaks(f, sv[:, 0], lo, hi)
    low = peak_idx[f[peak_idx] >= LOW_LINES * f[1]]
    f_low = max(lo, LOW_LINES * f[1], f[low[0]] if low.size else lo)
    runs = [
        _identify_part(ys, scale, sample_rate, part, nyq, max_order=max_order, block_rows=block_rows)
        for part in sub_bands(lo, hi, f_low, y.shape[0])
    ]
    candidates = [c for r in runs for c in r.candidates]
    modes, harmonics, f0, mode_of, dropped = select(
        candidates,
        frequency_hz=f,
        level=sv[:, 0],
        peak_idx=peak_idx,
        fe=fe,
        seconds=seconds,
        channels=y.shape[0],
    )
    notes = [
        f"SSI-cov on {y.shape[0]} channel(s), "
        + "; ".join(
            f"{r.settings.band[0]:.4g}-{r.settings.band[1]:.4g} Hz at {r.settings.sample_rate:.4g} S/s "
            f"({r.settings.block_rows} block rows, orders 2-{r.settings.max_order})"
            for r in runs
        )
        + f"; averaged spectra: Welch, Hann, {nper} samples ({f[1]:.3g} Hz), "
        f"{2 * yd.shape[1] // nper - 1} averages"
    ]
    if not modes:
        notes.append(
            f"no mode in {lo:g}-{hi:g} Hz: no group of poles stable at {MIN_STABLE_FRACTION:.0%} of the "
            "converged orders that is neither a tone nor noise (see dropped); a longer record, a "
            "band around one peak of the averaged spectrum, or more sensors would help"
        )
    return OMAResult(
        modes,
        harmonics,
        label_peaks(f, sv[:, 0], peak_idx, modes, harmonics),
        (float(lo), float(hi)),
        [r.settings for r in runs],
        f0,
        f,
        sv,
        _chart(runs, mode_of),
        list(channels or []),
        [d for r in runs for d in r.dropped] + dropped,
        notes,
    )
