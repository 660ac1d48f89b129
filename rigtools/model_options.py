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
from pathlib import Path
from typing import Any

from rigtools.errors import UserError
from rigtools.memory import check_memory
from rigtools.options import duration as _duration
from rigtools.options import quantity
from rigtools.progress import working

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


def announce_work(system: Any, points: list[tuple[float, float]], settings: Any, quiet: bool) -> None:
    """Refuse a run that needs more memory than available; say so when the runs will take long.

    ``points``: (fe, force) of each run."""
    from rigtools.simulation import (
        LONG_WORK_SECONDS,
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
            f"this will take {human_seconds(least)} to {human_seconds(most)} (contact stiffness "
            f"{c.stiffness:.3g} N/m: {n} steps per period; the most if settling takes all of --max-settle)",
            file=sys.stderr,
        )
    from rigtools.runtime import ensure_kernels_compiled

    ensure_kernels_compiled()  # first run only: says so instead of a frozen progress bar


def write_plot(no_plot: bool, out: Path, make_figure: Callable[[], Any]) -> Path | None:
    """``make_figure()`` saved beside ``out`` (:func:`rigtools.derived_files.plot_path`), unless ``no_plot``."""
    if no_plot:
        return None
    from rigtools.derived_files import plot_path
    from rigtools.figures import save_figure

    return save_figure(make_figure(), plot_path(out))
