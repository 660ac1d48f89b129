"""``rig simulate``: one vibro-impact run of the FE (or AM) model, settled and recorded as HDF5."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from rigtools.config import load_rig
from rigtools.errors import UserError
from rigtools.options import check_out, quantity

HELP = "simulate the vibro-impact response (FE or assumed-modes model) and record it as HDF5"
EPILOG = """\
A force F0 sin(2 pi fe t) acts at the force-sensor position of the active blade; the shrouds
hit each other across the gap (penalty contact of the rig file's [contact]). The reduced model
(low flexural modes plus static correction) is stepped exactly per mode with the contact solved
in every step, run from rest until the response repeats period after period (steady state,
reported), then --duration is recorded.

Written channels (one point, backend "fem", SI units): active_shroud_accel, passive_shroud_accel
(m/s^2), force (N, force into the blade at the sensor), active_shroud_disp, passive_shroud_disp,
force_point_disp (m), active_shroud_vel, passive_shroud_vel, force_point_vel (m/s),
force_point_accel (m/s^2), contact_force (N).

--json prints {"harmonics": {channel: [{"k", "frequency_hz", "amplitude"}, ...]},
"contact": {"peak_force_n", "impacts_per_period"}, "steady_state": true|false, "plot": PNG
path or null} for k = 1..30 of active_shroud_accel, passive_shroud_accel, force and
contact_force (peak amplitudes; the acceleration harmonics come from the velocity, k w |V_k|,
exact for a periodic response).

Plot: FILE.png beside FILE.h5 (same name; --no-plot skips it): the shroud displacements (mm)
and the contact force (N) over the last 3 periods, and the amplitude spectra (m/s^2) of both
shroud accelerations with k*fe and the blades' flexural natural frequencies marked (as the
paper's Figure 9).

Quantities take units: "0.5 mm", "15 N", "60 Hz", "2 s"; a plain number is SI (m, N, Hz, s).

examples:
  rig simulate --out run.h5
  rig simulate --fe 60 --force 15 --gap "0.5 mm" --duration 1 --out run.h5 --json
  rig simulate --model am --gap "0.7 mm" --out am.h5 --overwrite
"""

# recorded channel -> (run output, units, quantity, location)
CHANNELS = {
    "active_shroud_accel": ("active_tip_acceleration", "m/s^2", "acceleration", "active blade shroud (tip)"),
    "passive_shroud_accel": ("passive_tip_acceleration", "m/s^2", "acceleration", "passive blade shroud (tip)"),
    "force": ("excitation_force", "N", "force", "active blade, force sensor"),
    "active_shroud_disp": ("active_tip_displacement", "m", "displacement", "active blade shroud (tip)"),
    "passive_shroud_disp": ("passive_tip_displacement", "m", "displacement", "passive blade shroud (tip)"),
    "force_point_disp": ("force_point_displacement", "m", "displacement", "active blade, force sensor"),
    "active_shroud_vel": ("active_tip_velocity", "m/s", "velocity", "active blade shroud (tip)"),
    "passive_shroud_vel": ("passive_tip_velocity", "m/s", "velocity", "passive blade shroud (tip)"),
    "force_point_vel": ("force_point_velocity", "m/s", "velocity", "active blade, force sensor"),
    "force_point_accel": ("force_point_acceleration", "m/s^2", "acceleration", "active blade, force sensor"),
    "contact_force": ("contact_force", "N", "force", "between the shrouds"),
}
# harmonics in --json: channel -> (output, derivative order applied to it)
HARMONIC_CHANNELS = {
    "active_shroud_accel": ("active_tip_velocity", 1),
    "passive_shroud_accel": ("passive_tip_velocity", 1),
    "force": ("excitation_force", 0),
    "contact_force": ("contact_force", 0),
}
K_MAX = 30


def add_model_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--rig", metavar="FILE", help="rig file (TOML); default: the calibrated default rig")
    p.add_argument("--model", choices=("fem", "am"), default="fem",
                   help="fem: reduced FE model (default); am: assumed-modes (analytical) model")
    p.add_argument("--duration", default="1 s",
                   help='recorded time after the steady state is reached (default "1 s"; at least one period)')
    p.add_argument("--max-settle", default="30 s",
                   help='give up waiting for a steady state after this simulated time (default "30 s")')
    p.add_argument("--steps-per-period", type=int, default=None, metavar="N",
                   help="time steps per excitation period (default: 30 per contact period, at least 120)")
    p.add_argument("--out", required=True, metavar="FILE", help="HDF5 file to write (.h5)")
    p.add_argument("--overwrite", action="store_true", help="replace FILE if it exists")
    p.add_argument("--json", action="store_true", help="print the results as JSON on stdout")
    p.add_argument("--no-plot", action="store_true", help="do not write the PNG plot beside FILE")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("simulate", help=HELP, description=HELP + ".", epilog=EPILOG,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--fe", default="60 Hz", help='excitation frequency (default "60 Hz")')
    p.add_argument("--force", default="15 N", help='force amplitude F0 (default "15 N")')
    p.add_argument("--gap", default=None, help='shroud gap (default: the rig file\'s, e.g. "0.5 mm")')
    add_model_options(p)
    p.set_defaults(func=run)


def load_system(args: argparse.Namespace):
    """(rig config, reduced system) for the chosen model."""
    from sim.reduction import reduced_system

    cfg = load_rig(args.rig)
    params = cfg.to_params()
    return cfg, reduced_system(params, args.model)


def run_options(args: argparse.Namespace, fe_values: list[float]) -> dict:
    """run_harmonic options from the CLI, with the duration checked against the period."""
    duration = quantity(args.duration, "time", "--duration")
    max_settle = quantity(args.max_settle, "time", "--max-settle")
    for fe in fe_values:
        if fe > 0 and duration * fe < 1.0 - 1e-9:
            raise UserError(f"--duration = {args.duration!r} is shorter than one excitation period "
                            f"(1/fe = {1 / fe:.4g} s at fe = {fe:g} Hz)")
    if max_settle < 0:
        raise UserError(f"--max-settle = {args.max_settle!r}: must be >= 0")
    if args.steps_per_period is not None and args.steps_per_period < 4 * K_MAX:
        raise UserError(f"--steps-per-period = {args.steps_per_period}: need at least {4 * K_MAX} "
                        f"to resolve harmonic {K_MAX}")
    return {"duration": duration, "max_settle_time": max_settle, "steps_per_period": args.steps_per_period}


def simulate_point(system, fe: float, force: float, options: dict, initial=None):
    """One settled run; SimulationInputError becomes a one-line UserError."""
    from sim.vibro_impact import SimulationInputError, run_harmonic

    try:
        return run_harmonic(system, fe, force, record_periods=max(1, int(round(options["duration"] * fe))),
                            steps_per_period=options["steps_per_period"],
                            max_settle_time=options["max_settle_time"], initial=initial)
    except SimulationInputError as exc:
        raise UserError(str(exc)) from None


def channel_specs(sample_rate: float):
    from rigtools.recording import ChannelSpec

    return [ChannelSpec(name=name, units=units, quantity=q, sample_rate=sample_rate, location=loc)
            for name, (_, units, q, loc) in CHANNELS.items()]


def channel_block(run) -> np.ndarray:
    return np.vstack([run.outputs[src] for src, *_ in CHANNELS.values()])


def harmonics_of(run) -> dict[str, list[dict]]:
    """k = 1..30 harmonics of the --json channels (acceleration via the velocity, exact for a
    periodic signal and second-order accurate in the step)."""
    from analysis.harmonics import derivative_harmonics, harmonic_amplitudes

    out = {}
    for name, (src, order) in HARMONIC_CHANNELS.items():
        fit = harmonic_amplitudes(run.outputs[src], run.sample_rate, run.fe, K_MAX)
        if order:
            fit = derivative_harmonics(fit, order)
        out[name] = [{"k": r["k"], "frequency_hz": r["frequency_hz"], "amplitude": r["amplitude"]}
                     for r in fit.to_records()]
    return out


def point_params(run, model: str) -> dict:
    return {
        "fe": run.fe, "force_amplitude": run.force_amplitude, "gap": run.gap, "model": model,
        "steps_per_period": run.steps_per_period, "time_step": run.dt,
        "settle_time": run.settle_time,
    }


def end_attrs(run) -> dict:
    return {
        "settled": bool(run.steady_state), "period_multiple": int(run.period_multiple),
        "peak_contact_force": run.peak_contact_force, "impacts_per_period": run.impacts_per_period,
        "measured_force_amplitude": float(np.max(np.abs(run.outputs["excitation_force"]))),
    }


def summary(run) -> dict:
    return {
        "harmonics": harmonics_of(run),
        "contact": {"peak_force_n": run.peak_contact_force, "impacts_per_period": run.impacts_per_period},
        "steady_state": bool(run.steady_state),
    }


def natural_frequencies(system) -> dict[str, np.ndarray]:
    """The kept (not static-correction) mode frequencies of each blade of a reduced system, Hz:
    its flexural natural frequencies."""
    from sim.reduction import ACTIVE, PASSIVE

    real = np.ones(system.n_modes, bool) if system.pseudo is None else ~np.asarray(system.pseudo, bool)
    f = system.frequencies_hz
    return {"active": np.sort(f[real & (system.blade == ACTIVE)]),
            "passive": np.sort(f[real & (system.blade == PASSIVE)])}


def run_figure(run, system, title: str):
    """:func:`analysis.plots.vibro_impact_figure` of one settled run."""
    from analysis.plots import vibro_impact_figure

    o = run.outputs
    return vibro_impact_figure(run.time, o["active_tip_displacement"], o["passive_tip_displacement"],
                               o["contact_force"], o["active_tip_acceleration"], o["passive_tip_acceleration"],
                               run.fe, k_max=K_MAX, gap=run.gap, natural_frequencies_hz=natural_frequencies(system),
                               title=title)


def write_plot(args: argparse.Namespace, out: Path, make_figure) -> Path | None:
    """``make_figure()`` saved beside ``out`` (same name, .png), unless ``--no-plot``."""
    if args.no_plot:
        return None
    from rigtools.figures import plot_path, save_figure

    return save_figure(make_figure(), plot_path(out))


def run(args: argparse.Namespace) -> int:
    from rigtools.recording import RecordingWriter

    out = check_out(args)
    fe = quantity(args.fe, "frequency", "--fe")
    force = quantity(args.force, "force", "--force")
    if not fe > 0:
        raise UserError(f"--fe = {args.fe!r}: the excitation frequency must be > 0 Hz")
    if force < 0:
        raise UserError(f"--force = {args.force!r}: the force amplitude must be >= 0 N")
    options = run_options(args, [fe])
    cfg, system = load_system(args)
    if args.gap is not None:
        gap = quantity(args.gap, "length", "--gap")
        if gap < 0:
            raise UserError(f"--gap = {args.gap!r}: the gap must be >= 0")
        system = system.with_contact(gap=gap)
    if args.json:
        result = simulate_point(system, fe, force, options)
    else:
        from rich.console import Console

        with Console(stderr=True).status(f"simulating fe = {fe:g} Hz, F0 = {force:g} N, "
                                         f"gap = {system.contact.gap * 1e3:g} mm ({args.model})"):
            result = simulate_point(system, fe, force, options)
    experiment = {"procedure": "simulate", "model": args.model, "cli": "rig simulate"}
    with RecordingWriter(out, backend="fem", rig=cfg.to_json(), experiment=experiment,
                         overwrite=args.overwrite) as rec:
        point = rec.begin_point(params=point_params(result, args.model), channels=channel_specs(result.sample_rate))
        point.append(channel_block(result))
        point.set_attrs(**end_attrs(result))
        point.end()
    doc = summary(result)
    png = write_plot(args, out, lambda: run_figure(result, system, f"{cfg.name} ({args.model.upper()})"))
    doc["plot"] = None if png is None else str(png)
    if args.json:
        print(json.dumps(doc))
    else:
        print_summary(doc, result, out)
    return 0


def print_summary(doc: dict, result, out: Path) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console()
    table = Table(title=f"harmonics k*fe (fe = {result.fe:g} Hz), peak amplitudes")
    table.add_column("k", justify="right")
    table.add_column("Hz", justify="right")
    for name in ("active_shroud_accel", "passive_shroud_accel", "force", "contact_force"):
        table.add_column(name + (" (m/s²)" if "accel" in name else " (N)"), justify="right")
    h = doc["harmonics"]
    for i in range(10):
        table.add_row(str(i + 1), f"{h['force'][i]['frequency_hz']:g}",
                      *(f"{h[name][i]['amplitude']:.4g}" for name in
                        ("active_shroud_accel", "passive_shroud_accel", "force", "contact_force")))
    console.print(table)
    c = doc["contact"]
    console.print(f"peak contact force {c['peak_force_n']:.4g} N, {c['impacts_per_period']:g} impacts per period, "
                  f"steady state: {'yes' if doc['steady_state'] else 'NO'} "
                  f"(after {result.settle_time:.3g} s simulated); wrote {out}"
                  + (f" and {doc['plot']}" if doc.get("plot") else ""))
