"""``rig check FILE``: validate a recording against the HDF5 schema (v1)."""

from __future__ import annotations

import argparse
import sys

from rigtools import json_values

HELP = """\
Check that FILE is a valid rigtools recording (docs/recording-format.md): schema name and
version, root/point/channel attributes, point numbering, equal channel lengths and sample rates
within each point, and (unless --quick) that every sample can be read and is finite.

A file being written (its writer is running) is checked as it is: "being written now" is
noted and the open point's unflushed tail is not an error. NaN or infinite samples in a point
its writer ended are errors; a point that never ended (writer killed, write error) is noted
as incomplete.

An FRF set (rig import uff of UFF 58 FRFs) is checked against its own schema: attributes,
dataset shapes, and (unless --quick) finite FRFs and coherence (NaN only for a whole response
without one), coherence within [0, 1], and a uniform increasing frequency grid.

Exit status: 0 valid (notes such as "incomplete: status is 'recording'" may be printed),
1 invalid (one line per problem), 2 unreadable (missing, truncated, not HDF5) or written by a
newer rigtools (schema_version above the one this version reads: upgrade rigtools).

examples:
  rig check run.h5
  rig check --json run.h5
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "check",
        help="validate a recording or FRF set (exit 0 valid, 1 invalid, 2 unreadable)",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("file", metavar="FILE", help="recording or FRF set (.h5) to check")
    parser.add_argument("--quick", action="store_true", help="check metadata only; do not read the samples")
    parser.add_argument(
        "--json",
        action="store_true",
        help='print {"path", "valid", "readable", "status", "points", "channels", '
        '"problems": [{"where", "message", "severity", "fatal"}]}',
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.frf_set import FRFSetCheck, check_frf_set, is_frf_set
    from rigtools.recording import RecordingError, check_recording

    frf_set = is_frf_set(args.file)
    try:
        result = (check_frf_set if frf_set else check_recording)(args.file, read_data=not args.quick)
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
    what = "FRF set" if frf_set else "recording"
    if errors:
        print(f"{args.file}: INVALID {what} ({len(errors)} problem{'s' * (len(errors) != 1)})")
        for problem in errors:
            print(f"  error: {problem.line()}")
    elif isinstance(result, FRFSetCheck):
        print(f"{args.file}: valid rigtools FRF set ({result.n_frfs} FRF(s), {result.lines} lines)")
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
