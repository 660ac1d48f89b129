"""``rig info FILE``: summary of a recording (status, channels, points, durations), an FRF set
or a branches file."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from rigtools import json_values

HELP = """\
Summarise a recording: status (complete / aborted with its reason / recording = being written
now, or its writer was killed), backend, software and schema versions, the channels (quantity,
units, sample rate, sensor) and one row per point with its parameters, samples and duration.
A point shown "incomplete" was cut off (writer killed or a write error): do not count it.
An FRF set (rig import uff of UFF 58 FRFs) is described by its FRF kind and units, its
references and responses (node, direction, units), frequency range and resolution, source file.
A branches file (rig continuation) by its parameter and range, the quantities held fixed, and
one row per branch: period, status, points (stable ones), range and bifurcations (fold, period
doubling, ...), the parameter in the unit its figure uses (Hz, N, mm; V under --drive).

examples:
  rig info run.h5
  rig info --json run.h5 | python -m json.tool
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "info",
        help="summarise a recording (points, channels, durations, status), an FRF set or a branches file",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("file", metavar="FILE", help="recording, FRF set or branches file (.h5)")
    parser.add_argument(
        "--json", action="store_true", help="print the summary as JSON (root attributes, channels, points)"
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.branches import is_branches_file
    from rigtools.frf_set import is_frf_set
    from rigtools.recording import open_recording
    from rigtools.recording.summary import format_params, summary

    if is_frf_set(args.file):
        from rigtools.frf_set import summary as frf_set_summary
        from rigtools.tables import frf_set_tables

        return print_info(args, frf_set_summary(args.file), frf_set_tables)
    if is_branches_file(args.file):
        from rigtools.branches import branches_info
        from rigtools.tables import branches_tables

        return print_info(args, branches_info(args.file), branches_tables)
    with open_recording(args.file) as rec:
        info = summary(rec)
    if args.json:
        print(json_values.dumps(info, indent=1))
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
        sens = "" if ch["sensitivity"] is None else f"{ch['sensitivity']:.5g} {ch['sensitivity_units'] or ''}"
        table.add_row(
            ch["name"],
            ch["quantity"],
            ch["units"],
            f"{ch['sample_rate']:.5g}",
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
            format_params(p["params"]),
            str(p["n_samples"]),
            f"{p['duration_s']:.3f}",
            p["state"] if p["complete"] else f"[yellow]{p['state']}[/yellow]",
        )
    console.print(table)
    return 0


def print_info(args: argparse.Namespace, info: dict, tables: Callable[[dict], list[Any]]) -> int:
    """``info`` as JSON or as the lines and tables ``tables(info)`` makes."""
    if args.json:
        print(json_values.dumps(info, indent=1))
        return 0
    from rich.console import Console

    console = Console()
    for item in tables(info):
        console.print(item)
    return 0
