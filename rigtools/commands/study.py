"""``rig study``: gap, force-amplitude or frequency sweep of the vibro-impact model, one file,
each point written as soon as it settles."""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from rigtools.errors import UserError
from rigtools.model_options import add_model_options, announce_work, load_model, settings_of, write_plot
from rigtools.options import check_out, gap, quantity

HELP = "run a gap, force or frequency study of the vibro-impact model and record every point"
EPILOG = """\
The paper's studies (Figures 10-16): each value is run to a steady state and recorded as one
point of a single HDF5 file (backend "fem", the channels and point parameters of
`rig simulate`, plus direction and study_value). Fixed parameters default to the paper's: gap
study at F0 = 15 N, fe = 60 Hz; force study at gap 0.7 mm, fe = 60 Hz; frequency study at
gap 0.7 mm, F0 = 15 N.

--values is a comma list ("0.3 mm,0.5 mm,0.7 mm") or start:stop:step ("0.3 mm:0.9 mm:0.1 mm",
stop included), at most 10000 points, with units; a plain number is SI (m, N, Hz), so write
gaps with "mm" (a gap above 50 mm is refused).
Points run in sweep order and each starts from the previous point's state (as a slow sweep on
the rig does), so --direction both shows jumps and hysteresis; --from-rest starts each from rest.

Each point is written to FILE as soon as it has settled, so nothing finished is lost: on Ctrl-C,
SIGTERM or SIGHUP the file keeps every finished point and ends with status "aborted" and the
reason; after a crash or SIGKILL it keeps every point finished before (readable while the study
runs, e.g. by rig info). Memory does not grow with the number of points.

--json prints {"kind", "fixed", "points": [{"value", "direction", "fe", "force_amplitude",
"force_amplitude_measured", "gap", "steady_state", "peak_contact_force_n", "impacts_per_period",
"harmonics": {channel: [{"k", "frequency_hz", "amplitude"}, ...]}}, ...], "plot": PNG path or
null}.

Plot: FILE.png beside FILE.h5 (--no-plot skips it): peak contact force (N) versus the swept
value, up and down sweeps marked apart, and heat maps of the harmonics k = 1..30 (m/s^2, log
colour) of both shroud accelerations per point in run order.

Exit status: 0 written, 2 bad input (options, rig file, --out), 130 Ctrl-C, 143 SIGTERM,
129 SIGHUP (the file keeps every finished point, status "aborted").

Maps and clusters: `rig study map --gap "0.3 mm:0.7 mm:0.2 mm" --force "10 N,15 N,20 N" --fe
"58 Hz:62 Hz:2 Hz"` runs every (gap, F0) pair as a frequency sweep (no plot; rig report). Points
run in chains (a carried-state sweep is one chain; from rest, each point is one): in-process by
default, on --workers N local processes (a Dask LocalCluster) or on an existing Dask cluster
(--scheduler tcp://host:port). Results are written in point order and are bit-identical
whatever the number of workers; a point whose worker dies is rerun once and reported.

examples:
  rig study gap --values "0.3 mm:0.9 mm:0.1 mm" --out gap.h5
  rig study map --gap "0.3 mm,0.5 mm" --force "10 N,15 N" --fe "58 Hz,60 Hz" --from-rest --workers 2 --out map.h5
  rig study force --values "5 N,10 N,15 N,20 N,25 N" --out force.h5
  rig study frequency --values "60 Hz:80 Hz:1 Hz" --direction both --out sweep.h5
"""

DIMENSION = {"gap": "length", "force": "force", "frequency": "frequency"}
UNIT = {"gap": ("mm", 1e3), "force": ("N", 1.0), "frequency": ("Hz", 1.0)}
MAX_POINTS = 10_000


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


def parse_values(text: str, kind: str) -> list[float]:
    """``"a,b,c"`` or ``"start:stop:step"`` (stop included) in SI units, each checked."""
    dimension = DIMENSION[kind]
    one = (
        (lambda p: gap(p, "--values"))
        if kind == "gap"
        else (lambda p: quantity(p, dimension, "--values"))
    )
    text = text.strip()
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise UserError(f"--values = {text!r}: write start:stop:step")
        start, stop, step = (one(p) for p in parts)
        if not step > 0 or stop < start:
            raise UserError(f"--values = {text!r}: need step > 0 and stop >= start")
        n = int(np.floor((stop - start) / step + 1e-9)) + 1
        if n > MAX_POINTS:
            raise UserError(f"--values = {text!r}: {n} points is too many (at most {MAX_POINTS})")
        values = [start + i * step for i in range(n)]
    else:
        values = [one(p) for p in text.split(",") if p.strip()]
        if not values:
            raise UserError("--values: give at least one value")
        if len(values) > MAX_POINTS:
            raise UserError(f"--values: {len(values)} points is too many (at most {MAX_POINTS})")
    bad = [v for v in values if (v <= 0 if kind == "frequency" else v < 0)]
    if bad:
        what = {
            "gap": "gaps must be >= 0",
            "force": "force amplitudes must be >= 0",
            "frequency": "frequencies must be > 0",
        }[kind]
        raise UserError(f"--values = {text!r}: {what} (got {bad[0]:g})")
    return values


def make_map(args: argparse.Namespace):
    """:class:`rigtools.sim.studies.MapPlan` of ``rig study map`` (--gap, --force, --fe grids)."""
    from rigtools.sim.studies import MapPlan
    from rigtools.sim.vibro_impact import SimulationInputError

    missing = [o for o, v in (("--gap", args.gap), ("--force", args.force), ("--fe", args.fe)) if v is None]
    if missing:
        raise UserError(
            f'rig study map needs grids for {", ".join(missing)}, e.g. --gap "0.3 mm:0.7 mm:0.2 mm" '
            '--force "10 N,15 N,20 N" --fe "58 Hz:62 Hz:2 Hz"'
        )
    if args.values is not None:
        raise UserError(
            "--values is for gap, force and frequency studies; a map takes --gap, --force, --fe grids"
        )
    grids = [
        parse_values(args.gap, "gap"),
        parse_values(args.force, "force"),
        parse_values(args.fe, "frequency"),
    ]
    n = len(grids[0]) * len(grids[1]) * len(grids[2])
    if n > MAX_POINTS:
        raise UserError(f"the map has {n} points; at most {MAX_POINTS}")
    try:
        return MapPlan(*(tuple(g) for g in grids), direction=args.direction, carry_state=not args.from_rest)
    except SimulationInputError as exc:
        raise UserError(str(exc)) from None


def make_plan(args: argparse.Namespace, values: list[float]):
    """:class:`rigtools.sim.studies.StudyPlan` of the options."""
    from rigtools.sim.studies import StudyPlan
    from rigtools.sim.vibro_impact import SimulationInputError

    fixed = {}
    if args.fe is not None:
        fixed["fe"] = quantity(args.fe, "frequency", "--fe")
        if not fixed["fe"] > 0:
            raise UserError(f"--fe = {args.fe!r}: the excitation frequency must be > 0 Hz")
    if args.force is not None:
        fixed["force"] = quantity(args.force, "force", "--force")
        if fixed["force"] < 0:
            raise UserError(f"--force = {args.force!r}: the force amplitude must be >= 0 N")
    if args.gap is not None:
        fixed["gap"] = gap(args.gap)
    try:
        return StudyPlan(args.kind, tuple(values), args.direction, carry_state=not args.from_rest, **fixed)
    except SimulationInputError as exc:
        raise UserError(str(exc)) from None


def run(args: argparse.Namespace) -> int:
    from rigtools.errors import Interrupted as Stopped
    from rigtools.runtime import StopRequests

    with StopRequests() as stops:
        try:
            return _run(args, stops)
        except Stopped as exc:  # before the file was created
            print(f"rig study: {exc.reason}; nothing written", file=sys.stderr)
            return exc.exit_code


def _run(args: argparse.Namespace, stops) -> int:
    from rigtools import simulation as simu
    from rigtools.errors import Interrupted as Stopped
    from rigtools.recording import RecordingWriter
    from rigtools.recording.writer import one_line
    from rigtools.study_runner import StudyRunner

    out = check_out(args)
    if args.kind == "map":
        plan, values = make_map(args), None
    else:
        if args.values is None:
            raise UserError(f'rig study {args.kind} needs --values, e.g. --values "0.3 mm:0.9 mm:0.1 mm"')
        values = parse_values(args.values, args.kind)
        plan = make_plan(args, values)
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
    unit, scale = UNIT["frequency" if args.kind == "map" else args.kind]
    if args.kind == "map":
        label = lambda p: f"gap {p.gap * 1e3:g} mm, F0 {p.force:g} N, fe {p.fe:g} Hz"
    else:
        label = lambda p: f"{args.kind} {p.value * scale:g} {unit} ({p.direction})"
    rec = None
    try:
        with stops.protected():
            rec = RecordingWriter(
                out, backend="fem", rig=cfg.to_json(), experiment=experiment, overwrite=args.overwrite
            )
        with runner:
            if args.json or not sys.stderr.isatty():
                points = simu.write_study(
                    rec, system, plan, settings, args.model, guard=stops.protected, runner=runner
                )
            else:
                points = _with_progress(rec, system, plan, settings, args, planned, label, stops, runner)
            for index, reason in runner.report.retried:
                print(f"rig study: point {index + 1}: {reason}", file=sys.stderr)
    except Stopped as exc:
        if rec is None:
            raise
        n = rec.n_points  # every point begun was ended: writes are protected
        with stops.protected():
            rec.abort(f"{exc.reason} after {n} of {len(planned)} points")
        print(
            f"rig study: {exc.reason} after {n} of {len(planned)} points; {out} keeps them (status aborted)",
            file=sys.stderr,
        )
        return exc.exit_code
    except BaseException as exc:
        if rec is not None:
            with stops.protected():
                rec.abort(one_line(exc))
        raise
    try:
        with stops.protected():
            rec.close()
        png = (
            None
            if args.kind == "map"
            else write_plot(
                args.no_plot,
                out,
                lambda: study_plot(args.kind, plan.fixed, points, f"{cfg.name} ({args.model.upper()})"),
            )
        )
        if args.json:
            print(
                json.dumps(
                    {
                        "kind": args.kind,
                        "fixed": plan.fixed,
                        "points": points,
                        "plot": None if png is None else str(png),
                    }
                )
            )
        else:
            print_table(args.kind, points, out, png)
    except Stopped as exc:
        print(
            f"rig study: {exc.reason}; {out} is complete ({len(points)} points; no table or plot)",
            file=sys.stderr,
        )
        return exc.exit_code
    return 0


def _with_progress(rec, system, plan, settings, args, planned, label, stops, runner=None) -> list[dict]:
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from rigtools import simulation as simu

    with Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=Console(stderr=True),
    ) as bar:
        task = bar.add_task(f"{args.kind} study: {label(planned[0])}", total=len(planned))
        settle = bar.add_task("  settling (simulated s)", total=1.0)

        def on_point(p, summary) -> None:
            nxt = planned[p.index + 1] if p.index + 1 < len(planned) else None
            bar.update(
                task,
                completed=p.index + 1,
                description=f"{args.kind} study: " + (label(nxt) if nxt else "done"),
            )

        return simu.write_study(
            rec,
            system,
            plan,
            settings,
            args.model,
            on_point=on_point,
            guard=stops.protected,
            runner=runner,
            progress=lambda done, total: bar.update(settle, completed=done, total=total),
        )


def study_plot(kind: str, fixed: dict, points: list[dict], title: str):
    """:func:`rigtools.analysis.plots.study_figure` of the --json points (shroud acceleration harmonics)."""
    from rigtools.analysis.plots import study_figure

    harmonics = {
        label: np.array([[r["amplitude"] for r in p["harmonics"][channel]] for p in points])
        for label, channel in (
            ("active shroud", "active_shroud_accel"),
            ("passive shroud", "passive_shroud_accel"),
        )
    }
    return study_figure(
        kind,
        [p["value"] for p in points],
        [p["direction"] for p in points],
        [p["peak_contact_force_n"] for p in points],
        harmonics,
        fixed=fixed,
        title=title,
    )


def print_table(kind: str, points: list[dict], out, png=None) -> None:
    from rich.console import Console
    from rich.table import Table

    if kind == "map":
        kind = "frequency"  # a map's points are fe sweeps; the gap and F0 are in the file
    unit, scale = UNIT[kind]
    table = Table(title=f"{kind} study")
    for col in (
        f"{kind} ({unit})",
        "dir",
        "steady",
        "peak contact force (N)",
        "impacts/period",
        "active a(6fe) m/s²",
        "passive a(8fe) m/s²",
    ):
        table.add_column(col, justify="right")
    for p in points:
        h = p["harmonics"]
        table.add_row(
            f"{p['value'] * scale:g}",
            p["direction"],
            "yes" if p["steady_state"] else "NO",
            f"{p['peak_contact_force_n']:.4g}",
            f"{p['impacts_per_period']:g}",
            f"{h['active_shroud_accel'][5]['amplitude']:.4g}",
            f"{h['passive_shroud_accel'][7]['amplitude']:.4g}",
        )
    console = Console()
    console.print(table)
    console.print(f"wrote {out} ({len(points)} points)" + (f" and {png}" if png else ""))
