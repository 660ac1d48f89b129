"""``rig study``: gap, force-amplitude or frequency sweep of the vibro-impact model, one file,
each point written as soon as it settles."""

from __future__ import annotations

import argparse
import sys

from rigtools import json_values
from rigtools.errors import Interrupted as Stopped
from rigtools.model_options import add_model_options, announce_work, load_model, settings_of, write_plot
from rigtools.model_study import EPILOG

# literal here: `rig --help` reads each command's HELP from its source without importing it
HELP = "run a gap, force or frequency study of the vibro-impact model and record every point"
from rigtools.options import HDF5_SUFFIXES, check_out, scheduler_address
from rigtools.progress import StudyProgress


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "study",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "kind",
        choices=("gap", "force", "frequency", "map"),
        help="the swept parameter; map: gap x F0 x fe (--gap, --force, --fe take grids)",
    )
    p.add_argument("--values", default=None, help='"a,b,c" or "start:stop:step", with units (not for map)')
    p.add_argument("--fe", default=None, help='fixed excitation frequency (default "60 Hz"); map: a grid')
    p.add_argument("--force", default=None, help='fixed force amplitude (default "15 N"); map: a grid')
    p.add_argument("--gap", default=None, help='fixed gap (default "0.7 mm"; gap study: swept); map: a grid')
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="run independent chains of points on a Dask LocalCluster of N worker processes",
    )
    p.add_argument(
        "--scheduler",
        default=None,
        type=scheduler_address,
        metavar="ADDR",
        help="run on an existing Dask cluster, e.g. tcp://10.0.0.5:8786 (dask-jobqueue/SLURM)",
    )
    p.add_argument(
        "--direction",
        choices=("up", "down", "both"),
        default="up",
        help="sweep order: ascending, descending, or up then down (default up)",
    )
    p.add_argument("--from-rest", action="store_true", help="start every point from rest")
    add_model_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.runtime import StopRequests

    with StopRequests() as stops:
        try:
            code = _run(args, stops)
        except Stopped as exc:  # before the file was created
            print(f"rig study: {exc.reason}; nothing written", file=sys.stderr)
            code = exc.exit_code
    return code


def _run(args: argparse.Namespace, stops) -> int:
    from rigtools import model_study as ms
    from rigtools.study_runner import StudyRunner

    out = check_out(args, suffixes=HDF5_SUFFIXES)
    plan, values = ms.study_plan(
        args.kind,
        args.values,
        fe=args.fe,
        force=args.force,
        gap_value=args.gap,
        direction=args.direction,
        from_rest=args.from_rest,
    )
    planned = plan.points()
    runner = StudyRunner(workers=args.workers, scheduler=args.scheduler)
    settings = settings_of(args, sorted({p.fe for p in planned}))
    cfg, system = load_model(args.rig, args.model, quiet=args.json)
    announce_work(system, [(p.fe, p.force) for p in planned], settings, quiet=args.json)
    experiment = {
        "procedure": f"{args.kind} study",
        "model": args.model,
        "direction": args.direction,
        "carry_state": not args.from_rest,
        "fixed": plan.fixed,
        "values": values,
        "plan": plan.to_dict(),
        "cli": "rig study",
    }
    show = not args.json and sys.stderr.isatty()
    try:
        with runner, StudyProgress(f"{args.kind} study", planned, ms.point_label(args.kind), show) as bar:
            points = ms.record_study(
                out, plan, cfg, system, settings, experiment=experiment, model=args.model,
                overwrite=args.overwrite, runner=runner, guard=stops.protected,
                on_point=bar.on_point, progress=bar.settling,
            )  # fmt: skip
            for index, reason in runner.report.retried:
                print(f"rig study: point {index + 1}: {reason}", file=sys.stderr)
    except ms.StudyStopped as exc:
        print(f"rig study: {exc}; {out} keeps them (status aborted)", file=sys.stderr)
        return exc.stop.exit_code
    try:
        title = f"{cfg.name} ({args.model.upper()})"
        png = None
        if args.kind != "map":
            png = write_plot(args.no_plot, out, lambda: ms.study_plot(args.kind, plan.fixed, points, title))
        if args.json:
            doc = {"kind": args.kind, "fixed": plan.fixed, "points": points, "plot": png and str(png)}
            print(json_values.dumps(doc))
        else:
            print_table(args.kind, points, out, png)
    except Stopped as exc:
        print(
            f"rig study: {exc.reason}; {out} is complete ({len(points)} points; no table or plot)",
            file=sys.stderr,
        )
        return exc.exit_code
    return 0


def print_table(kind: str, points: list[dict], out, png=None) -> None:
    from rich.console import Console

    from rigtools.model_study import summary_table

    console = Console()
    console.print(summary_table(kind, points))
    console.print(f"wrote {out} ({len(points)} points)" + (f" and {png}" if png else ""))
