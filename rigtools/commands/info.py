"""``rig info FILE``: summary of a recording (status, channels, points, durations)."""

from __future__ import annotations

import argparse
import json
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rigtools.recording import Recording

HELP = """\
Summarise a recording: status (complete / aborted with its reason / recording = being written
now, or its writer was killed), backend, software and schema versions, the channels (quantity,
units, sample rate, sensor) and one row per point with its parameters, samples and duration.
A point shown "incomplete" was cut off (writer killed or a write error): do not count it.

examples:
  rig info recordings/run.h5
  rig info --json recordings/run.h5 | python -m json.tool
"""

# How to show well-known parameters: label, SI factor, unit.
_DISPLAY = {
    "fe": ("fe", 1.0, "Hz"),
    "force_amplitude": ("F0", 1.0, "N"),
    "gap": ("gap", 1e3, "mm"),
    "force_amplitude_measured": ("F meas", 1.0, "N"),
    "drive_amplitude": ("drive", 1.0, "V"),
}


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "info",
        help="summarise a recording (points, channels, durations, status)",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("file", metavar="FILE", help="recording (.h5)")
    parser.add_argument(
        "--json", action="store_true", help="print the summary as JSON (root attributes, channels, points)"
    )
    parser.set_defaults(func=run)


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
                "state": _point_state(rec, p),
                "n_samples": p.n_samples,
                "duration_s": p.duration,
                "channels": list(p.channels),
            }
            for p in rec.points
        ],
        "total_duration_s": sum(p.duration for p in rec.points),
    }


def _point_state(rec: Recording, point) -> str:
    """``complete``, ``in progress`` (the live writer's open point) or ``incomplete``."""
    if point.complete:
        return "complete"
    if rec.writer is not None and rec.points and point is rec.points[-1]:
        return "in progress"
    return "incomplete"


def _format_params(params: dict[str, Any]) -> str:
    parts = []
    for key, value in params.items():
        if key in _DISPLAY and isinstance(value, (int, float)) and not isinstance(value, bool):
            label, factor, unit = _DISPLAY[key]
            parts.append(f"{label}={value * factor:.4g} {unit}")
        elif isinstance(value, bool):
            parts.append(f"{key}={'yes' if value else 'no'}")
        elif isinstance(value, float):
            parts.append(f"{key}={value:.4g}")
        else:
            parts.append(f"{key}={value}")
    return ", ".join(parts)


def run(args: argparse.Namespace) -> int:
    from rigtools.recording import open_recording

    with open_recording(args.file) as rec:
        info = summary(rec)
    if args.json:
        print(json.dumps(info, indent=1))
        return 0

    from rich.console import Console
    from rich.table import Table

    console = Console()
    colour = {"complete": "green", "aborted": "red"}.get(info["status"], "yellow")
    status = f"[{colour}]{info['status']}[/{colour}]"
    if info["status"] == "aborted":
        status += f" ({info['abort_reason']})"
    elif info["status"] == "recording" and info["writer"]:
        status += f" (being written now: {info['writer']}; showing what is there)"
    elif info["status"] == "recording":
        status += " (incomplete: the writer stopped without closing the file)"
    if info["end_status"]:
        status += f"; procedure {info['end_status']}" + (
            f" ({info['end_reason']})" if info["end_reason"] and info["status"] != "aborted" else ""
        )
    console.print(f"[bold]{info['path']}[/bold]  status {status}")
    console.print(
        f"backend {info['backend']}, created {info['created']}, "
        f"rigtools {info['software_version']}, schema v{info['schema_version']}"
        + (f", opened as {info['opened_as']}" if info["opened_as"] != "clean" else "")
    )
    console.print(f"{len(info['points'])} points, {info['total_duration_s']:.3f} s recorded")

    table = Table(title="channels")
    for column in ("name", "quantity", "units", "rate (Hz)", "sensitivity", "physical", "location"):
        table.add_column(column)
    for ch in info["channels"]:
        sens = "" if ch["sensitivity"] is None else f"{ch['sensitivity']:g} {ch['sensitivity_units'] or ''}"
        table.add_row(
            ch["name"],
            ch["quantity"],
            ch["units"],
            f"{ch['sample_rate']:g}",
            sens,
            ch["physical_channel"] or "",
            ch["location"] or "",
        )
    console.print(table)

    table = Table(title="points")
    for column in ("point", "parameters", "samples", "duration (s)", "state"):
        table.add_column(column, justify="right" if column in ("samples", "duration (s)") else "left")
    for p in info["points"]:
        table.add_row(
            f"{p['index']:04d}",
            _format_params(p["params"]),
            str(p["n_samples"]),
            f"{p['duration_s']:.3f}",
            p["state"] if p["complete"] else f"[yellow]{p['state']}[/yellow]",
        )
    console.print(table)
    return 0
