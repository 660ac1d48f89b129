"""``rig continuation``: branches of periodic orbits of the model (stability, folds, period
doubling, grazing) against fe, force or gap, stored as HDF5 with a figure."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from rigtools.errors import exit_status_help

HELP = "continue the model's periodic orbits in fe, force or gap: branches, stability, bifurcations"
EPILOG = f"""\
Shooting on the reduced model's own integrator with pseudo-arclength continuation; Floquet
multipliers at every point; folds (LP: the branch turns), period doublings (PD: a real multiplier
at -1; then the period-2 branch, followed out of the range and back if it turns outside) and
Neimark-Sacker (NS: a complex pair on the unit circle) located on one contact structure; the
non-smooth events where the orbit's contacts change labelled as such: grazing (G: an impact
begins or ends), contact split (CS: the force releases and re-engages while the shrouds overlap),
sticking (ST). Each is relocated at doubled steps per period until it moves less than 0.05 %:
printed "label at VALUE -> CONVERGED at N steps/period (last change)", with its critical
multiplier. A failure inside the tracer ends the branch "failed" with its points written.

--model rig continues the simulated rig's model (the FEM of [test_article] driven through the
[shaker] and amplifier, as --backend sim runs it) holding the force fundamental at --force, as
the rig's procedures do (the drive amplitude is solved with each orbit, stability is at a fixed
drive); --drive holds a drive amplitude instead (then --param force is the drive, in V).

The file (kind "branches", docs/recording-format.md) holds each branch's points in order with
stability, multipliers, labels and response measures; FILE.png plots --measure against the
parameter (stable solid, unstable dashed); --measured overlays recorded up/down sweeps and
studies in the same measure (a rig recording has accelerations only: --measure accel1), their
jumps shaded, and prints a sentence per jump: the mechanism by which the sweep leaves the branch
it followed and how far from the jump, and the nearest turning point.

{exit_status_help(0, 2, 4, notes={0: "written (a branch that failed inside the tracer is kept, status failed)", 2: "bad input (options, a range beyond the model or the memory, --measured files)", 4: "the file cannot be written (disk full): nothing is left"})}

examples:
  rig continuation --param fe --from 62 --to 80 --force 15 --gap "0.7 mm" --out branches-fe.h5
  rig continuation --param gap --from "0.5 mm" --to "2 mm" --fe 60 --force 15 --out branches-gap.h5 --json
  rig continuation --param fe --from 60 --to 75 --measure accel1 --measured sweep.h5 --no-switch --out branches-sweep.h5
  rig continuation --param fe --from 60 --to 62 --model rig --gap "5 mm" --no-switch --out branches-rig.h5
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "continuation",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--param", required=True, choices=("fe", "force", "gap"), help="continued parameter")
    p.add_argument("--from", dest="start", required=True, help="first value (units accepted)")
    p.add_argument("--to", dest="stop", required=True, help="last value")
    p.add_argument("--fe", default="60 Hz", help='fixed excitation frequency (default "60 Hz")')
    p.add_argument("--force", help='fixed force amplitude (default "15 N"; not with --drive)')
    p.add_argument("--gap", default="0.7 mm", help='fixed gap (default "0.7 mm")')
    p.add_argument("--model", default="fem", choices=("fem", "am", "rig"), help="model (default fem)")
    p.add_argument("--drive", help='--model rig: hold this drive amplitude ("1 V", peak) instead of --force')
    p.add_argument("--rig", metavar="FILE", help="rig file (TOML); default: the calibrated default rig")
    p.add_argument("--measure", default="contact", choices=("contact", "accel1", "tip", "impacts"))
    p.add_argument("--no-switch", action="store_true", help="no period-2 branches")
    p.add_argument(
        "--measured",
        nargs="+",
        default=[],
        metavar="SWEEP.h5",
        help="recordings to overlay: stepped sines (rig acquire sweep) and studies (rig study), with their jumps",
    )
    p.add_argument("--out", required=True, metavar="FILE", help="output HDF5 file (.h5)")
    p.add_argument("--overwrite", action="store_true", help="replace FILE if it exists")
    p.add_argument("--json", action="store_true", help="print the branches' summary as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.branches import continue_to_file, located_lines, parse_inputs, summary
    from rigtools.branches_file import read_branches
    from rigtools.derived_files import plot_path
    from rigtools.figures import save_figure
    from rigtools.options import HDF5_SUFFIXES, check_out

    out = check_out(args, suffixes=HDF5_SUFFIXES, inputs=args.measured)  # a recording read is never replaced
    start, stop, fixed = parse_inputs(
        args.param, args.start, args.stop, args.fe, args.force, args.gap, args.drive
    )
    measured: list = []  # bad files before the work; without any, spare the procedures (scipy.signal)
    if args.measured:
        from rigtools.measured_sweeps import measured_sweeps

        measured = measured_sweeps(args.measured, args.param, args.measure)
    drive = args.drive is not None
    found: list = []  # the branches as they grow: written if interrupted
    try:
        cfg, branches = continue_to_file(
            out,
            args.param,
            start,
            stop,
            fixed,
            model=args.model,
            rig=args.rig,
            switch=not args.no_switch,
            drive=drive,
            measured=args.measured,
            found=found,
            announce=lambda line: print(line, file=sys.stderr),
        )
    except KeyboardInterrupt:
        kept = [len(b.points) for b in found if b.points]
        if kept:
            print(
                f"kept {sum(kept)} points of {len(kept)} branch(es) computed so far in {out}", file=sys.stderr
            )
        raise
    from rigtools.branches_figure import branches_figure  # matplotlib: once there is a figure to draw

    _, stored = read_branches(out)
    fig = branches_figure(stored, args.measure, cfg.name, measured, drive=drive)
    png = save_figure(fig, plot_path(out), dpi=120)
    doc = summary(branches)
    if args.json:
        print(json.dumps({**doc, "out": str(out), "plot": str(png)}))
        return 0
    for b, branch in zip(doc["branches"], branches, strict=True):
        marks = ", ".join(f"{x['label']} {x['value']:.6g}" for x in b["bifurcations"]) or "none"
        print(f"period {b['periods']}: {b['points']} points, {b['status']} {b['message']}; {marks}")
        for line in located_lines(branch, args.param):
            print(line)
    if measured:
        from rigtools.report.branches import measured_jump_sentences

        for line in measured_jump_sentences(stored, measured, args.measure):
            print(line)
    print(f"wrote {out} and {Path(png)}")
    return 0
