"""Model runs as recordings: the vibro-impact simulations that ``rig simulate``, ``rig study``
and later the EM-versus-FEM comparison and the demo share.

* :func:`load_system`, :func:`simulate_point`: the reduced model of a rig file and one settled run
  (its natural frequencies: :mod:`rigtools.sim.natural_frequencies`);
* :data:`MODEL_OUTPUTS`, :func:`channel_specs`, :func:`channel_block`, :func:`point_params`,
  :func:`end_attrs`: a run as one recording point, named by :mod:`rigtools.vocabulary`;
* :func:`harmonics_of`, :func:`point_summary`: the small per-point results printed or plotted;
* :func:`write_study`: a study streamed point by point into a recording (nothing finished is
  lost on Ctrl-C, SIGTERM, a crash or SIGKILL; memory does not grow with the points);
* :func:`run_memory_estimate`, :func:`run_time_estimate`, :func:`model_build_estimate`: what a
  run will cost, to refuse or announce it up front.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rigtools.analysis.harmonics import derivative_harmonics, harmonic_amplitudes
from rigtools.config import load_rig
from rigtools.errors import UserError
from rigtools.plot_process import FigureCall
from rigtools.recording import ChannelSpec
from rigtools.sim.natural_frequencies import reduced_natural_frequencies
from rigtools.sim.reduction import estimate_reduction_seconds, reduced_system
from rigtools.sim.vibro_impact import (
    SimulationInputError,
    check_time_step,
    contact_force_harmonics,
    estimate_steps,
    run_harmonic,
    steps_per_period_for,
    validate_contact,
)
from rigtools.study_runner import RunOptions, StudyRunner
from rigtools.units import MAX_GAP
from rigtools.vocabulary import CHANNELS

if TYPE_CHECKING:
    from rigtools.sim.studies import PlannedPoint
    from rigtools.sim.vibro_impact import VibroImpactRun

K_MAX = 30

# recorded channel (vocabulary name) -> output of rigtools.sim.vibro_impact.run_harmonic
MODEL_OUTPUTS: dict[str, str] = {
    "active_shroud_accel": "active_tip_acceleration",
    "passive_shroud_accel": "passive_tip_acceleration",
    "force": "excitation_force",
    "active_shroud_disp": "active_tip_displacement",
    "passive_shroud_disp": "passive_tip_displacement",
    "force_point_disp": "force_point_displacement",
    "active_shroud_vel": "active_tip_velocity",
    "passive_shroud_vel": "passive_tip_velocity",
    "force_point_vel": "force_point_velocity",
    "force_point_accel": "force_point_acceleration",
    "contact_force": "contact_force",
}
# harmonics reported per run: channel -> (run output, time derivatives applied to it). The
# accelerations come from the velocity, k w |V_k|: exact for a periodic response, while the
# point samples of an acceleration that jumps at impacts converge only to first order.
HARMONIC_SOURCES: dict[str, tuple[str, int]] = {
    "active_shroud_accel": ("active_tip_velocity", 1),
    "passive_shroud_accel": ("passive_tip_velocity", 1),
    "force": ("excitation_force", 0),
    "contact_force": ("contact_force", 0),
}

# Cost model (measured on a 2-core machine; estimates are stated as "about").
RECORD_BYTES_PER_SAMPLE = 600  # peak memory per recorded time step (outputs, copies, FFT, plot)
SETTLE_BYTES_PER_STEP = 5 * 2 * 14 * 8  # settling keeps 5 periods of 14 outputs, twice
# the sparse build and reduction: assembly triplets, LU fill, a few dozen vectors per DOF (both
# blades: 1335 / 1180 / 1132 bytes per DOF measured at 1600 / 6400 / 20000 elements per blade)
FE_BUILD_BYTES_PER_DOF = 1500.0
LONG_WORK_SECONDS = 60.0  # announce work expected to take longer than this
# refuse an excitation this far above the model's highest mode (kept or static-correction): the
# response there is the truncation of the model, not the blades', and the rig cannot drive it
MODEL_RANGE_FACTOR = 10.0


@dataclass(frozen=True)
class RunSettings:
    """How each settled run is made (SI).

    Attributes
    ----------
    duration
        Recorded time after the steady state, s (rounded to whole periods, at least one).
    max_settle_time
        Simulated time after which settling gives up (the record follows, ``settled`` False), s.
    steps_per_period
        Time steps per excitation period; ``None``: 30 per contact period, at least 120.
    """

    duration: float = 1.0
    max_settle_time: float = 30.0
    steps_per_period: int | None = None

    def record_periods(self, fe: float) -> int:
        return max(1, round(self.duration * fe))


# ------------------------------------------------------------------------------ the model


def load_system(rig: str | None, model: str = "fem"):
    """``(rig config, reduced system)`` of a rig file (``None``: the default rig) for ``model``
    (``"fem"`` or ``"am"``)."""
    cfg = load_rig(rig)
    return cfg, reduced_system(cfg.to_params(), model)


def simulate_point(
    system,
    fe: float,
    force: float,
    settings: RunSettings,
    initial=None,
    progress: Callable[[float, float], None] | None = None,
):
    """One settled run of ``F0 sin(2 pi fe t)`` (:func:`rigtools.sim.vibro_impact.run_harmonic`);
    :class:`rigtools.sim.vibro_impact.SimulationInputError` becomes a one-line :class:`UserError`.
    ``progress(simulated_s, at_most_s)`` is called while settling."""
    try:
        run = run_harmonic(
            system,
            fe,
            force,
            record_periods=settings.record_periods(fe),
            steps_per_period=settings.steps_per_period,
            max_settle_time=settings.max_settle_time,
            initial=initial,
            progress=progress,
        )
    except SimulationInputError as exc:
        raise UserError(str(exc)) from None
    check_finite(run)
    check_plausible(run)
    return run


def check_plausible(run) -> None:
    """Refuse a run whose shroud moves farther than any blade of the rig can (more than
    :data:`rigtools.units.MAX_GAP`, the widest gap a blade could close): the linear beam model is
    meaningless there, so it is never reported as a steady state. A typical cause is a unit slip
    (``"1 MN"`` for ``"1 mN"``)."""
    for name in ("active_tip_displacement", "passive_tip_displacement"):
        peak = float(np.max(np.abs(run.outputs[name]))) if run.outputs[name].size else 0.0
        if peak > MAX_GAP:
            raise UserError(
                f"--force = {run.force_amplitude:g} N at {run.fe:g} Hz moves the {name.split('_')[0]} shroud "
                f"{peak:.3g} m, more than any blade of the rig can ({MAX_GAP * 1e3:g} mm): not a "
                "physical steady state; check the force and its unit (mN, N, kN)"
            )


def check_finite(run) -> None:
    """Refuse a run whose outputs hold NaN or inf, naming the likely parameter."""
    bad = [name for name in MODEL_OUTPUTS.values() if not np.all(np.isfinite(run.outputs[name]))]
    if bad:
        raise UserError(
            f"the simulation diverged at fe = {run.fe:g} Hz, F0 = {run.force_amplitude:g} N, "
            f"gap = {run.gap * 1e3:g} mm ({bad[0]} is not finite): check the rig file's "
            "[contact] damping/stiffness and [damping] values"
        )


# ------------------------------------------------------------------------------ a run as a point


def channel_specs(sample_rate: float) -> list:
    """:class:`rigtools.recording.ChannelSpec` of every model channel, vocabulary order."""
    return [
        ChannelSpec(
            name=name,
            units=CHANNELS[name].units,
            quantity=CHANNELS[name].quantity,
            sample_rate=sample_rate,
            location=CHANNELS[name].location,
        )
        for name in MODEL_OUTPUTS
    ]


def channel_block(run, start: int = 0, stop: int | None = None) -> np.ndarray:
    """(channels, samples) block of a run (samples ``start:stop``) in :func:`channel_specs` order."""
    return np.vstack([run.outputs[src][start:stop] for src in MODEL_OUTPUTS.values()])


APPEND_SAMPLES = 1 << 20  # samples per appended block: no full copy of a long record


def force_fundamental(run) -> float:
    """Harmonic 1 (peak) of the force channel: ``force_amplitude_measured``."""
    return float(harmonic_amplitudes(run.outputs["excitation_force"], run.sample_rate, run.fe, 1).at(1))


def point_params(run, model: str) -> dict:
    """Parameters known when the point begins (vocabulary names, SI)."""
    return {
        "fe": run.fe,
        "force_amplitude": run.force_amplitude,
        "gap": run.gap,
        "model": model,
        "steps_per_period": run.steps_per_period,
        "time_step": run.dt,
        "settle_time": run.settle_time,
    }


def end_attrs(run) -> dict:
    """Parameters written when the point ends (vocabulary names, SI)."""
    return {
        "settled": bool(run.steady_state),
        "period_multiple": int(run.period_multiple),
        "peak_contact_force": run.peak_contact_force,
        "impacts_per_period": run.impacts_per_period,
        "force_amplitude_measured": force_fundamental(run),
    }


def write_point(rec, run, model: str, **extra) -> None:
    """One run as the next point of an open :class:`rigtools.recording.RecordingWriter`."""
    params = point_params(run, model)
    params.update(extra)
    point = rec.begin_point(params=params, channels=channel_specs(run.sample_rate))
    n = run.time.size
    for start in range(0, n, APPEND_SAMPLES):
        point.append(channel_block(run, start, min(n, start + APPEND_SAMPLES)))
    point.set_attrs(**end_attrs(run))
    point.end()


def harmonics_of(run) -> dict[str, list[dict]]:
    """k = 1..30 harmonics (peak amplitudes) of the reported channels:
    ``{channel: [{"k", "frequency_hz", "amplitude"}, ...]}``."""
    out = {}
    for name, (src, order) in HARMONIC_SOURCES.items():
        if src == "contact_force":  # exact from the per-step force (it jumps between samples)
            c = np.abs(contact_force_harmonics(run, K_MAX))
            out[name] = [
                {"k": k, "frequency_hz": k * run.fe, "amplitude": float(c[k - 1])}
                for k in range(1, K_MAX + 1)
            ]
            continue
        fit = harmonic_amplitudes(run.outputs[src], run.sample_rate, run.fe, K_MAX)
        if order:
            fit = derivative_harmonics(fit, order)
        out[name] = [
            {"k": r["k"], "frequency_hz": r["frequency_hz"], "amplitude": r["amplitude"]}
            for r in fit.to_records()
        ]
    return out


def point_summary(run) -> dict:
    """The small result of a run kept after its samples are written (``rig study --json`` point)."""
    return {
        "fe": run.fe,
        "force_amplitude": run.force_amplitude,
        "gap": run.gap,
        "force_amplitude_measured": force_fundamental(run),
        "steady_state": bool(run.steady_state),
        "peak_contact_force_n": run.peak_contact_force,
        "impacts_per_period": run.impacts_per_period,
        "harmonics": harmonics_of(run),
    }


def run_figure(run, system, title: str) -> FigureCall:
    """:func:`rigtools.analysis.plots.vibro_impact_figure` of one settled run, as a call to make:
    picklable, holding only the arrays it draws, and made without importing matplotlib (the
    figure is drawn by :mod:`rigtools.plot_process`, or in this process by calling it)."""
    o = run.outputs
    return FigureCall(
        "rigtools.analysis.plots",
        "vibro_impact_figure",
        run.time,
        o["active_tip_displacement"],
        o["passive_tip_displacement"],
        o["contact_force"],
        o["active_tip_acceleration"],
        o["passive_tip_acceleration"],
        run.fe,
        k_max=K_MAX,
        gap=run.gap,
        natural_frequencies_hz=reduced_natural_frequencies(system),
        title=title,
        force=o["excitation_force"],
    )


# ------------------------------------------------------------------------------ studies


def iter_study_points(
    system, plan, settings: RunSettings, progress: Callable[[float, float], None] | None = None, runner=None
) -> Iterator[tuple[PlannedPoint, VibroImpactRun]]:
    """``(planned point, settled run)`` of a :class:`rigtools.sim.studies.StudyPlan` or ``MapPlan``, in
    point order, through ``runner`` (a :class:`rigtools.study_runner.StudyRunner`; default
    in-process); input errors become :class:`UserError`. ``progress(simulated_s, at_most_s)``
    while each settles (in-process)."""
    runner = runner if runner is not None else StudyRunner()
    options = RunOptions(
        record_duration=settings.duration,
        steps_per_period=settings.steps_per_period,
        max_settle_time=settings.max_settle_time,
    )
    it = iter(runner.run(system, plan.chains(), options, settle_progress=progress))
    while True:
        try:
            point, run = next(it)
        except StopIteration:
            return
        except SimulationInputError as exc:
            raise UserError(str(exc)) from None
        check_finite(run)
        yield point, run


def write_study(
    rec,
    system,
    plan,
    settings: RunSettings,
    model: str,
    on_point: Callable[[PlannedPoint, dict], None] | None = None,
    guard: Callable[[], AbstractContextManager] = nullcontext,
    progress: Callable[[float, float], None] | None = None,
    runner=None,
) -> list[dict]:
    """Run a study and write each point to ``rec`` as soon as it settles.

    Only the per-point summaries (:func:`point_summary` plus ``value`` and ``direction``) are
    kept, so memory does not grow with the number of points. ``on_point(planned, summary)`` is
    called after each point is on disk; ``progress(simulated_s, at_most_s)`` while each point
    settles. Each point is written inside ``guard()`` (e.g.
    :meth:`rigtools.runtime.StopRequests.protected`, so a stop request waits for the write).
    Exceptions (Ctrl-C included) propagate with every finished point written; the caller ends
    the recording. ``runner`` (:class:`rigtools.study_runner.StudyRunner`) runs the points:
    in-process by default, or on a Dask cluster; points arrive and are written in point order.
    """
    summaries = []
    for planned, run in iter_study_points(system, plan, settings, progress, runner):
        with guard():
            write_point(rec, run, model, direction=planned.direction, study_value=planned.value)
        summary = {"value": planned.value, "direction": planned.direction, **point_summary(run)}
        del run
        summaries.append(summary)
        if on_point is not None:
            on_point(planned, summary)
    return summaries


# ------------------------------------------------------------------------------ costs


def steps_per_period(system, fe: float, force: float, settings: RunSettings) -> int:
    """The steps per period a run will use (:func:`rigtools.sim.vibro_impact.run_harmonic`'s rule)."""
    if settings.steps_per_period is not None:
        n = int(settings.steps_per_period)
        try:  # the contact must be resolved: refused before the first step, naming the option
            validate_contact(system)
            check_time_step(system, 1.0 / (fe * n), force_scale=max(100.0, 10.0 * force))
        except SimulationInputError as exc:
            raise UserError(f"--steps-per-period = {n}: {exc}") from None
        return n
    try:
        validate_contact(system)
        return steps_per_period_for(system, fe, force_scale=max(100.0, 10.0 * force))
    except SimulationInputError as exc:
        raise UserError(str(exc)) from None


def run_memory_estimate(system, fe: float, force: float, settings: RunSettings) -> int:
    """Peak bytes of one settled run with its recording, summary and plot."""
    n = steps_per_period(system, fe, force, settings)
    samples = n * settings.record_periods(fe)
    return int(samples * RECORD_BYTES_PER_SAMPLE + n * SETTLE_BYTES_PER_STEP)


def run_time_estimate(system, fe: float, force: float, settings: RunSettings):
    """What one settled run will cost, before it runs
    (:func:`rigtools.sim.vibro_impact.estimate_steps` with these settings).

    Steps per period (the contact's or ``settings.steps_per_period``) x periods to settle (the
    slowest modal decay, at most ``max_settle_time``, so it grows with fe) plus the recorded
    periods, times the model's modes (its size): ``.seconds`` expected, ``.worst_case_seconds``
    if settling takes all of ``max_settle_time``.

    Returns
    -------
    rigtools.sim.vibro_impact.CostEstimate
    """
    n = steps_per_period(system, fe, force, settings)  # refuses a bad --steps-per-period by name
    return estimate_steps(
        system,
        fe,
        force,
        record_periods=settings.record_periods(fe),
        steps_per_period=n if settings.steps_per_period is not None else None,
        max_settle_time=settings.max_settle_time,
    )


#: Continuation cost, measured on the calibrated FEM (14 modes, 28 states) on a 2-core machine:
#: 0.15 s per branch point at 328 steps per period (Newton iterations with the monodromy
#: matrix) and 7.7 kB of peak memory per step of a period (the sensitivities: ~10 B x states^2)
CONTINUATION_SECONDS_PER_STEP = 0.15 / 328
CONTINUATION_BYTES_PER_STEP_STATE2 = 10


def continuation_cost(system, fe_min: float, force_max: float) -> tuple[int, int, float]:
    """``(steps per period, peak bytes of one orbit, seconds per branch point)`` of a
    continuation whose lowest frequency is ``fe_min`` (the most steps per period: a period of
    the same time step) and largest force ``force_max`` (the contact's time scale), scaled from
    :data:`CONTINUATION_SECONDS_PER_STEP` by the model's states."""
    n = steps_per_period_for(system, fe_min, force_scale=max(100.0, 10.0 * force_max))
    states = 2 * int(np.size(system.omega))
    scale = (states / 28.0) ** 2
    return (
        n,
        int(n * states**2 * CONTINUATION_BYTES_PER_STEP_STATE2),
        n * CONTINUATION_SECONDS_PER_STEP * scale,
    )


def check_model_range(system, fe: float, name: str = "--fe") -> None:
    """Refuse an excitation more than :data:`MODEL_RANGE_FACTOR` times above the model's highest
    mode (kept modes and static-correction shapes): no answer there can be useful (the blades'
    modes that respond there are not in the model, and the rig's DAQ cannot drive it). ``name``:
    how the message names the frequency (the CLI's option, or the front door's argument)."""
    top = float(np.max(system.omega)) / (2.0 * math.pi)
    if fe > MODEL_RANGE_FACTOR * top:
        raise UserError(
            f"{name} = {fe / 1e3:.4g} kHz is more than {MODEL_RANGE_FACTOR:g} x the model's highest mode "
            f"({top / 1e3:.4g} kHz): its response there is not the blades'; "
            f"excite below {MODEL_RANGE_FACTOR * top / 1e3:.4g} kHz"
        )


def model_build_estimate(params, model: str = "fem") -> tuple[float, int]:
    """(seconds, peak bytes) to build the FE model of both blades and their modes (the seconds:
    :func:`rigtools.sim.reduction.estimate_reduction_seconds`)."""
    if model != "fem":
        return 0.0, 0
    peak = int(
        FE_BUILD_BYTES_PER_DOF * sum(6 * (int(b.elements) + 1) for b in (params.active, params.passive))
    )
    return estimate_reduction_seconds(params), peak


def human_seconds(s: float) -> str:
    """``"45 s"``, ``"4 min"``, ``"2.5 h"``."""
    if s < 90:
        return f"{s:.0f} s"
    if s < 5400:
        return f"{s / 60:.0f} min"
    return f"{s / 3600:.1f} h"
