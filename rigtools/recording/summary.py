"""What a recording holds, for a person or a script (``rig info``): status, backend, versions, the
channels and one entry per point, as plain data; and parameter values written for reading
(:mod:`rigtools.readable`'s significant digits, long arrays summarised)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rigtools.recording.reader import Point, Recording

from rigtools.readable import number

ARRAY_ITEMS = 6  # longer lists and arrays are summarised

# How to show well-known parameters: label, SI factor, unit.
_DISPLAY = {
    "fe": ("fe", 1.0, "Hz"),
    "force_amplitude": ("F0", 1.0, "N"),
    "gap": ("gap", 1e3, "mm"),
    "force_amplitude_measured": ("F meas", 1.0, "N"),
    "drive_amplitude": ("drive", 1.0, "V"),
}


def summary(rec: Recording) -> dict[str, Any]:
    """JSON-able summary of a recording (what ``rig info --json`` prints)."""
    channels: dict[str, dict[str, Any]] = {}
    for point in rec.points:
        for name, ch in point.channels.items():
            channels.setdefault(
                name,
                {
                    "name": name,
                    "quantity": ch.quantity,
                    "units": ch.units,
                    "sample_rate": ch.sample_rate,
                    "t0": ch.t0,
                    "sensitivity": ch.sensitivity,
                    "sensitivity_units": ch.sensitivity_units,
                    "physical_channel": ch.physical_channel,
                    "location": ch.location,
                    "node": ch.node,
                    "direction": ch.direction,
                },
            )
    return {
        "path": rec.path,
        "status": rec.status,
        "complete": rec.complete,
        "abort_reason": rec.abort_reason,
        "end_status": rec.attrs.get("end_status"),
        "end_reason": rec.attrs.get("end_reason"),
        "backend": rec.backend,
        "created": rec.created,
        "ended": rec.ended,
        "software_version": rec.software_version,
        "schema_version": rec.schema_version,
        "opened_as": rec.opened_as,
        "writer": rec.writer,
        "experiment": rec.experiment,
        "channels": list(channels.values()),
        "points": [
            {
                "index": p.index,
                "params": p.params,
                "start_time": p.start_time,
                "end_time": p.end_time,
                "ended": p.ended,
                "complete": p.complete,
                "state": point_state(rec, p),
                "n_samples": p.n_samples,
                "duration_s": p.duration,
                "channels": list(p.channels),
            }
            for p in rec.points
        ],
        "total_duration_s": sum(p.duration for p in rec.points),
        "notes": list(rec.notes),  # what --skip-damaged left out of a damaged file
    }


def point_state(rec: Recording, point: Point) -> str:
    """``complete``, ``stopped`` (ended by its writer, but the procedure was stopped inside it:
    ``point_complete`` false, as the monitor says), ``in progress`` (the live writer's open
    point) or ``incomplete``."""
    if point.complete:
        return "stopped" if point.stopped else "complete"
    if rec.writer is not None and rec.points and point is rec.points[-1]:
        return "in progress"
    return "incomplete"


def left_out_lines(points: list[Point]) -> list[str]:
    """One line per reason naming the points an export leaves out, because their record is not
    a whole measurement: cut off (their writer never ended them) or stopped inside
    (:attr:`Point.stopped <rigtools.recording.reader.Point.stopped>`). Empty if none."""
    cut = [p.index for p in points if not p.complete]
    stopped = [p.index for p in points if p.complete and p.stopped]
    lines = []
    for indices, why in (
        (cut, "its writer never ended it (the run was cut off), its record is incomplete"),
        (stopped, "the run was stopped inside it (point_complete false), its record is cut short"),
    ):
        if indices:
            names = ", ".join(str(i) for i in indices)
            lines.append(f"point{'s' if len(indices) > 1 else ''} {names} not exported: {why}")
    return lines


def format_value(value: Any) -> str:
    """A parameter value written for a person.

    Numbers to :data:`rigtools.readable.DIGITS` significant digits, booleans as yes/no, and an array or list longer
    than :data:`ARRAY_ITEMS` summarised by its length, smallest and largest value
    (``[100 values, 0 .. 99]``).
    """
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return number(value)
    if isinstance(value, (list, tuple)) or hasattr(value, "tolist"):
        items = value.tolist() if hasattr(value, "tolist") else list(value)
        if not isinstance(items, list):
            return format_value(items)
        numbers = [v for v in items if isinstance(v, (int, float)) and not isinstance(v, bool)]
        if len(items) > ARRAY_ITEMS and len(numbers) == len(items):
            return f"[{len(items)} values, {number(float(min(numbers)))} .. {number(float(max(numbers)))}]"
        if len(items) > ARRAY_ITEMS:
            return f"[{len(items)} items: {', '.join(format_value(v) for v in items[:2])}, ...]"
        return "[" + ", ".join(format_value(v) for v in items) + "]"
    return str(value)


def format_params(params: dict[str, Any]) -> str:
    parts = []
    for key, value in params.items():
        if key in _DISPLAY and isinstance(value, (int, float)) and not isinstance(value, bool):
            label, factor, unit = _DISPLAY[key]
            parts.append(f"{label}={number(float(value * factor))} {unit}")
        else:
            parts.append(f"{key}={format_value(value)}")
    return ", ".join(parts)
