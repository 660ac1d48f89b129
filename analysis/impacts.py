"""Shroud impacts from sampled signals only: shroud accelerations (and optionally the force).

A lab has no contact-force sensor, so impacts are found where the measured signals carry them:
each contact is a short force pulse of opposite sign on the two shrouds, so the *relative*
acceleration ``a_active - a_passive`` holds a sharp pulse whose width is the contact duration,
while the smooth forced response (a few low harmonics and the ringing of the blade modes it
excites) varies slowly.

Method (:func:`detect_impacts`):

1. **Impulsive part**: the relative acceleration (or the one shroud given) through a zero-phase
   4th-order Butterworth high-pass at ``highpass_hz`` (default ``min(30 fe, sample_rate / 8)``):
   a contact of duration ``tau`` has its energy up to about ``1 / tau``, above the cut-off.
2. **Detection**: peaks of its magnitude above ``threshold`` robust standard deviations (median
   absolute deviation / 0.6745) of the impulsive part (and at least 1e-3 of the signal's peak),
   ignoring the first and last 4 cut-off periods (filter start-up); a response with no impacts
   (or only noise) gives none. Each detection is moved to the largest sample-to-sample step of the
   unfiltered signal within 0.6 cut-off periods (the zero-phase filter rings on both sides).
3. **Grouping, onset and contact duration**: detections closer than ``min_separation`` (default
   ``1 / (8 fe)``) belong to one impact (the zero-phase filter rings on both sides of a pulse).
   The impact is timed at the first sample-to-sample step of the unfiltered signal inside its
   group that is at least half the largest: a contact force with damping jumps where the
   contact closes. The contact duration runs to the last later step of at least
   ``release_fraction`` of that one (the force jumping back to zero where a damped contact
   opens). A contact that opens smoothly (force decaying to zero, as in the simulated rig's
   contact law) has no such step; then, if the record is periodic (step 4), the relative
   displacement is rebuilt from the relative acceleration by integrating it twice over whole
   periods (:func:`periodic_double_integral`, exact up to a constant for a periodic record),
   and the contact lasts until it falls back below its level at the closing instant (the gap).
   Otherwise the impact's duration is NaN. ``contact_duration`` is the median over impacts
   (``None`` if none has one). Chattering contacts closer than ``min_separation`` count as one.
   Only meaningful with both shroud accelerations (relative motion).
4. **Periodicity**: the smallest ``m`` (1..``max_multiple``) such that every impact at ``t`` has a
   partner at ``t + m / fe`` (and ``t - m / fe``) within ``time_tolerance``, inside the record:
   the response is then period-``m``; none found means not periodic (quasi-periodic or chaotic)
   or too short a record (fewer than ``2 m`` periods).
5. **Peak levels**: for each channel given, the largest ``|x|`` of the raw signal (peak, units of
   the channel) and the mean of the impulsive part's ``|x|`` at the impacts.

Times are seconds from the first sample.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import signal


@dataclass(frozen=True)
class ImpactAnalysis:
    """Impacts found in one record (see the module docstring for the method).

    Attributes
    ----------
    times
        (n,) impact instants, s from the first sample.
    impacts_per_period
        Impacts per excitation period over the record (``n * fe / duration``).
    contact_duration
        Median contact-duration estimate, s (None with no impact or unresolved pulses).
    periodic
        True when the impact pattern repeats every ``period_multiple`` excitation periods.
    period_multiple
        The smallest such multiple (1 = one pattern per period), None if not periodic.
    peak_levels
        ``{channel: largest |x| of the raw record}`` (peak, channel units).
    impulse_levels
        ``{channel: mean |impulsive part| at the impacts}`` (peak, channel units; 0 if none).
    highpass_hz
        Cut-off used for the impulsive part, Hz.
    durations
        (n,) contact duration of each impact, s (NaN where only one end was detected).
    n_periods
        Excitation periods in the record.
    """

    times: np.ndarray
    impacts_per_period: float
    contact_duration: float | None
    periodic: bool
    period_multiple: int | None
    peak_levels: dict[str, float] = field(default_factory=dict)
    impulse_levels: dict[str, float] = field(default_factory=dict)
    highpass_hz: float = float("nan")
    n_periods: float = float("nan")
    durations: np.ndarray = field(default_factory=lambda: np.array([]))

    @property
    def n_impacts(self) -> int:
        return int(self.times.size)

    def to_dict(self) -> dict:
        """Plain-Python summary (for JSON)."""
        return {
            "n_impacts": self.n_impacts,
            "impacts_per_period": float(self.impacts_per_period),
            "contact_duration_s": None if self.contact_duration is None else float(self.contact_duration),
            "periodic": bool(self.periodic),
            "period_multiple": self.period_multiple,
            "peak_levels": {k: float(v) for k, v in self.peak_levels.items()},
            "impulse_levels": {k: float(v) for k, v in self.impulse_levels.items()},
            "highpass_hz": float(self.highpass_hz),
            "n_periods": float(self.n_periods),
        }


def impulsive_part(x: np.ndarray, sample_rate: float, highpass_hz: float) -> np.ndarray:
    """Zero-phase 4th-order Butterworth high-pass of ``x`` at ``highpass_hz``."""
    if not 0 < highpass_hz < sample_rate / 2:
        raise ValueError(f"highpass_hz must lie between 0 and {sample_rate / 2:g} Hz, got {highpass_hz:g}")
    sos = signal.butter(4, highpass_hz, btype="highpass", fs=sample_rate, output="sos")
    return signal.sosfiltfilt(sos, np.asarray(x, dtype=float))


def _robust_sigma(x: np.ndarray) -> float:
    return float(np.median(np.abs(x - np.median(x))) / 0.6745)


def periodic_double_integral(x: np.ndarray, sample_rate: float, base_hz: float) -> np.ndarray:
    """Zero-mean double time integral of a periodic record (acceleration -> displacement).

    The record is cut to the largest whole number of periods of ``base_hz`` (to the nearest
    sample) and integrated in the frequency domain, ``U = -A / (2 pi f)**2`` with the mean
    dropped; the result is that period-periodic displacement over the whole record (repeated
    past the cut). Exact for a periodic record of whole periods; otherwise leakage of the cut."""
    x = np.asarray(x, dtype=float)
    n_per = int(np.floor(x.size * base_hz / sample_rate))
    if n_per < 1:
        raise ValueError("record shorter than one period")
    n = round(n_per * sample_rate / base_hz)
    n = min(n, x.size)
    spec = np.fft.rfft(x[:n])
    f = np.fft.rfftfreq(n, 1.0 / sample_rate)
    spec[0] = 0.0
    spec[1:] /= -((2 * np.pi * f[1:]) ** 2)
    u = np.fft.irfft(spec, n=n)
    return np.resize(u, x.size)


def _opening_time(u: np.ndarray, i: int) -> float:
    """Samples from the contact closing (between samples ``i - 1`` and ``i``) to where the relative
    displacement ``u`` falls back below its level there, linearly interpolated; NaN if it does
    not within the record."""
    level = 0.5 * (u[i - 1] + u[i])
    below = np.flatnonzero(u[i + 1 :] < level)
    if below.size == 0:
        return float("nan")
    j = i + 1 + int(below[0])
    frac = (u[j - 1] - level) / (u[j - 1] - u[j])
    return (j - 1 + frac) - (i - 0.5)


def period_multiple(
    times: np.ndarray, fe: float, duration: float, *, max_multiple: int = 8, time_tolerance: float
) -> int | None:
    """Smallest ``m`` for which the impact times repeat after ``m / fe`` (see module docstring)."""
    t = np.sort(np.asarray(times, dtype=float))
    if t.size == 0:
        return None
    for m in range(1, int(max_multiple) + 1):
        shift = m / fe
        if duration < 2 * shift:
            return None
        ok = True
        for direction in (+1, -1):
            target = t + direction * shift
            inside = (target > time_tolerance) & (target < duration - time_tolerance)
            if not np.any(inside):
                ok = False
                break
            j = np.clip(np.searchsorted(t, target[inside]), 1, t.size - 1)
            nearest = np.minimum(np.abs(t[j] - target[inside]), np.abs(t[j - 1] - target[inside]))
            if np.any(nearest > time_tolerance):
                ok = False
                break
        if ok:
            return m
    return None


def detect_impacts(
    active_acceleration: np.ndarray,
    sample_rate: float,
    fe: float,
    *,
    passive_acceleration: np.ndarray | None = None,
    force: np.ndarray | None = None,
    highpass_hz: float | None = None,
    threshold: float = 8.0,
    min_separation: float | None = None,
    max_multiple: int = 8,
    time_tolerance: float | None = None,
    release_fraction: float = 0.2,
) -> ImpactAnalysis:
    """Impacts per period, peak levels, contact duration and periodicity from sampled signals.

    Parameters
    ----------
    active_acceleration
        (n,) active shroud acceleration, m/s², in the impact direction.
    sample_rate
        Samples per second, Hz.
    fe
        Excitation frequency, Hz.
    passive_acceleration
        (n,) passive shroud acceleration, m/s² (same direction). When given, impacts are found on
        the relative acceleration (stronger, and the common smooth motion cancels).
    force
        (n,) force-sensor signal, N: only its peak levels are reported.
    highpass_hz
        Cut-off of the impulsive part, Hz (default ``min(30 fe, sample_rate / 8)``).
    threshold
        Detection level in robust standard deviations of the impulsive part.
    min_separation
        Detections closer than this are one impact, s (default ``1 / (8 fe)``); must exceed the
        contact duration.
    max_multiple
        Largest period multiple tried.
    time_tolerance
        Timing tolerance of the periodicity check, s (default ``max(3 / sample_rate, 0.01 / fe)``).
    release_fraction
        A step of at least this fraction of the closing step marks the contact opening.

    Returns
    -------
    ImpactAnalysis

    Examples
    --------
    A 50 Hz response with one sharp impact per period, 1 s at 10 kHz:

    >>> import numpy as np
    >>> from rigtools.analysis.impacts import detect_impacts
    >>> fs, fe = 10000.0, 50.0
    >>> t = np.arange(int(fs)) / fs
    >>> acceleration = 100.0 * np.sin(2 * np.pi * fe * t)
    >>> acceleration[np.arange(50) * 200 + 50] += 2000.0
    >>> found = detect_impacts(acceleration, fs, fe)
    >>> found.impacts_per_period, found.periodic, found.period_multiple
    (1.0, True, 1)
    """
    a = np.asarray(active_acceleration, dtype=float)
    if a.ndim != 1 or a.size < 16:
        raise ValueError(f"need a 1-D record of at least 16 samples, got shape {a.shape}")
    if not (sample_rate > 0 and fe > 0):
        raise ValueError("sample_rate and fe must be positive")
    channels: dict[str, np.ndarray] = {"active_acceleration": a}
    if passive_acceleration is not None:
        channels["passive_acceleration"] = np.asarray(passive_acceleration, dtype=float)
    if force is not None:
        channels["force"] = np.asarray(force, dtype=float)
    for name, x in channels.items():
        if x.shape != a.shape:
            raise ValueError(f"{name} has {x.shape} samples, active_acceleration {a.shape}")
    fc = float(highpass_hz) if highpass_hz is not None else min(30.0 * fe, sample_rate / 8.0)
    base = a - channels["passive_acceleration"] if passive_acceleration is not None else a
    hp = impulsive_part(base, sample_rate, fc)
    mag = np.abs(hp)
    sigma = _robust_sigma(hp)
    sep = float(min_separation) if min_separation is not None else 1.0 / (8.0 * fe)
    # level: threshold robust sigmas, and at least 1e-3 of the signal's peak (a noise-free smooth
    # record has a vanishing sigma); detections within 4 cut-off periods of either end are the
    # filter's start-up transients, not impacts
    level = max(threshold * sigma, 1e-3 * float(np.max(np.abs(base))))
    found, _ = signal.find_peaks(mag, height=level if level > 0 else np.inf)
    edge = int(np.ceil(4.0 * sample_rate / fc))
    found = found[(found >= edge) & (found < mag.size - edge)]
    groups: list[list[int]] = []
    for i in found:
        if groups and (i - groups[-1][-1]) < sep * sample_rate:
            groups[-1].append(int(i))
        else:
            groups.append([int(i)])
    # the zero-phase filter rings before a jump as much as after it, so the detections of one
    # impact spread over a few cut-off periods: place the impact on the largest sample-to-sample
    # step of the unfiltered signal inside its group (the contact closing), and its end on the
    # last step after it of at least release_fraction of that size (a damped contact opening)
    step = np.abs(np.diff(base))
    w = int(np.ceil(sample_rate / fc))
    onsets: list[int] = []
    ends: list[float] = []  # contact durations, s (NaN where no opening is seen)
    for g in groups:
        lo, hi = max(g[0] - w, 0), min(g[-1] + w, step.size)
        seg = step[lo:hi]
        k = int(np.flatnonzero(seg >= 0.5 * seg.max())[0])  # the first of the large steps
        onsets.append(lo + k + 1)
        after = np.flatnonzero(seg[k + 2 :] >= release_fraction * seg[k])
        ends.append((after[-1] + 1) / sample_rate + 1.0 / sample_rate if after.size else np.nan)
    peaks = np.array(onsets, dtype=int)
    durations = np.array(ends)
    duration = a.size / sample_rate
    times = peaks / sample_rate
    tol = float(time_tolerance) if time_tolerance is not None else max(3.0 / sample_rate, 0.01 / fe)
    m = period_multiple(times, fe, duration, max_multiple=max_multiple, time_tolerance=tol)
    if m is not None and np.any(~np.isfinite(durations)):
        durations = durations.copy()
        u = periodic_double_integral(base, sample_rate, fe / m)
        for j, i in enumerate(peaks):
            if not np.isfinite(durations[j]) and 1 <= i < u.size - 1:
                durations[j] = _opening_time(u, int(i)) / sample_rate
    contact = float(np.nanmedian(durations)) if np.any(np.isfinite(durations)) else None
    impulse_levels = {}
    for name, x in channels.items():
        if peaks.size:
            hx = np.abs(impulsive_part(x, sample_rate, fc))
            spans = [(g[0], g[-1]) for g in groups]
            half = max(2, round(2e-4 * sample_rate))
            impulse_levels[name] = float(
                np.mean([hx[max(lo - half, 0) : hi + half + 1].max() for lo, hi in spans])
            )
        else:
            impulse_levels[name] = 0.0
    return ImpactAnalysis(
        times=times,
        impacts_per_period=float(peaks.size / (duration * fe)),
        contact_duration=contact,
        periodic=m is not None,
        period_multiple=m,
        peak_levels={name: float(np.max(np.abs(x))) for name, x in channels.items()},
        impulse_levels=impulse_levels,
        highpass_hz=fc,
        n_periods=duration * fe,
        durations=durations,
    )


def impacts_from_contact_force(contact_force: np.ndarray, sample_rate: float, fe: float) -> dict:
    """Reference values from a simulated contact force (the truth a lab does not have): onset
    times (s), impacts per period and the median contact duration (s)."""
    fc = np.asarray(contact_force, dtype=float)
    closed = fc > 0
    onsets = np.flatnonzero(closed[1:] & ~closed[:-1]) + 1
    ends = np.flatnonzero(~closed[1:] & closed[:-1]) + 1
    durations = [(ends[ends > s][0] - s) / sample_rate for s in onsets if np.any(ends > s)]
    return {
        "onsets": onsets / sample_rate,
        "impacts_per_period": onsets.size / (fc.size / sample_rate * fe),
        "contact_duration": float(np.median(durations)) if durations else None,
    }
