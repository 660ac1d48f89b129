"""``rig export``: a recording or FRF set in another tool's format (UFF 58 for modal software)."""

from __future__ import annotations

import argparse
import sys

from rigtools import json_values
from rigtools.errors import UserError, exit_status_help
from rigtools.frf_options import add_frf_arguments, frf_options
from rigtools.options import UFF_SUFFIXES, add_skip_damaged, output_path

HELP = (
    "export a recording or FRF set as UFF 58 (time records, spectra, FRFs with coherence) for modal software"
)
EPILOG = (
    """\
rig export uff FILE.h5 OUT.uff writes, with pyuff, one UFF 58 function per channel and point:
FRFs first: H1 of every response over the force (type 4) with its coherence (type 6), the very
estimate rig analyze reports (burst: frame per burst period; chirp: whole periods; impacts: a
frame per hit; continuous random: Hann, 50 % overlap; --excitation/--frame-samples override as
in rig analyze); then time records (type 1) and auto spectra (type 2, RMS^2 per bin from the
flattop amplitude spectrum: a sine of peak amplitude A reads A^2/2), reference node 0. The file
starts with a units dataset 164 (SI: m, N, s, K); each 58 record carries the specific data type
(12 acceleration, 13 force, 8 displacement, ...), the unit exponents and the recording's date.

Nodes: force sensor 1, active shroud 2, passive shroud 3, drive 100, other channels 101+;
direction 2 (+Y, the blades' impact direction) for all. A channel rig import uff read keeps the
node, direction, entity name and ID line 1 of its record; other channels of an imported recording
get nodes 101+ and direction 0 (none), said in one line. Binary, double precision values; the
abscissa increment is stored in the format's E13.5 field (6 significant digits).

Points a run did not finish are left out: cut off (the writer never ended them) or stopped
inside (point_complete false: a stop cut the record short). A truncated record read by another
tool would be silently wrong data; one line on stderr names them (--json: skipped_incomplete_points
and skipped_why).

A recording without a force channel (response-only, e.g. an imported ambient or operational
record) gets its time records and spectra, and one line saying no FRF was written.

An FRF set (rig import uff of an analyser's FRFs) is written back as its FRFs, one type 4
record per response with its coherence (type 6) where it has one, each with the entity names,
nodes and direction codes (1..6 = +X..+RZ, negative the opposite sense) it was imported with.

examples:
  rig export uff run.h5 run.uff
  rig export uff frf.h5 frf.uff --what frf --json

"""
    + exit_status_help(
        0,
        2,
        notes={
            0: "written",
            2: "bad input (unreadable recording, existing OUT without --overwrite, --excitation/--frame-samples where no FRF is estimated: --what without frf, no broadband point)",
        },
    )
    + """
"""
)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "export",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("format", choices=("uff",), help="output format")
    p.add_argument("file", metavar="FILE.h5", help="the recording or FRF set")
    add_skip_damaged(p)
    p.add_argument("out", metavar="OUT", help="file to write")
    p.add_argument(
        "--what",
        default="time,spectra,frf",
        help='comma list of time, spectra, frf (default "time,spectra,frf")',
    )
    add_frf_arguments(p, analysis=False)
    p.add_argument("--reference", metavar="CHANNEL", help="the excitation channel (default: the force)")
    p.add_argument("--overwrite", action="store_true", help="replace OUT if it exists")
    p.add_argument("--json", action="store_true", help="print what was written as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.interop.uff import WHAT, file_functions, write_uff

    what = tuple(w.strip() for w in args.what.split(",") if w.strip())
    unknown = [w for w in what if w not in WHAT]
    if unknown or not what:
        raise UserError(f"--what = {args.what!r}: use a comma list of {', '.join(WHAT)}")
    options = frf_options(args)
    out = output_path(args.out, args.overwrite, "OUT", suffixes=UFF_SUFFIXES, inputs=[args.file])
    notes: list[str] = []
    left_out: list[str] = []
    functions, skipped = file_functions(
        args.file, what, frf_options=options, reference=args.reference, notes=notes, left_out=left_out
    )
    for line in left_out:  # a cut or stopped point is a truncated record: never exported as data
        print(line, file=sys.stderr)
    if not functions:
        why = notes[0] if notes else "FRFs need a broadband point with a force channel"
        raise UserError(f"{args.file}: nothing to export for --what {args.what!r}: {why}")
    write_uff(out, functions)
    counts: dict[str, int] = {}
    for f in functions:
        key = {1: "time", 2: "spectra", 4: "frf", 6: "coherence"}[f.func_type]
        counts[key] = counts.get(key, 0) + 1
    if args.json:
        doc = {
            "file": str(out),
            "datasets": counts,
            "skipped_incomplete_points": skipped,
            "skipped_why": left_out,
            "notes": notes,
        }
        print(json_values.dumps(doc))
    else:
        for line in notes:
            print(line)
        print(f"wrote {out}: " + ", ".join(f"{v} {k}" for k, v in counts.items()) + " (UFF 58, SI)")
    return 0
