"""What a harmonic run takes before it starts: its inputs checked
(:func:`validate_harmonic_input`), its steps per period (:func:`steps_per_period_for`) and its
cost (:func:`estimate_steps`, :class:`CostEstimate`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rigtools.sim.contact import contact_period
from rigtools.sim.impact_stepper import effective_contact_damping, validate_contact
from rigtools.sim.params import SimulationInputError
from rigtools.sim.reduction import ReducedSystem

DEFAULT_STEPS_PER_CONTACT = 30  # halving the step then moves harmonics k <= 10 by < 0.2 %


def steps_per_period_for(
    system: ReducedSystem,
    fe: float,
    steps_per_contact: int = DEFAULT_STEPS_PER_CONTACT,
    force_scale: float = 100.0,
    k_max: int = 30,
) -> int:
    """Integer steps per excitation period giving at least ``steps_per_contact`` steps per
    contact period, ``c dt / m_eff <= 1`` for the contact damping ``c`` and a sample rate of at
    least ``4 * k_max * fe``."""
    tc = contact_period(system.contact_effective_mass(), system.contact, force_scale)
    n = math.ceil(steps_per_contact / (fe * tc) - 1e-9)
    # and c dt / m_eff <= 1 for the contact damping (half the limit of check_time_step)
    c = effective_contact_damping(system.contact, force_scale)
    n_c = math.ceil(c / (fe * system.contact_effective_mass()) - 1e-9) if c > 0 else 0
    return max(n, n_c, 4 * k_max)


def validate_harmonic_input(fe: float, force_amplitude: float, gap: float | None = None) -> None:
    """One-line refusal of a non-positive frequency, a negative force or gap."""
    if not (fe > 0 and math.isfinite(fe)):
        raise SimulationInputError(f"excitation frequency must be > 0 Hz, got {fe:g} Hz")
    if not (force_amplitude >= 0 and math.isfinite(force_amplitude)):
        raise SimulationInputError(f"force amplitude must be >= 0 N, got {force_amplitude:g} N")
    if gap is not None and not gap >= 0:
        raise SimulationInputError(f"gap must be >= 0, got {gap * 1e3:g} mm")


# Rough speed of the compiled kernel on the reference machine (2 shared cores, 2026): about
# 25-55 ns per step and mode, settling checks included (kc = 1e6, 1e8, 1e10 N/m on the default
# rig). Only for telling a user "this will take minutes"; never used for decisions.
SECONDS_PER_MODE_STEP = 30e-9


@dataclass(frozen=True)
class CostEstimate:
    """What a harmonic run will cost (:func:`estimate_steps`)."""

    steps_per_period: int
    limited_by: str  # "contact stiffness", "contact damping" or "harmonics"
    time_step: float  # s
    settle_periods: int  # estimated periods to settle (modal-damping decay to ``tol``)
    record_periods: int
    total_steps: int  # (settle + record) * steps_per_period
    mode_steps: int  # total_steps * n_modes: the kernel's work
    seconds: float  # rough wall time at SECONDS_PER_MODE_STEP
    worst_case_steps: int  # if the run never settles: max_settle_time, then the record
    worst_case_seconds: float

    def describe(self) -> str:
        """One line for a user, e.g. ``'~7.5e+07 steps (3.27e+05 per period, set by the contact
        stiffness), about 32 s (up to 4.6e+02 s if it does not settle)'``."""
        return (
            f"~{self.total_steps:.2g} steps ({self.steps_per_period:.3g} per period, set by the "
            f"{self.limited_by}), about {self.seconds:.2g} s (up to {self.worst_case_seconds:.2g} s "
            f"if it does not settle)"
        )


def estimate_steps(
    system: ReducedSystem,
    fe: float,
    force_amplitude: float = 0.0,
    *,
    record_periods: int = 20,
    steps_per_period: int | None = None,
    tol: float = 1e-5,
    max_settle_time: float = 30.0,
    check_every: int = 5,
) -> CostEstimate:
    """Cheap up-front estimate of a :func:`rigtools.sim.vibro_impact.run_harmonic` call (no integration).

    Steps per period as :func:`rigtools.sim.vibro_impact.run_harmonic` chooses them; settling time from the slowest
    decaying flexural mode, ``ln(1 / tol) / min(zeta_j w_j)`` (an upper bound in practice: the
    contact damping only speeds settling; measured on the default rig at 60 Hz: 3.1-4.3 s against
    3.4 s estimated), capped at ``max_settle_time``, rounded up to ``check_every`` periods. A
    run that never settles (a nearly elastic contact, e.g. 1e12 N/m with 200 N*s/m: 4e-4 of
    critical) runs for ``max_settle_time``: ``worst_case_steps``.
    Arguments as :func:`rigtools.sim.vibro_impact.run_harmonic`. Raises :class:`SimulationInputError` for invalid input.
    """
    validate_harmonic_input(fe, force_amplitude, system.contact.gap)
    validate_contact(system)
    force_scale = max(100.0, 10.0 * force_amplitude)
    auto = steps_per_period_for(system, fe, force_scale=force_scale)
    n = auto if steps_per_period is None else int(steps_per_period)
    if steps_per_period is None:
        tc = contact_period(system.contact_effective_mass(), system.contact, force_scale)
        n_k = math.ceil(DEFAULT_STEPS_PER_CONTACT / (fe * tc) - 1e-9)
        c = effective_contact_damping(system.contact, force_scale)
        n_c = math.ceil(c / (fe * system.contact_effective_mass()) - 1e-9) if c > 0 else 0
        limited = (
            "harmonics"
            if n == 4 * 30 and n > max(n_k, n_c)
            else "contact damping"
            if n_c > n_k
            else "contact stiffness"
        )
    else:
        limited = "given steps per period"
    real = np.ones(system.n_modes, bool) if system.pseudo is None else ~np.asarray(system.pseudo, bool)
    decay = float(np.min((system.zeta * system.omega)[real])) if real.any() else math.inf
    t_settle = math.log(1.0 / tol) / decay if decay > 0 else math.inf
    t_settle = min(t_settle, max_settle_time)
    periods = max(check_every, math.ceil(t_settle * fe / check_every) * check_every)
    total = (periods + int(record_periods)) * n
    mode_steps = total * system.n_modes
    max_periods = max(math.ceil(max_settle_time * fe), check_every)
    worst = (math.ceil(max_periods / check_every) * check_every + int(record_periods)) * n
    return CostEstimate(
        steps_per_period=n,
        limited_by=limited,
        time_step=1.0 / (fe * n),
        settle_periods=periods,
        record_periods=int(record_periods),
        total_steps=total,
        mode_steps=mode_steps,
        seconds=mode_steps * SECONDS_PER_MODE_STEP,
        worst_case_steps=worst,
        worst_case_seconds=worst * system.n_modes * SECONDS_PER_MODE_STEP,
    )
