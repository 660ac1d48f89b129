"""``rig check FILE``: validate a recording, an FRF set or a branches file against its HDF5 schema."""

from __future__ import annotations

import argparse
import sys

from rigtools import json_values
from rigtools.errors import exit_status_help

HELP = (
    """\
Check that FILE is a valid rigtools recording (docs/recording-format.md): schema name and
version, root/point/channel attributes, point numbering, equal channel lengths and sample rates
within each point, and (unless --quick) that every sample can be read and is finite.

A file being written (its writer is running) is checked as it is: "being written now" is
noted and the open point's unflushed tail is not an error. NaN or infinite samples in a point
its writer ended are errors; a point that never ended (writer killed, write error) is noted
as incomplete. Every reader (info, analyze, report, export, compare, update) refuses a file
check rejects, in one line; --skip-damaged reads the rest, leaving each damaged point or channel
out with a note (a rig attribute that does not validate only stops the readers that build the
model from it).

An FRF set (rig import uff of UFF 58 FRFs) is checked against its own schema: attributes,
dataset shapes, and (unless --quick) finite FRFs and coherence (NaN only for a whole response
without one), coherence within [0, 1], and a uniform increasing frequency grid.

A branches file (rig continuation) is checked against its own schema: root attributes, each
branch's attributes and datasets of one point count, the measures rig report --branches draws,
and (unless --quick) finite parameter values and no infinite multiplier or measure.

"""
    + exit_status_help(
        0,
        1,
        2,
        notes={
            0: "valid (notes such as \"incomplete: status is 'recording'\" may be printed)",
            1: "invalid (one line per problem)",
            2: "unreadable (missing, truncated, not HDF5) or written by a newer rigtools (schema_version above the one this version reads: upgrade rigtools)",
        },
    )
    + """

examples:
  rig check run.h5
  rig check --json run.h5
"""
)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "check",
        help="validate a recording, FRF set or branches file (exit 0 valid, 1 invalid, 2 unreadable)",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("file", metavar="FILE", help="recording, FRF set or branches file (.h5) to check")
    parser.add_argument("--quick", action="store_true", help="check metadata only; do not read the samples")
    parser.add_argument(
        "--json",
        action="store_true",
        help='print {"path", "valid", "readable", "status", "points", "channels", '
        '"problems": [{"where", "message", "severity", "fatal"}]}',
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.branches_file import BranchesCheck, check_branches, is_branches_file
    from rigtools.frf_set import FRFSetCheck, check_frf_set, is_frf_set
    from rigtools.recording import RecordingError, check_recording

    what, check = (
        ("FRF set", check_frf_set)
        if is_frf_set(args.file)
        else ("branches file", check_branches)
        if is_branches_file(args.file)
        else ("recording", check_recording)
    )
    try:
        result = check(args.file, read_data=not args.quick)
    except RecordingError as exc:
        if args.json:
            print(
                json_values.dumps(
                    {
                        "path": args.file,
                        "valid": False,
                        "readable": False,
                        "problems": [{"where": "/", "message": str(exc), "severity": "error", "fatal": True}],
                    },
                    indent=1,
                )
            )
            return 2
        raise
    if args.json:
        print(json_values.dumps({**result.to_dict(), "readable": True}, indent=1))
        return 0 if result.valid else 1
    errors = [p for p in result.problems if p.severity == "error"]
    notes = [p for p in result.problems if p.severity != "error"]
    if errors:
        print(f"{args.file}: INVALID {what} ({len(errors)} problem{'s' * (len(errors) != 1)})")
        for problem in errors:
            print(f"  error: {problem.line()}")
    elif isinstance(result, FRFSetCheck):
        print(f"{args.file}: valid rigtools FRF set ({result.n_frfs} FRF(s), {result.lines} lines)")
    elif isinstance(result, BranchesCheck):
        print(
            f"{args.file}: valid rigtools branches file of rig continuation ({result.n_branches} "
            f"branch(es), {result.n_points} points; rig report --branches draws them)"
        )
    else:
        print(
            f"{args.file}: valid rigtools recording (status {result.status}, "
            f"{result.n_points} point{'s' * (result.n_points != 1)}, "
            f"{result.n_channels} channel{'s' * (result.n_channels != 1)})"
        )
    for problem in notes:
        print(f"  note: {problem.line()}")
    sys.stdout.flush()
    return 1 if errors else 0
