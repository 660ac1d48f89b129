"""``rig compare``: an experiment (EM) recording beside a model (FEM/AM) recording or model runs."""

from __future__ import annotations

import argparse
from pathlib import Path

from rigtools import json_values
from rigtools.errors import UserError, exit_status_help
from rigtools.options import add_skip_damaged, output_folder

HELP = "EM vs FEM/AM side by side: harmonic tables, agreement scores, natural frequencies, figures"
EPILOG = (
    """\
Pairs the points of EM.h5 (rig acquire dwell | sweep | study) by meaning (fe, gap, force target)
with those of a model recording FEM.h5 (rig simulate | rig study), or with --simulate runs the
model at every EM point at the measured fe, gap and force:
  --excitation measured  the harmonics k = 1..30 (amplitude, phase) of the force the blade felt
                         (EM force over its settled window) drive the model
  --excitation nominal   F0 sin(2 pi fe t), F0 the EM force fundamental
EM points are analysed over their settled window (record_start, record_samples).

Printed: the natural frequencies of FEM, AM and EM with differences in % (EM from the FRF points
of EM.h5 or of --frf FRF.h5, rig acquire frf; without FRF data this is said), per point the
harmonic amplitudes (peak) of force and both shroud accelerations with diff % = 100 (model - EM) /
EM, next to each large difference (> 30 %) of a harmonic near a natural frequency the offset of
that frequency that explains it, and one agreement score per point:
  score = 10^-E, E = energy-weighted mean |log10(model / EM)| of the harmonics k = 1..30 of
  active_shroud_accel and passive_shroud_accel, averaged over both (1 = identical; 1/q when
  every harmonic is q times off). The force is the input and is not scored.
--out DIR writes the figures (study trends with EM and the model on the same axes, per point the
waveform/spectrum overlay in the paper's Figures 8-16 layout and harmonic bars) as
DIR/EMSTEM.compare-*.png; never over a recording or a file rigtools did not write.

"""
    + exit_status_help(0, 2, notes={0: "compared", 2: "bad input (files, options, nothing to pair)"})
    + """

examples:
  rig compare dwell.h5 --simulate                       # FEM driven by the measured force
  rig compare dwell.h5 --simulate --excitation nominal --model am
  rig compare dwell.h5 fem.h5 --frf frf.h5 --out figs/
  rig compare dwell.h5 --simulate --json > cmp.json     # scores, tables, explanations
  rig compare dwell.h5 --simulate --workers 2           # model points on 2 local processes
"""
)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "compare",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("em", metavar="EM.h5", help="experiment recording (rig acquire ...)")
    p.add_argument("fem", metavar="FEM.h5", nargs="?", help="model recording (rig simulate / rig study)")
    add_skip_damaged(p)
    p.add_argument(
        "--simulate", action="store_true", help="run the model at every EM point instead of FEM.h5"
    )
    p.add_argument(
        "--model",
        choices=("fem", "am"),
        default="fem",
        help="model run by --simulate: reduced FE model (default) or assumed-modes model",
    )
    p.add_argument(
        "--excitation",
        choices=("measured", "nominal"),
        default="measured",
        help="--simulate drive: the recorded force waveform (default) or F0 sin",
    )
    p.add_argument("--rig", metavar="FILE", help="rig file for the model; default: the rig stored in EM.h5")
    p.add_argument(
        "--frf", metavar="FRF.h5", help="FRF recording (rig acquire frf) giving the EM natural frequencies"
    )
    p.add_argument(
        "--harmonics",
        metavar="K",
        default="12",
        help="harmonics shown per point in the table, k = 1..K plus 22 (default 12; JSON has all 30)",
    )
    p.add_argument(
        "--workers",
        metavar="N",
        help="--simulate: run the model points on N local worker processes (Dask; default in this process)",
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of tables")
    p.add_argument("--out", metavar="DIR", help="write the figures as PNG into DIR")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.options import count

    k_show = count(args.harmonics, "--harmonics", minimum=1, maximum=30)
    workers = None if args.workers is None else count(args.workers, "--workers", minimum=1, maximum=256)
    if args.simulate and args.fem:
        raise UserError("give FEM.h5 or --simulate, not both")
    if not args.simulate and not args.fem:
        raise UserError("give a model recording FEM.h5 or --simulate")
    for path, what in ((args.em, "EM.h5"), (args.fem, "FEM.h5"), (args.frf, "--frf"), (args.rig, "--rig")):
        if path is not None and not Path(path).is_file():
            raise UserError(f"{what} {path}: no such file")
    if args.out is not None:
        output_folder(args.out, replaceable=f"{Path(args.em).stem}.compare-*.png")
    from rich.console import Console

    from rigtools.progress import counted
    from rigtools.recording_comparison import compare_recordings

    doing = "comparing" + (" (model runs at the EM points)" if args.simulate else "")
    with counted(doing, quiet=args.json, prefix="model run ") as progress:
        cmp = compare_recordings(
            args.em,
            args.fem,
            simulate=args.simulate,
            model=args.model,
            excitation=args.excitation,
            rig=args.rig,
            frf=args.frf,
            workers=workers,
            progress=progress,
        )
    written = cmp.save_figures(args.out) if args.out else []
    if args.json:
        out = cmp.to_dict()
        out["figures"] = [str(p) for p in written]
        print(json_values.dumps(out, indent=1))
    else:
        from rigtools.tables import comparison_tables

        console = Console()
        for item in comparison_tables(cmp, k_show):
            console.print(item)
        for p in written:
            print(f"wrote {p}")
    return 0
