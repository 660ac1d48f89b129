"""``rig info FILE``: summary of a recording (status, channels, points, durations), an FRF set
or a branches file."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from rigtools import json_values
from rigtools.errors import exit_status_help
from rigtools.options import add_skip_damaged

HELP = (
    """\
Summarise a recording: status (complete / aborted with its reason / recording = being written
now, or its writer was killed), backend, software and schema versions, the channels (quantity,
units, sample rate, sensor) and one row per point with its parameters, samples and duration.
A point shown "incomplete" was cut off (writer killed or a write error): do not count it.
Parameters are shown in columns with their units (fe in Hz, F0 and F1 in N, gap in mm, drive in
V), each point's harmonics by channel (fundamental and the largest k >= 2); numbers to 4
significant digits, a harmonic below 1e-9 of its channel's largest as "0 (round-off)".
An FRF set (rig import uff of UFF 58 FRFs) is described by its FRF kind and units, its
references and responses (node, direction, units), frequency range and resolution, source file.
A branches file (rig continuation) by its parameter and range, the quantities held fixed, and
one row per branch: period, status, points (stable ones), range and bifurcations (fold, period
doubling, ...), the parameter in the unit its figure uses (Hz, N, mm; V under --drive).

"""
    + exit_status_help(
        0, 2, notes={0: "summarised", 2: "unreadable file (missing, not HDF5, not written by rigtools)"}
    )
    + """

examples:
  rig info run.h5
  rig info --json run.h5 | python -m json.tool
"""
)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "info",
        help="summarise a recording (points, channels, durations, status), an FRF set or a branches file",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("file", metavar="FILE", help="recording, FRF set or branches file (.h5)")
    add_skip_damaged(parser)
    parser.add_argument(
        "--json", action="store_true", help="print the summary as JSON (root attributes, channels, points)"
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.branches_file import is_branches_file
    from rigtools.frf_set import is_frf_set
    from rigtools.recording import open_recording
    from rigtools.recording.summary import summary

    if is_frf_set(args.file):
        from rigtools.frf_set import summary as frf_set_summary
        from rigtools.tables import frf_set_tables

        return print_info(args, frf_set_summary(args.file), frf_set_tables)
    if is_branches_file(args.file):
        from rigtools.branches_file import branches_info
        from rigtools.tables import branches_tables

        return print_info(args, branches_info(args.file), branches_tables)
    with open_recording(args.file) as rec:
        info = summary(rec)
    from rigtools.tables import recording_tables

    return print_info(args, info, recording_tables)


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
