"""``rig study``: gap, force-amplitude or frequency sweep of the vibro-impact model, one file."""

from __future__ import annotations

import argparse
import json

import numpy as np

from rigtools.commands.simulate import (
    add_model_options, channel_block, channel_specs, end_attrs, harmonics_of,
    load_system, point_params, run_options, write_plot,
)
from rigtools.options import check_out, quantity
from rigtools.errors import UserError

HELP = "run a gap, force or frequency study of the vibro-impact model and record every point"
EPILOG = """\
The paper's studies (Figures 10-16): each value is run to a steady state and recorded as one
point of a single HDF5 file (backend "fem", the channels of `rig simulate`). Fixed parameters
default to the paper's: gap study at F0 = 15 N, fe = 60 Hz; force study at gap 0.7 mm,
fe = 60 Hz; frequency study at gap 0.7 mm, F0 = 15 N.

--values is a comma list ("0.3 mm,0.5 mm,0.7 mm") or start:stop:step ("0.3 mm:0.9 mm:0.1 mm",
stop included), with units; a plain number is SI (m, N, Hz), so write gaps with "mm".
Points run in sweep order and each starts from the previous point's state (as a slow sweep on
the rig does), so --direction both shows jumps and hysteresis; --from-rest starts each from rest.
Point attributes: fe, force_amplitude, gap, direction, settled, peak_contact_force,
impacts_per_period, period_multiple.

--json prints {"kind", "fixed", "points": [{"value", "direction", "fe", "force_amplitude",
"gap", "steady_state", "peak_contact_force_n", "impacts_per_period", "harmonics": {channel:
[{"k", "frequency_hz", "amplitude"}, ...]}}, ...], "plot": PNG path or null}.

Plot: FILE.png beside FILE.h5 (same name; --no-plot skips it): peak contact force (N) versus
the swept value, up and down sweeps marked apart, and heat maps of the harmonics k = 1..30
(m/s^2, log colour) of both shroud accelerations per point in run order.

examples:
  rig study gap --values "0.3 mm:0.9 mm:0.1 mm" --out gap.h5
  rig study force --values "5 N,10 N,15 N,20 N,25 N" --out force.h5
  rig study frequency --values "60 Hz:80 Hz:1 Hz" --direction both --out sweep.h5
"""

DIMENSION = {"gap": "length", "force": "force", "frequency": "frequency"}


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("study", help=HELP, description=HELP + ".", epilog=EPILOG,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("kind", choices=("gap", "force", "frequency"), help="the swept parameter")
    p.add_argument("--values", required=True, help='"a,b,c" or "start:stop:step", with units')
    p.add_argument("--fe", default=None, help='fixed excitation frequency (default "60 Hz")')
    p.add_argument("--force", default=None, help='fixed force amplitude (default "15 N")')
    p.add_argument("--gap", default=None, help='fixed gap (default "0.7 mm"; gap study: swept)')
    p.add_argument("--direction", choices=("up", "down", "both"), default="up",
                   help="sweep order: ascending, descending, or up then down (default up)")
    p.add_argument("--from-rest", action="store_true", help="start every point from rest")
    add_model_options(p)
    p.set_defaults(func=run)


def parse_values(text: str, dimension: str) -> list[float]:
    """``"a,b,c"`` or ``"start:stop:step"`` (stop included) in SI units."""
    text = text.strip()
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise UserError(f"--values = {text!r}: write start:stop:step")
        start, stop, step = (quantity(p, dimension, "--values") for p in parts)
        if not step > 0 or stop < start:
            raise UserError(f"--values = {text!r}: need step > 0 and stop >= start")
        n = int(np.floor((stop - start) / step + 1e-9)) + 1
        if n > 10_000:
            raise UserError(f"--values = {text!r}: {n} points is too many (at most 10000)")
        return [start + i * step for i in range(n)]
    values = [quantity(p, dimension, "--values") for p in text.split(",") if p.strip()]
    if not values:
        raise UserError("--values: give at least one value")
    return values


def run(args: argparse.Namespace) -> int:
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from rigtools.recording import RecordingWriter
    from sim.studies import DEFAULTS, run_study, sweep_order
    from sim.vibro_impact import SimulationInputError

    out = check_out(args)
    values = parse_values(args.values, DIMENSION[args.kind])
    if args.kind == "gap" and any(v > 0.05 for v in values):
        raise UserError(f"--values = {args.values!r}: a gap above 50 mm; write gaps with units, e.g. '0.5 mm'")
    bad = [v for v in values if (v <= 0 if args.kind == "frequency" else v < 0)]
    if bad:
        what = {"gap": "gaps must be >= 0", "force": "force amplitudes must be >= 0",
                "frequency": "frequencies must be > 0"}[args.kind]
        raise UserError(f"--values = {args.values!r}: {what} (got {bad[0]:g})")
    fixed = dict(DEFAULTS[args.kind])
    if args.fe is not None:
        fixed["fe"] = quantity(args.fe, "frequency", "--fe")
    if args.force is not None:
        fixed["force"] = quantity(args.force, "force", "--force")
    if args.gap is not None:
        fixed["gap"] = quantity(args.gap, "length", "--gap")
    if fixed.get("fe", 1.0) <= 0 or fixed.get("force", 0.0) < 0 or fixed.get("gap", 0.0) < 0:
        raise UserError("--fe must be > 0, --force and --gap >= 0")
    fe_values = values if args.kind == "frequency" else [fixed["fe"]]
    options = run_options(args, fe_values)
    cfg, system = load_system(args)

    kw = {k: v for k, v in fixed.items() if k in ("fe", "force", "gap")}
    study_kwargs = dict(direction=args.direction, carry_state=not args.from_rest,
                        max_settle_time=options["max_settle_time"],
                        steps_per_period=options["steps_per_period"],
                        record_duration=options["duration"], **kw)
    try:
        if args.json:
            study = run_study(system, args.kind, values, **study_kwargs)
        else:
            with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                          TimeElapsedColumn(), transient=False) as bar:
                task = bar.add_task(f"{args.kind} study", total=len(sweep_order(values, args.direction)))

                def progress(done: int, total: int, text: str) -> None:
                    bar.update(task, completed=done, total=total, description=f"{args.kind} study: {text}")

                study = run_study(system, args.kind, values, progress=progress, **study_kwargs)
    except SimulationInputError as exc:
        raise UserError(str(exc)) from None

    experiment = {"procedure": f"{args.kind} study", "model": args.model, "direction": args.direction,
                  "carry_state": not args.from_rest, "fixed": study.fixed, "values": values,
                  "cli": "rig study"}
    doc_points = []
    with RecordingWriter(out, backend="fem", rig=cfg.to_json(), experiment=experiment,
                         overwrite=args.overwrite) as rec:
        for p in study.points:
            r = p.run
            params = point_params(r, args.model)
            params.update(direction=p.direction, study_value=p.value)
            point = rec.begin_point(params=params, channels=channel_specs(r.sample_rate))
            point.append(channel_block(r))
            point.set_attrs(**end_attrs(r))
            point.end()
            doc_points.append({
                "value": p.value, "direction": p.direction, "fe": r.fe, "force_amplitude": r.force_amplitude,
                "gap": r.gap, "steady_state": bool(r.steady_state), "peak_contact_force_n": r.peak_contact_force,
                "impacts_per_period": r.impacts_per_period, "harmonics": harmonics_of(r),
            })
    png = write_plot(args, out, lambda: study_plot(args.kind, study.fixed, doc_points,
                                                   f"{cfg.name} ({args.model.upper()})"))
    if args.json:
        print(json.dumps({"kind": args.kind, "fixed": study.fixed, "points": doc_points,
                          "plot": None if png is None else str(png)}))
    else:
        print_table(args.kind, doc_points, out, png)
    return 0


def study_plot(kind: str, fixed: dict, points: list[dict], title: str):
    """:func:`analysis.plots.study_figure` of the --json points (shroud acceleration harmonics)."""
    from analysis.plots import study_figure

    harmonics = {
        label: np.array([[r["amplitude"] for r in p["harmonics"][channel]] for p in points])
        for label, channel in (("active shroud", "active_shroud_accel"), ("passive shroud", "passive_shroud_accel"))
    }
    return study_figure(kind, [p["value"] for p in points], [p["direction"] for p in points],
                        [p["peak_contact_force_n"] for p in points], harmonics, fixed=fixed, title=title)


def print_table(kind: str, points: list[dict], out, png=None) -> None:
    from rich.console import Console
    from rich.table import Table

    unit = {"gap": "mm", "force": "N", "frequency": "Hz"}[kind]
    scale = 1e3 if kind == "gap" else 1.0
    table = Table(title=f"{kind} study")
    for col in (f"{kind} ({unit})", "dir", "steady", "peak contact force (N)", "impacts/period",
                "active a(6fe) m/s²", "passive a(8fe) m/s²"):
        table.add_column(col, justify="right")
    for p in points:
        h = p["harmonics"]
        table.add_row(f"{p['value'] * scale:g}", p["direction"], "yes" if p["steady_state"] else "NO",
                      f"{p['peak_contact_force_n']:.4g}", f"{p['impacts_per_period']:g}",
                      f"{h['active_shroud_accel'][5]['amplitude']:.4g}",
                      f"{h['passive_shroud_accel'][7]['amplitude']:.4g}")
    console = Console()
    console.print(table)
    console.print(f"wrote {out} ({len(points)} points)" + (f" and {png}" if png else ""))
