"""Vibro-impact runs of a :class:`rigtools.sim.reduction.ReducedSystem`: a harmonic (or periodic)
force, settled to a detected steady state, then whole periods recorded (:func:`run_harmonic`).

The parts, each importable from here as before:

* :mod:`rigtools.sim.impact_kernel`: the compiled inner loop (exact first-order-hold propagation
  of each mode, the contact force solved in every step, contact events located inside a step),
  :data:`OUT_COLUMNS`;
* :mod:`rigtools.sim.impact_stepper`: :class:`VibroImpactStepper` (block-wise, carried state,
  optional :class:`ShakerCoupling`), the time-step checks, :class:`SimulationDivergedError`;
* :mod:`rigtools.sim.run_steps`: steps per period, input checks and cost (:func:`estimate_steps`);
* :mod:`rigtools.sim.contact_harmonics`: exact contact-force harmonics of a settled run.

Time convention: ``step(u)`` takes the input at the END of each step (``u[i]`` at
``t0 + (i+1)*dt``, the input at ``t0`` being carried from the previous call) and returns the
outputs at the same instants.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from rigtools.sim.contact_harmonics import contact_force_harmonics
from rigtools.sim.impact_kernel import DIVERGED_DISPLACEMENT, N_OUT, OUT_COLUMNS, foh_propagators
from rigtools.sim.impact_stepper import (
    FORCE_SLOT,
    MAX_CONTACT_DAMPING_STEP,
    MIN_STEPS_PER_CONTACT,
    HasContact,
    ShakerCoupling,
    SimulationDivergedError,
    StepOutput,
    StepperState,
    VibroImpactStepper,
    check_time_step,
    diverged_message,
    effective_contact_damping,
    validate_contact,
)
from rigtools.sim.params import SimulationInputError
from rigtools.sim.reduction import ReducedSystem
from rigtools.sim.run_steps import (
    DEFAULT_STEPS_PER_CONTACT,
    SECONDS_PER_MODE_STEP,
    CostEstimate,
    estimate_steps,
    steps_per_period_for,
    validate_harmonic_input,
)
from rigtools.sim.steady_state import check_periodic

__all__ = [
    "DEFAULT_STEPS_PER_CONTACT",
    "DIVERGED_DISPLACEMENT",
    "MAX_CONTACT_DAMPING_STEP",
    "MIN_STEPS_PER_CONTACT",
    "N_OUT",
    "OUT_COLUMNS",
    "SECONDS_PER_MODE_STEP",
    "CostEstimate",
    "HasContact",
    "RunState",
    "ShakerCoupling",
    "SimulationDivergedError",
    "SimulationInputError",
    "StepOutput",
    "StepperState",
    "VibroImpactRun",
    "VibroImpactStepper",
    "check_time_step",
    "contact_force_harmonics",
    "diverged_message",
    "effective_contact_damping",
    "estimate_steps",
    "foh_propagators",
    "periodic_force",
    "periodic_force_terms",
    "run_harmonic",
    "steps_per_period_for",
    "validate_contact",
    "validate_harmonic_input",
]


@dataclass
class RunState:
    """What a sweep carries from one point to the next: the stepper state and the force phase."""

    stepper: StepperState
    phase: float = 0.0  # phase of the force sin(phase) at the state's time, rad


@dataclass
class VibroImpactRun:
    """A harmonically forced run, settled to steady state, then recorded.

    ``outputs`` holds the recorded time histories (keys of :data:`OUT_COLUMNS`, SI, y direction),
    sampled at ``sample_rate = fe * steps_per_period``; the record holds ``record_periods``
    whole excitation periods, starting at an instant where the force phase is zero.
    """

    fe: float
    force_amplitude: float
    gap: float
    dt: float
    steps_per_period: int
    record_periods: int
    time: np.ndarray
    outputs: dict[str, np.ndarray]
    steady_state: bool
    period_multiple: int
    mismatch: float
    settle_time: float
    contact_period: float
    final_state: RunState = field(repr=False)

    @property
    def sample_rate(self) -> float:
        return self.fe * self.steps_per_period

    @property
    def peak_contact_force(self) -> float:
        return float(self.outputs["contact_force"].max())

    @property
    def impacts_per_period(self) -> float:
        """Contact onsets per excitation period over the record.

        The record holds whole periods of a periodic response, so it wraps around: a contact
        that starts on the first sample is counted (its previous sample is the last one).
        """
        closed = self.outputs["contact_force"] > 0
        onsets = int(np.count_nonzero(closed & ~np.roll(closed, 1)))
        return onsets / self.record_periods

    @property
    def min_steps_per_contact(self) -> float:
        """Shortest contact in the record, in steps (inf without contact)."""
        closed = np.r_[False, self.outputs["contact_force"] > 0, False].astype(np.int8)
        edges = np.diff(closed)
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        # a contact that straddles the record ends is not a whole contact
        lengths = [e - s for s, e in zip(starts, ends, strict=True) if s > 0 and e < closed.size - 2]
        return float(min(lengths)) if lengths else float("inf")

    def energy_balance(self) -> dict[str, float]:
        """Work per excitation period over the record, J (contact damping from the exact
        per-step energies of the kernel, the rest by the periodic trapezoidal rule).

        Returns ``input`` (``excitation_force * force_point_velocity``), ``modal_damping``,
        ``contact_damping``, and ``imbalance = (input - dissipated) / input`` (stored energy
        returns to its value after whole periods of a periodic response).
        """
        o = self.outputs

        def work(p):  # whole periods of a periodic signal: the rectangle sum is the trapezoid rule
            return float(np.sum(p)) * self.dt / self.record_periods

        w_in = work(o["excitation_force"] * o["force_point_velocity"])
        w_md = work(o["damping_power"])
        w_cd = work(o["contact_damping_power"])
        imbalance = (w_in - w_md - w_cd) / w_in if w_in != 0 else float("nan")
        return {"input": w_in, "modal_damping": w_md, "contact_damping": w_cd, "imbalance": imbalance}


class _TipHistory:
    """The last ``keep`` samples of both tips' displacement and velocity (rows), appended from
    the kernel's output in place: no allocation per chunk."""

    COLUMNS = (0, 1, 3, 4)  # active x, v; passive x, v (OUT_COLUMNS)

    def __init__(self, keep: int, chunk: int) -> None:
        self.keep = int(keep)
        self.buf = np.empty((len(self.COLUMNS), self.keep + max(int(chunk), self.keep)))
        self.end = 0

    def append(self, out: np.ndarray) -> None:
        m, cap = out.shape[0], self.buf.shape[1]
        if m >= self.keep:
            for r, c in enumerate(self.COLUMNS):
                self.buf[r, : self.keep] = out[m - self.keep :, c]
            self.end = self.keep
            return
        if self.end + m > cap:
            # move the samples still needed to the front (row by row: 1-D copies, no temporary)
            n_old = min(self.end, self.keep - m)
            for r in range(len(self.COLUMNS)):
                self.buf[r, :n_old] = self.buf[r, self.end - n_old : self.end]
            self.end = n_old
        for r, c in enumerate(self.COLUMNS):
            self.buf[r, self.end : self.end + m] = out[:, c]
        self.end += m

    def view(self) -> np.ndarray:
        """(4, min(samples so far, keep)) view of the latest samples, oldest first."""
        return self.buf[:, max(0, self.end - self.keep) : self.end]


def _pair_scale(hist: np.ndarray, n: int) -> np.ndarray:
    """Common scale of the tip displacements (rows 0, 2) and of the tip velocities (rows 1, 3)
    over the last three periods."""
    span = np.ptp(hist[:, -3 * n :], axis=1)
    x, v = max(span[0], span[2]), max(span[1], span[3])
    return np.array([x, v, x, v])


def run_harmonic(
    system: ReducedSystem,
    fe: float,
    force_amplitude: float,
    *,
    record_periods: int = 20,
    steps_per_period: int | None = None,
    max_settle_time: float = 30.0,
    tol: float = 1e-5,
    check_every: int = 5,
    initial: RunState | None = None,
    min_settle_periods: int = 0,
    progress: Callable[[float, float], None] | None = None,
    force_harmonics=None,
) -> VibroImpactRun:
    """Force ``F0 sin(2 pi fe t)`` at the force point, run to a periodic steady state, record.

    With ``force_harmonics`` the periodic force ``sum_k A_k cos(k 2 pi fe t + phi_k)`` replaces
    ``F0 sin`` (e.g. the harmonics of a force measured on the rig).

    Parameters
    ----------
    system
        Reduced system (its ``contact`` sets the gap and stiffness).
    fe, force_amplitude
        Excitation frequency (Hz, > 0) and force amplitude (N, >= 0).
    record_periods
        Whole excitation periods recorded after settling (>= 1).
    steps_per_period
        Integer steps per period (default: :func:`steps_per_period_for`). Refused with
        :class:`SimulationInputError` if the step does not resolve the contact (for a Hertz
        contact, its tangent stiffness at ``max(100 N, 10 F0)``).
    max_settle_time
        Give up settling after this much simulated time, s (``steady_state`` is then False and
        the record follows anyway).
    tol
        Relative period-to-period mismatch of the tip displacements and velocities accepted
        as steady (:func:`rigtools.sim.steady_state.check_periodic`).
    check_every
        Periods simulated between checks.
    initial
        State to start from (a previous point of a sweep); default: at rest.
    min_settle_periods
        Periods to run before the first check.
    progress
        ``progress(simulated_s, at_most_s)`` after every ``check_every`` periods of settling.
    force_harmonics
        The periodic force instead of ``F0 sin``: a sequence of ``(k, A_k, phi_k)`` (k >= 1
        integer, peak amplitude A_k >= 0 in N, phase phi_k in rad, the convention of
        :mod:`rigtools.analysis.harmonics`) or a 1-D complex array ``c`` with ``c[k-1] = A_k exp(i phi_k)``;
        ``F0 sin`` is ``[(1, F0, -pi/2)]``. Each ``k`` must lie below half the steps per period.
        ``force_amplitude`` is then only recorded as the run's nominal amplitude (and sizes the
        step with the harmonics' sum). Default ``None``: ``F0 sin``, bit-identical to before.

    Returns
    -------
    VibroImpactRun

    Examples
    --------
    The default rig at 60 Hz and 15 N with a 0.5 mm gap: settled, one impact per period, its peak
    contact force in N:

    >>> import rigtools
    >>> from rigtools.sim.reduction import reduced_system
    >>> from rigtools.sim.vibro_impact import run_harmonic
    >>> system = reduced_system(rigtools.load_rig().to_params(), "fem")
    >>> run = run_harmonic(system.with_contact(gap=0.5e-3), 60.0, 15.0, record_periods=4)
    >>> run.steady_state, run.impacts_per_period, round(run.peak_contact_force, 1)
    (True, 1.0, 50.7)
    """
    validate_harmonic_input(fe, force_amplitude, system.contact.gap)
    validate_contact(system)
    record_periods = int(record_periods)
    if record_periods < 1:
        raise SimulationInputError("the record must hold at least one excitation period")
    harmonics = None if force_harmonics is None else periodic_force_terms(force_harmonics)
    # a Hertz contact stiffens with the force: size the step for a generous peak force
    peak = force_amplitude if harmonics is None else max(force_amplitude, float(np.sum(harmonics[:, 1])))
    force_scale = max(100.0, 10.0 * peak)
    n = (
        steps_per_period_for(system, fe, force_scale=force_scale)
        if steps_per_period is None
        else int(steps_per_period)
    )
    dt = 1.0 / (fe * n)
    stepper = VibroImpactStepper(system, dt, force_scale=force_scale)
    if initial is not None:
        stepper.state = initial.stepper.copy()
        phase0 = initial.phase
    else:
        phase0 = 0.0
    t_start = stepper.time
    ramp = _force_period(stepper, fe, force_amplitude, harmonics, phase0, n)
    max_periods = max(math.ceil(max_settle_time * fe), check_every)
    hist, out, periods_run = _settle(
        stepper, ramp, fe, tol, check_every, max_periods, min_settle_periods, record_periods, progress
    )
    settle_time = stepper.time - t_start
    rec_u = np.tile(ramp, record_periods)
    # samples at t = 0, dt, ..., (P n - 1) dt of the record, the force phase being phase0 at t = 0:
    # the last settling output, then the kernel's outputs written straight behind it
    buf = np.empty((rec_u.size + 1, N_OUT))
    buf[0] = out[-1] if periods_run else 0.0
    stepper.advance(rec_u, buf[1:])
    hist.append(buf[1:])
    tips = hist.view()
    final = check_periodic(tips, n, tol, scale=_pair_scale(tips, n))
    steady = final.steady  # the record itself must repeat (checked on its last periods)
    data = buf[:-1]
    t_rec = dt * np.arange(data.shape[0])
    outputs = {name: data[:, i] for i, name in enumerate(OUT_COLUMNS) if name != "coil_current"}
    return VibroImpactRun(
        fe=float(fe),
        force_amplitude=float(force_amplitude),
        gap=float(system.contact.gap),
        dt=dt,
        steps_per_period=n,
        record_periods=record_periods,
        time=t_rec,
        outputs=outputs,
        steady_state=bool(steady),
        period_multiple=final.period_multiple if steady else 0,
        mismatch=float(final.mismatch),
        settle_time=float(settle_time),
        contact_period=stepper.contact_period,
        final_state=RunState(stepper.state.copy(), phase0),
    )


def _settle(
    stepper: VibroImpactStepper,
    ramp: np.ndarray,
    fe: float,
    tol: float,
    check_every: int,
    max_periods: int,
    min_settle_periods: int,
    record_periods: int,
    progress: Callable[[float, float], None] | None,
) -> tuple[_TipHistory, np.ndarray, int]:
    """Run whole periods of the force ``ramp`` (one period of step-end samples at ``fe``), ``check_every``
    at a time, until the tips repeat to ``tol`` (:func:`rigtools.sim.steady_state.check_periodic`)
    or ``max_periods`` have run; ``(the tips' recent history, the last chunk's outputs, periods
    run)``."""
    n = ramp.size
    chunk = np.tile(ramp, check_every)
    keep = max(check_every, 3 + 4) * n  # enough periods for m <= 4 with 3 compared
    hist = _TipHistory(keep, chunk.size)
    out = np.empty((chunk.size, N_OUT))
    periods_run = 0
    while periods_run < max_periods:
        stepper.advance(chunk, out)
        periods_run += check_every
        if progress is not None:
            progress(periods_run / fe, (max_periods + record_periods) / fe)
        hist.append(out)
        if periods_run < min_settle_periods:
            continue
        tips = hist.view()
        if check_periodic(tips, n, tol, scale=_pair_scale(tips, n)).steady:
            break
    return hist, out, periods_run


def _force_period(
    stepper: VibroImpactStepper,
    fe: float,
    force_amplitude: float,
    harmonics: np.ndarray | None,
    phase0: float,
    n: int,
) -> np.ndarray:
    """One period of force samples at the step ends (``F0 sin``, or the periodic force of
    ``harmonics``) from the force phase ``phase0``; the stepper's carried force set to the force
    at ``phase0`` (the phase restarts each period)."""
    w = 2.0 * np.pi * fe
    dt = stepper.dt
    if harmonics is None:
        stepper.state.scalars[FORCE_SLOT] = force_amplitude * math.sin(phase0)
        return force_amplitude * np.sin(phase0 + w * dt * np.arange(1, n + 1))
    if np.any(harmonics[:, 0] >= n / 2):
        raise SimulationInputError(
            f"force harmonic k = {int(harmonics[:, 0].max())} needs more than {n} steps per period "
            f"(k < steps / 2)"
        )
    stepper.state.scalars[FORCE_SLOT] = float(periodic_force(harmonics, np.array([phase0]))[0])
    return periodic_force(harmonics, phase0 + w * dt * np.arange(1, n + 1))


def periodic_force_terms(force_harmonics) -> np.ndarray:
    """``(n, 3)`` array of ``(k, A_k, phi_k)`` from :func:`run_harmonic`'s ``force_harmonics``
    (tuples or complex coefficients); refuses a non-integer or non-positive ``k``, a negative
    or non-finite amplitude."""
    arr = np.asarray(force_harmonics)
    if np.iscomplexobj(arr):
        c = arr.ravel()
        terms = np.column_stack([np.arange(1, c.size + 1), np.abs(c), np.angle(c)])
    else:
        terms = np.asarray(arr, dtype=float).reshape(-1, 3) if arr.size else np.empty((0, 3))
    if terms.shape[0] == 0:
        raise SimulationInputError("force_harmonics holds no harmonic")
    k, a, _ph = terms.T
    if not (np.all(np.isfinite(terms)) and np.all(k >= 1) and np.all(k == np.round(k))):
        raise SimulationInputError("force harmonics need integer orders k >= 1 and finite values")
    if np.any(a < 0):
        raise SimulationInputError("force harmonic amplitudes must be >= 0 N")
    return terms


def periodic_force(terms: np.ndarray, phase: np.ndarray) -> np.ndarray:
    """``sum_k A_k cos(k phase + phi_k)`` of :func:`periodic_force_terms` at phases ``phase`` (rad)."""
    phase = np.asarray(phase, dtype=float)
    out = np.zeros_like(phase)
    for k, a, ph in terms:
        out += a * np.cos(k * phase + ph)
    return out
