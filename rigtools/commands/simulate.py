"""``rig simulate``: one vibro-impact run of the FE (or AM) model, settled and recorded as HDF5.

Parse, call :mod:`rigtools.simulation`, print. Also holds the option parsing ``rig study``
shares (model options, finite quantities, the gap rule, output checks, cost announcements).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import textwrap
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from rigtools.errors import UserError
from rigtools.options import check_out, quantity
from rigtools.vocabulary import channel_names, describe_channels

HELP = "simulate the vibro-impact response (FE or assumed-modes model) and record it as HDF5"
EPILOG = f"""\
A force F0 sin(2 pi fe t) acts at the force-sensor position of the active blade; the shrouds
hit each other across the gap (penalty contact of the rig file's [contact]). The reduced model
(low flexural modes plus static correction) is stepped exactly per mode with the contact solved
in every step, run from rest until the response repeats period after period (steady state,
reported), then --duration is recorded.

Written channels (one point, backend "fem", SI units, names as in rig acquire's recordings):
{textwrap.fill(describe_channels(channel_names("fem")) + ".", 95)}
"force" is the force into the active blade at the sensor, as on the rig.
Point parameters: fe, force_amplitude (F0, N), gap (m), model, steps_per_period, time_step,
settle_time; at the end settled, period_multiple, peak_contact_force (N), impacts_per_period,
force_amplitude_measured (N, harmonic 1 of the force channel, as rig acquire writes it).

--json prints {{"harmonics": {{channel: [{{"k", "frequency_hz", "amplitude"}}, ...]}},
"contact": {{"peak_force_n", "impacts_per_period"}}, "steady_state": true|false, "plot": PNG
path or null}} for k = 1..30 of active_shroud_accel, passive_shroud_accel, force and
contact_force (peak amplitudes; the acceleration harmonics come from the velocity, k w |V_k|,
exact for a periodic response).

Plot: FILE.png beside FILE.h5 (--no-plot skips it): the shroud displacements (mm) and the
contact force (N) over the last 3 periods, and the amplitude spectra (m/s^2) of both shroud
accelerations with k*fe and the blades' flexural natural frequencies marked (the paper's
Figure 9).

Quantities take units: "0.5 mm", "15 N", "60 Hz", "2 s"; a plain number is SI (m, N, Hz, s),
so write gaps with "mm": a gap above 50 mm is refused. Work that needs more memory than the
machine has (a very stiff contact with a long --duration) is refused up front with the
estimate; work expected to take over a minute is announced with its estimate.

Exit status: 0 written, 2 bad input (options, rig file, --out), 130 Ctrl-C, 143 SIGTERM, 129 SIGHUP
(before the run is written: nothing is written; once it is, the file is completed).

examples:
  rig simulate --out run.h5
  rig simulate --fe 60 --force 15 --gap "0.5 mm" --duration 1 --out run.h5 --json
  rig simulate --model am --gap "0.7 mm" --out am.h5 --overwrite
"""

MAX_GAP = 0.05  # m: no blade closes a gap this wide; a plain "0.5" meant mm
MAX_STEPS_PER_PERIOD = 10_000_000


# ------------------------------------------------------------------------------ shared options


def number(text: str, dimension: str, option: str) -> float:
    """A finite quantity (``quantity`` refuses bad text; ``"1e400"`` parses to inf: refused here)."""
    value = quantity(text, dimension, option)
    if not math.isfinite(value):
        raise UserError(f"{option} = {text!r}: not a finite number")
    return value


def gap_option(text: str, option: str = "--gap") -> float:
    """A shroud gap in m, ``>= 0`` and at most 50 mm (a plain number is metres: "0.5" is refused).

    TODO: use ``rigtools.options.gap(text, option)`` (the one shared rule) once merged.
    """
    gap = number(text, "length", option)
    if gap < 0:
        raise UserError(f"{option} = {text!r}: the gap must be >= 0")
    if gap > MAX_GAP:
        raise UserError(
            f"{option} = {text!r} is {gap * 1e3:g} mm, wider than any blade could close "
            f"(at most {MAX_GAP * 1e3:g} mm); write gaps with units, e.g. '0.5 mm'"
        )
    return gap


def check_output(args: argparse.Namespace) -> Path:
    """``--out`` checked before any work: folder exists and is writable, not a directory, not an
    existing file without ``--overwrite``, not read-only.

    TODO: the directory/read-only checks belong in ``rigtools.options.check_out``.
    """
    out = Path(args.out)
    if str(args.out).strip() and out.is_dir():
        raise UserError(
            f"--out = {args.out!r} is a directory; give a file name, e.g. {str(out / 'run.h5')!r}"
        )
    out = check_out(args)
    folder = out.parent if str(out.parent) else Path(".")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UserError(f"--out = {args.out!r}: folder {str(folder)!r} is not writable")
    if out.exists() and not os.access(out, os.W_OK):
        raise UserError(f"--out = {args.out!r} is read-only")
    return out


def add_model_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--rig", metavar="FILE", help="rig file (TOML); default: the calibrated default rig")
    p.add_argument(
        "--model",
        choices=("fem", "am"),
        default="fem",
        help="fem: reduced FE model (default); am: assumed-modes (analytical) model",
    )
    p.add_argument(
        "--duration",
        default="1 s",
        help='recorded time after the steady state is reached (default "1 s"; at least one period)',
    )
    p.add_argument(
        "--max-settle",
        default="30 s",
        help='give up waiting for a steady state after this simulated time (default "30 s")',
    )
    p.add_argument(
        "--steps-per-period",
        type=int,
        default=None,
        metavar="N",
        help="time steps per excitation period (default: 30 per contact period, at least 120)",
    )
    p.add_argument("--out", required=True, metavar="FILE", help="HDF5 file to write (.h5)")
    p.add_argument("--overwrite", action="store_true", help="replace FILE if it exists")
    p.add_argument("--json", action="store_true", help="print the results as JSON on stdout")
    p.add_argument("--no-plot", action="store_true", help="do not write the PNG plot beside FILE")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "simulate",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--fe", default="60 Hz", help='excitation frequency (default "60 Hz")')
    p.add_argument("--force", default="15 N", help='force amplitude F0 (default "15 N")')
    p.add_argument("--gap", default=None, help='shroud gap (default: the rig file\'s, e.g. "0.5 mm")')
    add_model_options(p)
    p.set_defaults(func=run)


def run_settings(args: argparse.Namespace, fe_values: list[float]):
    """:class:`rigtools.simulation.RunSettings` from the options, checked against the periods."""
    from rigtools.simulation import K_MAX, RunSettings

    duration = number(args.duration, "time", "--duration")
    max_settle = number(args.max_settle, "time", "--max-settle")
    if not duration > 0:
        raise UserError(f"--duration = {args.duration!r}: must be > 0 s")
    for fe in fe_values:
        if duration * fe < 1.0 - 1e-9:
            raise UserError(
                f"--duration = {args.duration!r} is shorter than one excitation period "
                f"(1/fe = {1 / fe:.4g} s at fe = {fe:g} Hz)"
            )
    if max_settle < 0:
        raise UserError(f"--max-settle = {args.max_settle!r}: must be >= 0")
    n = args.steps_per_period
    if n is not None and not 4 * K_MAX <= n <= MAX_STEPS_PER_PERIOD:
        raise UserError(
            f"--steps-per-period = {n}: need {4 * K_MAX} (to resolve harmonic {K_MAX}) to "
            f"{MAX_STEPS_PER_PERIOD}"
        )
    return RunSettings(duration=duration, max_settle_time=max_settle, steps_per_period=n)


def announce_model(params, model: str = "fem", quiet: bool = False) -> str:
    """Refuse an FE model too large for the memory (one line with the estimate); say so when
    building it will take long. Returns ``"N + M elements"`` for status lines."""
    from rigtools.simulation import check_memory, human_seconds, model_build_estimate

    seconds, peak = model_build_estimate(params, model)
    elements = f"{params.active.elements} + {params.passive.elements} elements"
    check_memory(peak, f"the FE model ({elements})", "use fewer [blade] elements")
    if seconds > 20 and not quiet:
        print(f"building the FE model ({elements}) takes about {human_seconds(seconds)}", file=sys.stderr)
    return elements


@contextmanager
def working(text: str, quiet: bool = False) -> Iterator[None]:
    """A spinner with the elapsed time on stderr while the block runs (nothing if ``quiet`` or
    stderr is not a terminal)."""
    if quiet or not sys.stderr.isatty():
        yield
        return
    from rich.console import Console
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    with Progress(
        SpinnerColumn(),
        TextColumn("{task.description}"),
        TimeElapsedColumn(),
        console=Console(stderr=True),
        transient=True,
    ) as bar:
        bar.add_task(text, total=None)
        yield


@contextmanager
def simulated_time_bar(text: str, at_most: float, quiet: bool = False) -> Iterator:
    """A progress bar of simulated time (settling, at most --max-settle, then the record) on
    stderr; yields the ``progress(simulated_s, at_most_s)`` callback (None if quiet / not a tty)."""
    if quiet or not sys.stderr.isatty():
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed:.3g}/{task.total:.3g} s"),
        TimeElapsedColumn(),
        console=Console(stderr=True),
        transient=True,
    ) as bar:
        task = bar.add_task(f"settling {text}", total=at_most)
        yield lambda done, total: bar.update(task, completed=done, total=total)


def load_model(args: argparse.Namespace, quiet: bool):
    """``(rig config, reduced system)`` of ``--rig`` and ``--model``, announced (:func:`announce_model`)."""
    from rigtools.config import load_rig
    from rigtools.sim.reduction import reduced_system

    cfg = load_rig(args.rig)
    params = cfg.to_params()
    elements = announce_model(params, args.model, quiet)
    with working(
        f"building the {'FE' if args.model == 'fem' else 'assumed-modes'} model ({elements})", quiet
    ):
        return cfg, reduced_system(params, args.model)


def announce_work(system, points: list[tuple[float, float]], settings, quiet: bool) -> None:
    """Refuse a run that needs more memory than available; say so when the runs will take long.

    ``points``: (fe, force) of each run."""
    from rigtools.simulation import (
        LONG_WORK_SECONDS,
        check_memory,
        human_seconds,
        run_memory_estimate,
        run_time_estimate,
        steps_per_period,
    )

    worst = max(points, key=lambda p: run_memory_estimate(system, p[0], p[1], settings))
    need = run_memory_estimate(system, *worst, settings)
    n = steps_per_period(system, *worst, settings)
    check_memory(
        need,
        f"a run of {n} steps per period x {settings.record_periods(worst[0])} recorded periods",
        "shorten --duration (or give fewer --steps-per-period, or a softer contact)",
    )
    least = sum(run_time_estimate(system, fe, f, settings)[0] for fe, f in points)
    most = sum(run_time_estimate(system, fe, f, settings)[1] for fe, f in points)
    if most > LONG_WORK_SECONDS and not quiet:
        c = system.contact
        print(
            f"this will take {human_seconds(least)} to {human_seconds(most)} (contact stiffness {c.stiffness:.3g} "
            f"N/m: {n} steps per period; the most if settling takes all of --max-settle)",
            file=sys.stderr,
        )
    from rigtools.runtime import ensure_kernels_compiled

    ensure_kernels_compiled()  # first run only: says so instead of a frozen progress bar


# ------------------------------------------------------------------------------ rig simulate


def write_plot(args: argparse.Namespace, out: Path, make_figure) -> Path | None:
    """``make_figure()`` saved beside ``out`` (:func:`rigtools.figures.plot_path`), unless ``--no-plot``."""
    if args.no_plot:
        return None
    from rigtools.figures import plot_path, save_figure

    return save_figure(make_figure(), plot_path(out))


def run(args: argparse.Namespace) -> int:
    from rigtools.errors import Interrupted as Stopped
    from rigtools.runtime import StopRequests

    written: list[Path] = []
    with StopRequests() as stops:
        try:
            return _run(args, stops, written)
        except Stopped as exc:
            what = f"{written[0]} is complete (no summary or plot)" if written else "nothing written"
            print(f"rig simulate: {exc.reason}; {what}", file=sys.stderr)
            return exc.exit_code


def _run(args: argparse.Namespace, stops, written: list) -> int:
    from rigtools import simulation as simu
    from rigtools.recording import RecordingWriter

    out = check_output(args)
    fe = number(args.fe, "frequency", "--fe")
    force = number(args.force, "force", "--force")
    if not fe > 0:
        raise UserError(f"--fe = {args.fe!r}: the excitation frequency must be > 0 Hz")
    if force < 0:
        raise UserError(f"--force = {args.force!r}: the force amplitude must be >= 0 N")
    gap = None if args.gap is None else gap_option(args.gap)
    settings = run_settings(args, [fe])
    cfg, system = load_model(args, quiet=args.json)
    if gap is not None:
        system = system.with_contact(gap=gap)
    announce_work(system, [(fe, force)], settings, quiet=args.json)
    with simulated_time_bar(
        f"{fe:g} Hz, {force:g} N, gap {system.contact.gap * 1e3:g} mm",
        (max(math.ceil(settings.max_settle_time * fe), 5) + settings.record_periods(fe)) / fe,
        args.json,
    ) as progress:
        result = simu.simulate_point(system, fe, force, settings, progress=progress)
    experiment = {"procedure": "simulate", "model": args.model, "cli": "rig simulate"}
    with stops.protected():  # a stop request waits until the file is complete
        with RecordingWriter(
            out, backend="fem", rig=cfg.to_json(), experiment=experiment, overwrite=args.overwrite
        ) as rec:
            simu.write_point(rec, result, args.model)
        written.append(out)
    doc = {
        "harmonics": simu.harmonics_of(result),
        "contact": {
            "peak_force_n": result.peak_contact_force,
            "impacts_per_period": result.impacts_per_period,
        },
        "steady_state": bool(result.steady_state),
    }
    png = write_plot(args, out, lambda: simu.run_figure(result, system, f"{cfg.name} ({args.model.upper()})"))
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
    names = ("active_shroud_accel", "passive_shroud_accel", "force", "contact_force")
    for name in names:
        table.add_column(name + (" (m/s²)" if "accel" in name else " (N)"), justify="right")
    h = doc["harmonics"]
    for i in range(10):
        table.add_row(
            str(i + 1),
            f"{h['force'][i]['frequency_hz']:g}",
            *(f"{h[name][i]['amplitude']:.4g}" for name in names),
        )
    console.print(table)
    c = doc["contact"]
    console.print(
        f"peak contact force {c['peak_force_n']:.4g} N, {c['impacts_per_period']:g} impacts per period, "
        f"steady state: {'yes' if doc['steady_state'] else 'NO'} "
        f"(after {result.settle_time:.3g} s simulated); wrote {out}"
        + (f" and {doc['plot']}" if doc.get("plot") else "")
    )
