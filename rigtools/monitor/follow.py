"""Following a recording while it is written (or a finished one): what the monitor shows.

:class:`Follower` opens the recording read-only (SWMR while a writer runs, through
:func:`rigtools.recording.open_recording`), reads only the samples appended since its last look
into a bounded buffer of the latest ones, and turns them into a :class:`Snapshot`: decimated
traces (:mod:`.envelope`), the amplitude spectrum with its k·fe harmonics, the force-control
state, impacts per period, peaks against the safety limits, the points done and the status.
It never writes the recording; it holds the file open only while it reads (a few ms per look).

Live numbers come from the last whole periods (at most :data:`ANALYSIS_SECONDS`); once a point is
ended by its writer they are its record window's, analysed by :func:`rigtools.recording_analysis.periodic.analyze_periodic`,
the function ``rig analyze`` uses, so the two show the same numbers.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rigtools.errors import one_line
from rigtools.monitor.control_files import live_path, read_json
from rigtools.monitor.controlled import live_phase_deg, procedure_kind, row_fields, state_text
from rigtools.monitor.envelope import max_envelope, min_max_envelope
from rigtools.recording.lock import writer_alive
from rigtools.recording.schema import RecordingError, parse_utc
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL, DRIVE, FORCE, PASSIVE_SHROUD_ACCEL

#: Channels drawn as time traces (those a recording has).
TRACE_CHANNELS = (FORCE, ACTIVE_SHROUD_ACCEL, PASSIVE_SHROUD_ACCEL)
#: Periods of fe shown in the time traces.
TRACE_PERIODS = 5
#: Live analysis window (spectrum, F1, impacts): whole periods within this many seconds.
ANALYSIS_SECONDS = 1.0
#: Impacts are found in a window this much wider on both sides than the one they are counted in, s.
IMPACT_MARGIN_S = 0.01
#: Fewest periods the live analysis waits for.
MIN_PERIODS = 10
#: Harmonics marked in the spectrum.
K_MAX = 10
#: A file unreadable this long (s) is reported on the page.
UNREADABLE_S = 3.0
#: Harmonics named in the spectrum (the strongest, k >= 2, of the active shroud).
NAMED = 3


@dataclass(frozen=True)
class Snapshot:
    """What the monitor shows at one moment (plain data; the page draws it).

    Attributes
    ----------
    version
        Increases with every new snapshot.
    status
        ``waiting`` (no file yet), ``recording``, ``finished``, ``aborted``, ``failed`` or
        ``incomplete`` (writer gone without closing the file); ``status_text`` says more.
    point, n_points
        Index of the point shown and the number of points planned (or present).
    latest_t, latest_epoch
        Time of the newest sample shown, s from the point's start and s since the epoch.
    traces
        ``{channel: (times, values)}``, min/max envelopes of the last :data:`TRACE_PERIODS`.
    spectrum
        ``{channel: (frequencies, amplitudes)}``, peak amplitude, of the analysis window.
    harmonics
        ``(k, k·fe)`` marked; ``named``: ``(k, frequency, amplitude, channel)`` of the strongest.
    control
        ``target``, ``f1``, ``drive``, ``error``, ``updates``, ``settled``, ``phase``.
    impacts_per_period
        Over the analysis window (None without both shroud accelerations or fe).
    peaks
        One row per channel: ``channel``, ``units``, ``peak``, ``warning``, ``abort``.
    points
        One row per point: headline numbers (a controlled test's point also its
        :data:`rigtools.monitor.controlled.ROW_FIELDS`).
    kind
        ``"pll"`` or ``"cbc"`` for a controlled test (:mod:`.controlled`), else ``""``.
    phase_deg
        Phase of the active shroud displacement's fundamental to the force's, deg (a controlled
        test: live over the analysis window, or as the ended point was written).
    controlled_state
        A controlled test's state in words: a PLL's lock, a CBC's iteration.
    """

    version: int
    wall_time: float
    path: str
    status: str
    status_text: str
    point: int | None = None
    n_points: int = 0
    fe: float | None = None
    window: str = ""
    latest_t: float = 0.0
    latest_epoch: float | None = None
    units: dict[str, str] = field(default_factory=dict)
    traces: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    spectrum: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    harmonics: list[tuple[int, float]] = field(default_factory=list)
    named: list[tuple[int, float, float, str]] = field(default_factory=list)
    control: dict[str, Any] = field(default_factory=dict)
    impacts_per_period: float | None = None
    peaks: list[dict[str, Any]] = field(default_factory=list)
    points: list[dict[str, Any]] = field(default_factory=list)
    end: str = ""
    accepts_stop: bool = False
    kind: str = ""
    phase_deg: float | None = None
    controlled_state: str = ""


class _Buffer:
    """The latest samples of one point's channels (at most ``capacity`` per channel)."""

    def __init__(self, index: int, names: list[str], capacity: int) -> None:
        self.index, self.names, self.capacity = index, names, capacity
        self.data = np.zeros((len(names), 0))
        self.total = 0  # samples per channel in the point as of the last look
        self.read = 0  # samples per channel read from the file (each sample once)

    def extend(self, point) -> None:
        n = point.n_samples
        if n <= self.total:
            return
        first = max(self.total, n - self.capacity)
        new = np.vstack([np.asarray(point.channels[c][first:n], dtype=float) for c in self.names])
        self.read += n - first
        self.data = np.concatenate([self.data, new], axis=1)[:, -self.capacity :]
        self.total = n

    def last(self, name: str, n: int) -> np.ndarray:
        return self.data[self.names.index(name), -n:]


def _epoch(text: str) -> float | None:
    try:
        return parse_utc(text).timestamp()
    except (ValueError, TypeError):
        return None


class Follower:
    """Looks at a recording on every :meth:`poll` and keeps the latest :class:`Snapshot`.

    Parameters
    ----------
    path
        The recording (it may not exist yet: the snapshot then says ``waiting``).
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.version = 0
        self.snapshot = Snapshot(0, time.time(), str(self.path), "waiting", "waiting for the recording")
        self._buffer: _Buffer | None = None
        self._analysed: dict[int, dict[str, Any]] = {}  # ended points: index -> headline row
        self._limits: dict[str, tuple[float, float]] | None = None
        self._failing_since = 0.0
        self._key: tuple | None = None
        self._kind: str | None = None

    def poll(self) -> Snapshot:
        """Read what was appended since the last look; returns (and keeps) the new snapshot."""
        from rigtools.recording import open_recording

        if not self.path.exists():
            return self.snapshot
        try:
            # a live follower shows what is there: no sample scan per poll, damaged parts left out
            rec = open_recording(self.path, wait=False, skip_damaged=True, check_samples=False)
        except RecordingError as exc:
            # the writer adds structure for a few ms at a time: look again at the next poll, and
            # say so only when the file stays unreadable
            self._failing_since = self._failing_since or time.monotonic()
            if time.monotonic() - self._failing_since < UNREADABLE_S or self.snapshot.status == "waiting":
                return self.snapshot
            return self._publish(**{**_fields(self.snapshot), "status_text": f"cannot read the file ({exc})"})
        self._failing_since = 0.0
        with rec:
            return self._look(rec)

    # -- one look -------------------------------------------------------------------------------
    def _look(self, rec) -> Snapshot:
        live = read_json(live_path(self.path)) if rec.writer is not None else None
        last = rec.points[-1] if rec.points else None
        key = (
            rec.status,
            rec.writer,
            rec.attrs.get("end_status"),
            len(rec.points),
            None if last is None else (last.n_samples, last.complete),
            json.dumps(live, sort_keys=True),
        )
        if key == self._key:  # nothing new: the snapshot stands (no work, nothing sent)
            return self.snapshot
        self._key = key
        status, status_text, end = _status(rec)
        if self._limits is None:
            self._limits = _limits(rec)
        if self._kind is None:
            self._kind = procedure_kind(rec)
        points = self._points(rec)
        fields: dict[str, Any] = dict(
            status=status,
            status_text=status_text,
            end=end,
            points=points,
            n_points=len(rec.points),
            accepts_stop=bool(live and live.get("accepts_stop")),
            kind=self._kind,
        )
        event = dict((live or {}).get("event") or {})
        control = (live or {}).get("control") or {}
        if control.get("point") == event.get("point"):
            event["update"] = control.get("update")
        if event.get("n_points"):
            fields["n_points"] = max(len(rec.points), int(event["n_points"]))
        if not rec.points:
            return self._publish(**fields)
        point = rec.points[-1]
        if point.n_samples == 0 and len(rec.points) > 1:
            point = rec.points[-2]  # a point just begun: keep showing the one before
        fields.update(self._point_view(point, event, ended=point.complete))
        if self._kind:
            fields["controlled_state"] = state_text(
                self._kind, fields.get("control") or {}, event, points, fields.get("point")
            )
        return self._publish(**fields)

    def _point_view(self, point, event: dict, ended: bool) -> dict[str, Any]:
        rate = float(point.sample_rate or 0.0)
        names = [c for c in point.channels if c != "contact_force"]
        fe = point.params.get("fe")
        fe = float(fe) if isinstance(fe, (int, float)) and fe > 0 else None
        seconds = max(ANALYSIS_SECONDS, (MIN_PERIODS + 1) / fe if fe else 0.0) + 2 * IMPACT_MARGIN_S
        capacity = int(seconds * rate) + 1
        if self._buffer is None or self._buffer.index != point.index or self._buffer.names != names:
            self._buffer = _Buffer(point.index, names, capacity)
        buf = self._buffer
        buf.extend(point)
        view: dict[str, Any] = {
            "point": point.index,
            "fe": fe,
            "latest_t": buf.total / rate if rate else 0.0,
            "units": {c: point.channels[c].units for c in names},
        }
        start_epoch = _epoch(point.start_time)
        if start_epoch is not None and rate:
            view["latest_epoch"] = start_epoch + point.channels[names[0]].t0 + buf.total / rate
        if not rate or not buf.total:
            return view
        traced = [c for c in TRACE_CHANNELS if c in names] or names[:3]
        n_trace = round(TRACE_PERIODS * rate / fe) if fe else int(0.1 * rate)
        first = max(0, buf.total - min(n_trace, buf.data.shape[1]))
        view["traces"] = {
            c: min_max_envelope(buf.last(c, buf.total - first), first / rate, 1.0 / rate) for c in traced
        }
        view["peaks"] = self._peaks(point, names)
        if ended and fe and point.index in self._analysed:
            view.update(self._analysed[point.index]["view"])
            return view
        view.update(self._live_analysis(buf, rate, fe, traced, point, event))
        return view

    def _live_analysis(self, buf: _Buffer, rate: float, fe: float | None, traced, point, event) -> dict:
        from rigtools.analysis.harmonics import harmonic_amplitudes
        from rigtools.analysis.impacts import detect_impacts
        from rigtools.analysis.spectra import amplitude_spectrum

        have = buf.data.shape[1]
        if fe:
            per = rate / fe
            periods = int(min(have, ANALYSIS_SECONDS * rate) / per)
            if periods < MIN_PERIODS:
                return {"window": f"waiting for {MIN_PERIODS} periods", "control": _control(point, event)}
            n = round(periods * per)
            window = f"last {periods} periods"
        else:
            n, window = min(have, int(ANALYSIS_SECONDS * rate)), "last samples"
        out: dict[str, Any] = {"window": window}
        arrays = {c: buf.last(c, n) for c in buf.names}
        out.update(_spectrum({c: arrays[c] for c in traced}, rate, fe, amplitude_spectrum))
        f1 = drive = None
        if fe and FORCE in arrays:
            f1 = float(harmonic_amplitudes(arrays[FORCE], rate, fe, 1).amplitude[0])
        if fe and DRIVE in arrays:
            drive = float(harmonic_amplitudes(arrays[DRIVE], rate, fe, 1).amplitude[0])
        out["control"] = _control(point, event, f1, drive)
        if self._kind and fe and FORCE in arrays and ACTIVE_SHROUD_ACCEL in arrays:
            out["phase_deg"] = live_phase_deg(
                arrays[FORCE], arrays[ACTIVE_SHROUD_ACCEL], rate, fe, harmonic_amplitudes
            )
        margin = int(IMPACT_MARGIN_S * rate)
        if fe and ACTIVE_SHROUD_ACCEL in arrays and have >= n + 2 * margin:
            # impacts counted in whole periods that end `margin` before the newest sample, found
            # in a window `margin` wider on both sides: one at a window's edge is counted once
            # (the detector ignores a few ms at each end of what it is given)
            wide = {
                c: buf.last(c, n + 2 * margin)
                for c in (ACTIVE_SHROUD_ACCEL, PASSIVE_SHROUD_ACCEL, FORCE)
                if c in buf.names
            }
            imp = detect_impacts(
                wide[ACTIVE_SHROUD_ACCEL],
                rate,
                fe,
                passive_acceleration=wide.get(PASSIVE_SHROUD_ACCEL),
                force=wide.get(FORCE),
            )
            inside = np.count_nonzero((imp.times >= margin / rate) & (imp.times < (margin + n) / rate))
            out["impacts_per_period"] = inside / (n / rate * fe)
        return out

    def _peaks(self, point, names: list[str]) -> list[dict[str, Any]]:
        buf = self._buffer
        assert buf is not None
        rows = []
        for c in names:
            warning, abort = (self._limits or {}).get(c, (None, None))
            peak = float(np.max(np.abs(buf.last(c, buf.data.shape[1])))) if buf.data.shape[1] else 0.0
            rows.append(
                {
                    "channel": c,
                    "units": point.channels[c].units,
                    "peak": peak,
                    "warning": warning,
                    "abort": abort,
                }
            )
        return rows

    # -- points done ----------------------------------------------------------------------------
    def _points(self, rec) -> list[dict[str, Any]]:
        rows = []
        for p in rec.points:
            if _measured(p) and p.index not in self._analysed:
                self._analysed[p.index] = _analyse_point(p)
            row = dict(self._analysed[p.index]["row"]) if _measured(p) else _row(p, None)
            if p.complete and not _measured(p):
                row["state"] = "stopped"  # ended by a stop or a fault before its record
            elif not p.complete:
                row["state"] = (
                    "in progress" if rec.writer is not None and p is rec.points[-1] else "incomplete"
                )
            rows.append(row)
        return rows

    def _publish(self, **fields: Any) -> Snapshot:
        self.version += 1
        self.snapshot = Snapshot(self.version, time.time(), str(self.path), **fields)
        return self.snapshot


def unreadable_ended(path: str | Path) -> str | None:
    """Why a recording no process writes cannot be shown, in one line naming it; ``None`` when it
    is not a file (absent: a run not started yet), being written, or shows. ``rig monitor`` says this and
    ends instead of serving a page that waits for a damaged file for ever.

    Parameters
    ----------
    path
        The recording.
    """
    from rigtools.recording import open_recording

    path = Path(path)
    if not path.is_file() or writer_alive(path) is not None:  # a folder: serve() says so
        return None
    try:
        with open_recording(path, wait=False, skip_damaged=True, check_samples=False) as rec:
            Follower(path)._look(rec)
    except Exception as exc:  # noqa: BLE001 - any failure to show it is said, in one line
        text = one_line(exc)
        return text if str(path) in text else f"{path}: {text}"
    return None


def _fields(s: Snapshot) -> dict[str, Any]:
    """A snapshot's fields but its version and time (to publish it again with a change)."""
    return {k: v for k, v in vars(s).items() if k not in ("version", "wall_time", "path")}


# -- helpers ------------------------------------------------------------------------------------
def _status(rec) -> tuple[str, str, str]:
    """``(status, text, what happened at the end)`` of an open recording."""
    end_status = rec.attrs.get("end_status") or ""
    end_reason = rec.attrs.get("end_reason") or ""
    if rec.status == "recording":
        if rec.writer is not None:
            return "recording", f"recording ({rec.writer})", ""
        return "incomplete", "incomplete: the writer stopped without closing the file", ""
    if rec.status == "complete":
        return "finished", "finished", _end_text(rec, "finished", "")
    word = end_status or rec.abort_reason.split(":", 1)[0] or "aborted"
    reason = end_reason or rec.abort_reason.split(":", 1)[-1].strip()
    word = word if word in ("aborted", "failed") else "aborted"
    return word, f"{word}: {reason}", _end_text(rec, word, reason)


def _end_text(rec, word: str, reason: str) -> str:
    """The run's end in a sentence: how it ended and the drive's last value in the record."""
    text = f"the run {word}" + (f" ({reason})" if reason else "")
    if rec.points:
        p = rec.points[-1]
        if DRIVE in p.channels and p.n_samples and p.sample_rate:
            n = p.n_samples
            tail = np.asarray(p.channels[DRIVE][max(0, n - int(0.01 * p.sample_rate)) : n], dtype=float)
            text += (
                f"; drive {float(np.max(np.abs(tail))):.3g} V at the end of point {p.index + 1} "
                f"(t = {n / p.sample_rate:.3f} s)"
            )
    return text


def _limits(rec) -> dict[str, tuple[float, float]]:
    try:
        cfg = rec.rig_config()
    except Exception:  # noqa: BLE001 - any rig text that is not ours (other software): no limits to show
        return {}
    limits = {name: (lim.warning, lim.abort) for name, lim in cfg.safety.limits.items()}
    limits.setdefault(DRIVE, (cfg.safety.max_drive, cfg.safety.max_drive))
    return limits


def _control(point, event: dict, f1: float | None = None, drive: float | None = None) -> dict[str, Any]:
    params = point.params
    target = params.get("force_amplitude")
    target = float(target) if isinstance(target, (int, float)) else None
    if _measured(point):
        f1 = params.get("force_amplitude_measured", f1)
        drive = params.get("drive_amplitude", drive)
    same_point = event.get("point") == point.index + 1
    updates = (
        params.get("control_updates") if _measured(point) else (event.get("update") if same_point else None)
    )
    return {
        "target": target,
        "f1": f1,
        "drive": drive,
        "error": (f1 / target - 1.0) if f1 is not None and target else None,
        "updates": updates,
        "settled": params.get("settled") if _measured(point) else None,
        "phase": ("done" if _measured(point) else "stopped")
        if point.complete
        else (event.get("kind", "") if same_point else ""),
    }


def _spectrum(
    arrays: dict[str, np.ndarray], rate: float, fe: float | None, amplitude_spectrum
) -> dict[str, Any]:
    spectra = {}
    full = {}
    for c, x in arrays.items():
        freqs, amp = amplitude_spectrum(x, rate)
        full[c] = (freqs, amp)
        spectra[c] = max_envelope(freqs, amp)
    out: dict[str, Any] = {"spectrum": spectra}
    if not fe:
        return out
    k_top = max(1, min(K_MAX, int(rate / 2 / fe - 1e-9)))
    out["harmonics"] = [(k, k * fe) for k in range(1, k_top + 1)]
    ref = ACTIVE_SHROUD_ACCEL if ACTIVE_SHROUD_ACCEL in full else next(iter(full))
    freqs, amp = full[ref]
    df = freqs[1] - freqs[0]
    levels = []
    for k in range(2, k_top + 1):
        i = round(k * fe / df)
        lo, hi = max(0, i - 2), min(len(amp), i + 3)
        levels.append((k, k * fe, float(amp[lo:hi].max()), ref))
    out["named"] = sorted(levels, key=lambda r: -r[2])[:NAMED]
    return out


def _measured(point) -> bool:
    """True for a point ended normally with its record (a stopped point is ended too, but
    ``point_complete`` is false and it has no record window)."""
    return point.complete and point.params.get("point_complete", True) is not False


def _row(point, analysis: dict | None) -> dict[str, Any]:
    p = point.params
    row = {
        "point": point.index,
        "fe": p.get("fe"),
        "gap": p.get("gap"),
        "target": p.get("force_amplitude"),
        "f1": p.get("force_amplitude_measured"),
        "drive": p.get("drive_amplitude"),
        "settled": p.get("settled"),
        "direction": p.get("direction"),
        "response": None,
        "impacts_per_period": None,
        "state": "complete" if point.complete else "incomplete",
        **row_fields(p),
    }
    if analysis is not None:
        row.update(analysis)
    return row


def _analyse_point(point) -> dict[str, Any]:
    """An ended point, once: F1 and impacts per period of its record window as ``rig analyze``
    finds them (:func:`rigtools.recording_analysis.periodic.analyze_periodic`: the same window, the same impact
    detection). F1 is fitted alone: over whole periods the harmonics are orthogonal, so it equals
    the fit with every harmonic that ``rig analyze`` makes, at a fraction of the cost."""
    from rigtools.analysis.harmonics import harmonic_amplitudes
    from rigtools.analysis.impacts import detect_impacts
    from rigtools.analysis.spectra import amplitude_spectrum
    from rigtools.recording_analysis.samples import WINDOW_SAMPLES, record_window

    fe = point.params.get("fe")
    if not isinstance(fe, (int, float)) or fe <= 0 or not point.sample_rate:
        return {"row": _row(point, None), "view": {}}
    rate = float(point.sample_rate)
    start, n = record_window(point)
    if n < 3:
        return {"row": _row(point, None), "view": {}}
    chans = point.channels
    f1 = None
    if FORCE in chans:
        f1 = float(
            harmonic_amplitudes(
                np.asarray(chans[FORCE][start : start + n], dtype=float), rate, fe, 1
            ).amplitude[0]
        )
    response = None
    if ACTIVE_SHROUD_ACCEL in chans:  # the response a stepped sine's jumps show in: its fundamental
        response = float(
            harmonic_amplitudes(
                np.asarray(chans[ACTIVE_SHROUD_ACCEL][start : start + n], dtype=float), rate, fe, 1
            ).amplitude[0]
        )
    ipp = None
    if ACTIVE_SHROUD_ACCEL in chans:
        per = rate / fe  # the window rig analyze takes impacts from
        m = n if n <= WINDOW_SAMPLES else int(np.floor(WINDOW_SAMPLES / per) * per)
        a = start + n - m
        window = {c: np.asarray(chans[c][a : a + m], dtype=float) for c in TRACE_CHANNELS if c in chans}
        imp = detect_impacts(
            window[ACTIVE_SHROUD_ACCEL],
            rate,
            fe,
            passive_acceleration=window.get(PASSIVE_SHROUD_ACCEL),
            force=window.get(FORCE),
        )
        ipp = float(imp.impacts_per_period)
    n_spec = min(n, int(math.floor(ANALYSIS_SECONDS * fe) * rate / fe) or n)
    traced = [c for c in TRACE_CHANNELS if c in point.channels]
    arrays = {c: np.asarray(point.channels[c][start + n - n_spec : start + n], dtype=float) for c in traced}
    view: dict[str, Any] = {
        "window": f"record window ({n / rate * fe:.0f} periods)",
        "impacts_per_period": ipp,
    }
    if isinstance(point.params.get("phase_deg"), (int, float)):
        view["phase_deg"] = float(point.params["phase_deg"])  # as the procedure measured it
    if arrays:
        view.update(_spectrum(arrays, rate, float(fe), amplitude_spectrum))
        n_trace = min(n_spec, round(TRACE_PERIODS * rate / fe))
        first = start + n - n_trace
        view["traces"] = {c: min_max_envelope(arrays[c][-n_trace:], first / rate, 1.0 / rate) for c in traced}
    view["control"] = _control(point, {}, f1, point.params.get("drive_amplitude"))
    view["control"]["f1"] = f1
    view["control"]["error"] = (
        f1 / view["control"]["target"] - 1.0 if f1 and view["control"]["target"] else None
    )
    row = _row(point, {"f1": f1, "impacts_per_period": ipp, "response": response})
    return {"row": row, "view": view}
