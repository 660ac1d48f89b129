"""What every model-run command shares (``rig simulate``, ``rig study``, ``rig harmonic``,
``rig modal``): the model options, the run settings checked against the excitation periods, and
the up-front refusal or announcement of what a model or a run will cost.

Light at import (argparse and rigtools' light modules only): command modules import it at the top;
the model itself is built only when a command runs.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path
from typing import Any

from rigtools.errors import UserError
from rigtools.memory import check_memory
from rigtools.options import duration as _duration
from rigtools.options import quantity
from rigtools.progress import working
from rigtools.units import MAX_FORCE

MAX_STEPS_PER_PERIOD = 10_000_000


def add_model_options(p: argparse.ArgumentParser) -> None:
    """``--rig --model --duration --max-settle --steps-per-period --out --overwrite --json --no-plot``."""
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


def run_settings(
    duration: str | float,
    max_settle: str | float,
    steps_per_period: int | None,
    fe_values: Sequence[float],
    *,
    names: tuple[str, str, str] = ("--duration", "--max-settle", "--steps-per-period"),
) -> Any:
    """:class:`rigtools.simulation.RunSettings` checked against the excitation periods.

    Parameters
    ----------
    duration
        Recorded time after the steady state (``"1 s"`` or s), at least one period of every fe.
    max_settle
        Simulated time allowed to reach the steady state (``"30 s"`` or s), ``>= 0``.
    steps_per_period
        Time steps per excitation period, or ``None`` (chosen from the contact).
    fe_values
        Excitation frequencies (Hz) the settings will run at.
    names
        How messages name the three settings: the CLI's options, or the front door's arguments.
    """
    from rigtools.simulation import K_MAX, RunSettings

    duration_name, settle_name, steps_name = names
    recorded = _duration(duration, duration_name)
    for fe in fe_values:
        if recorded * fe < 1.0 - 1e-9:
            raise UserError(
                f"{duration_name} = {duration!r} is shorter than one excitation period "
                f"(1/fe = {1 / fe:.4g} s at fe = {fe:g} Hz)"
            )
    settle = _duration(max_settle, settle_name, allow_zero=True)
    n = steps_per_period
    if n is not None and not 4 * K_MAX <= n <= MAX_STEPS_PER_PERIOD:
        raise UserError(
            f"{steps_name} = {n}: need {4 * K_MAX} (to resolve harmonic {K_MAX}) to {MAX_STEPS_PER_PERIOD}"
        )
    return RunSettings(duration=recorded, max_settle_time=settle, steps_per_period=n)


def settings_of(args: argparse.Namespace, fe_values: Sequence[float]) -> Any:
    """:func:`run_settings` of the options added by :func:`add_model_options`."""
    return run_settings(args.duration, args.max_settle, args.steps_per_period, fe_values)


def excitation(
    fe: str | float, force: str | float, *, names: tuple[str, str] = ("--fe", "--force")
) -> tuple[float, float]:
    """``(fe, F0)`` in Hz and N: ``fe > 0``, ``F0 >= 0``, each a finite quantity; messages name
    them as ``names`` (the CLI's options, or the front door's arguments)."""
    fe_name, force_name = names
    f = quantity(fe, "frequency", fe_name)
    if not f > 0:
        raise UserError(f"{fe_name} = {fe!r}: the excitation frequency must be > 0 Hz")
    f0 = quantity(force, "force", force_name)
    if f0 < 0:
        raise UserError(f"{force_name} = {force!r}: the force amplitude must be >= 0 N")
    if f0 > MAX_FORCE:
        raise UserError(
            f"{force_name} = {force!r}: outside the allowed range [0, {MAX_FORCE:g}] N "
            "(the shaker's range, as rig acquire's)"
        )
    return f, f0


def announce_model(params: Any, model: str = "fem", quiet: bool = False) -> str:
    """Refuse an FE model too large for the memory (one line with the estimate); say so when
    building it will take long. Returns ``"N + M elements"`` for status lines."""
    from rigtools.simulation import human_seconds, model_build_estimate

    seconds, peak = model_build_estimate(params, model)
    elements = f"{params.active.elements} + {params.passive.elements} elements"
    check_memory(peak, f"the FE model ({elements})", "use fewer [blade] elements")
    if seconds > 20 and not quiet:
        print(f"building the FE model ({elements}) takes about {human_seconds(seconds)}", file=sys.stderr)
    return elements


def load_model(rig: str | None, model: str, quiet: bool) -> tuple[Any, Any]:
    """``(rig config, reduced system)`` of a rig file (``None``: the default rig) and a model
    (``"fem"`` or ``"am"``), announced (:func:`announce_model`)."""
    from rigtools.config import load_rig
    from rigtools.sim.reduction import reduced_system

    cfg = load_rig(rig)
    params = cfg.to_params()
    elements = announce_model(params, model, quiet)
    with working(f"building the {'FE' if model == 'fem' else 'assumed-modes'} model ({elements})", quiet):
        return cfg, reduced_system(params, model)


def announce_work(
    system: Any,
    points: list[tuple[float, float]],
    settings: Any,
    quiet: bool,
    *,
    names: tuple[str, str] = ("--fe", "--duration"),
) -> None:
    """Refuse a run that needs more memory than available or an excitation far above the model
    (:func:`rigtools.simulation.check_model_range`); say so, in one line on stderr with the
    estimate, when the runs may take longer than :data:`rigtools.simulation.LONG_WORK_SECONDS`.

    ``points``: (fe, force) of each run. The estimate (:func:`rigtools.simulation.run_time_estimate`)
    covers the steps per period (contact, fe), the periods to settle (growing with fe), the
    recorded periods and the model's size (its modes). ``names``: how the messages name the
    frequency and the recorded duration (the CLI's options, or the front door's arguments)."""
    from rigtools.simulation import (
        LONG_WORK_SECONDS,
        check_model_range,
        human_seconds,
        run_memory_estimate,
        run_time_estimate,
        steps_per_period,
    )

    fe_name, duration_name = names
    for fe, _ in points:
        check_model_range(system, fe, fe_name)
    worst = max(points, key=lambda p: run_memory_estimate(system, p[0], p[1], settings))
    need = run_memory_estimate(system, *worst, settings)
    n = steps_per_period(system, *worst, settings)
    check_memory(
        need,
        f"a run of {n} steps per period x {settings.record_periods(worst[0])} recorded periods",
        f"shorten {duration_name}"
        + (
            " (or give fewer --steps-per-period, or a softer contact)"
            if duration_name.startswith("--")
            else ""
        ),
    )
    estimates = [run_time_estimate(system, fe, f, settings) for fe, f in points]
    expected = sum(e.seconds for e in estimates)
    most = sum(e.worst_case_seconds for e in estimates)
    if most > LONG_WORK_SECONDS and not quiet:
        print(long_work_line(system, points, estimates, expected, most, human_seconds), file=sys.stderr)
    from rigtools.runtime import ensure_kernels_compiled

    ensure_kernels_compiled()  # first run only: says so instead of a frozen progress bar


def long_work_line(system: Any, points, estimates, expected: float, most: float, human) -> str:
    """The announcement: the total and what makes the costliest run cost."""
    k = max(range(len(points)), key=lambda i: estimates[i].worst_case_seconds)
    e, fe = estimates[k], points[k][0]
    runs = f"{len(points)} runs, the longest: " if len(points) > 1 else ""
    return (
        f"this will take about {human(expected)}, up to {human(most)} if settling takes all of "
        f"--max-settle ({runs}{e.steps_per_period} steps per period, set by the {e.limited_by}, x "
        f"~{e.settle_periods} periods to settle + {e.record_periods} recorded at {fe:g} Hz; "
        f"{system.n_modes} modes)"
    )


def plot_ahead(no_plot: bool) -> AbstractContextManager[Any]:
    """A :class:`rigtools.plot_process.PlotProcess` importing the plotting code while the command
    works, ended on leaving the block; ``None`` with ``no_plot``."""
    if no_plot:
        return nullcontext(None)
    from rigtools.plot_process import PlotProcess

    return PlotProcess()


def write_plot(no_plot: bool, out: Path, make_figure: Callable[[], Any], helper: Any = None) -> Path | None:
    """``make_figure()`` saved beside ``out`` (:func:`rigtools.derived_files.plot_path`), unless
    ``no_plot``: by ``helper`` (:func:`plot_ahead`'s; ``make_figure`` then picklable, e.g. a
    :func:`functools.partial`) if given and able, else in this process."""
    if no_plot:
        return None
    from rigtools.derived_files import plot_path

    path = plot_path(out)
    if helper is not None and helper.write(make_figure, path):
        return path
    from rigtools.figures import save_figure  # matplotlib: imported here only when drawn here

    return save_figure(make_figure(), path)
