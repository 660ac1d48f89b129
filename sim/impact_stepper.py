"""Block-wise stepping of a :class:`rigtools.sim.reduction.ReducedSystem` with carried state
(:class:`VibroImpactStepper`), the shaker coupling, the time-step checks and the divergence message.

Time convention: ``step(u)`` takes the input at the END of each step (``u[i]`` at
``t0 + (i+1)*dt``, the input at ``t0`` being carried from the previous call) and returns the
outputs at the same instants. The compiled loop is :mod:`rigtools.sim.impact_kernel`; settled
harmonic runs are :mod:`rigtools.sim.vibro_impact`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from rigtools.sim.contact import contact_period, kernel_contact
from rigtools.sim.impact_kernel import (
    DIVERGED_DISPLACEMENT,
    N_OUT,
    OUT_COLUMNS,
    _kernel,
    _kernel_columns,
    _props,
)
from rigtools.sim.params import ContactParams, SimulationInputError
from rigtools.sim.reduction import ReducedSystem
from rigtools.sim.shaker_params import ShakerCoupling

MIN_STEPS_PER_CONTACT = 20
# contact damping c over the step: c dt / m_eff above 2 makes the end-of-step damping force
# overshoot and the run diverge (1e4 N*s/m at the default 50 us step: 8.5, no steady state;
# 1e5: 1e227 N); at <= 2 the contact-force harmonics agree with a 4x finer step to 0.01 %
MAX_CONTACT_DAMPING_STEP = 2.0
# scalar state slots (StepperState.scalars): last load at the force point, last contact force,
# coil current, last coil voltage, last force-point velocity
FORCE_SLOT, CONTACT_SLOT, CURRENT_SLOT, VOLTAGE_SLOT, VELOCITY_SLOT = range(5)


class SimulationDivergedError(SimulationInputError):
    """The integration produced a non-finite or absurd value; the message names the likely
    parameters."""


@dataclass
class StepOutput:
    """Outputs of :meth:`VibroImpactStepper.step`, one value per step (y direction, SI)."""

    time: np.ndarray
    data: np.ndarray = field(repr=False)  # (n_steps, N_OUT) in OUT_COLUMNS order

    def __getattr__(self, name: str) -> np.ndarray:
        # only called for names that are not attributes; during copy/unpickling ``data`` is not
        # set yet and lookups such as ``__setstate__`` must end in AttributeError
        if name in OUT_COLUMNS:
            return self.data[:, OUT_COLUMNS.index(name)]
        raise AttributeError(name)

    def as_dict(self) -> dict[str, np.ndarray]:
        return {name: self.data[:, i] for i, name in enumerate(OUT_COLUMNS)}


@dataclass
class StepperState:
    """Carried state: modal coordinates, their rates, the last loads, coil current, time."""

    q: np.ndarray
    v: np.ndarray
    scalars: np.ndarray  # see the *_SLOT indices
    time: float = 0.0

    def copy(self) -> StepperState:
        return StepperState(self.q.copy(), self.v.copy(), self.scalars.copy(), self.time)


def _coil_coefficients(shaker: ShakerCoupling, dt: float) -> tuple[float, float, float]:
    """Exact FOH step of ``L di/dt + R i = w(t)``: ``i1 = e i0 + c0 w0 + c1 w1``."""
    r, ind = shaker.coil_resistance, shaker.coil_inductance
    if ind <= 0.0:
        return 0.0, 0.0, 1.0 / r
    x = r * dt / ind
    e = math.exp(-x)
    # integral of exp(-R(h-s)/L)/L * (w0 (1 - s/h) + w1 s/h) ds
    if x < 1e-6:
        c1 = dt / (2 * ind)
        c0 = dt / (2 * ind)
    else:
        one_minus = -math.expm1(-x)
        c1 = (1.0 / r) * (1.0 - one_minus / x)
        c0 = (1.0 / r) * (one_minus / x - e)
    return e, c0, c1


def effective_contact_damping(contact, force_scale: float = 100.0) -> float:
    """Damping coefficient of the contact, N*s/m: ``c_c`` for the linear and Hertz laws; for
    Hunt-Crossley ``c_c g^p`` at the penetration carrying ``force_scale`` newtons."""
    if contact.law == "hunt-crossley":
        return contact.damping * force_scale / contact.stiffness
    return contact.damping


class HasContact(Protocol):
    """What :func:`check_time_step` reads of a system: the contact and the mass it moves."""

    @property
    def contact(self) -> ContactParams: ...

    def contact_effective_mass(self) -> float: ...


def check_time_step(
    system: HasContact, dt: float, force_scale: float = 100.0, min_steps: int = MIN_STEPS_PER_CONTACT
) -> float:
    """Refuse a step that does not resolve the contact period with ``min_steps`` steps, or
    whose contact damping force would overshoot (``c dt / m_eff > 2``).

    Returns the contact period (s). ``force_scale`` (N) sets the tangent stiffness of a Hertz
    contact. Raises :class:`SimulationInputError` with one line otherwise, or for an invalid
    contact (:func:`validate_contact`).
    """
    if not (dt > 0 and math.isfinite(dt)):
        raise SimulationInputError(f"time step must be > 0, got {dt}")
    validate_contact(system)  # before the contact period, which needs a positive stiffness
    meff = system.contact_effective_mass()
    tc = contact_period(meff, system.contact, force_scale)
    if dt > tc / min_steps:
        raise SimulationInputError(
            f"time step {dt * 1e6:.3g} us is too coarse for the contact stiffness "
            f"{system.contact.stiffness:.3g}: the contact period {tc * 1e3:.3g} ms needs "
            f"dt <= {tc / min_steps * 1e6:.3g} us ({min_steps} steps per contact period)"
        )
    c = effective_contact_damping(system.contact, force_scale)
    if c * dt > MAX_CONTACT_DAMPING_STEP * meff:
        raise SimulationInputError(
            f"time step {dt * 1e6:.3g} us is too coarse for the contact damping {c:.3g} N*s/m "
            f"({c / (2 * math.sqrt(system.contact.stiffness * meff)):.3g} of critical on "
            f"{meff * 1e3:.3g} g): it needs dt <= {MAX_CONTACT_DAMPING_STEP * meff / c * 1e6:.3g} us "
            f"(c dt / m <= {MAX_CONTACT_DAMPING_STEP:g}); lower the contact damping or the step"
        )
    return tc


class VibroImpactStepper:
    """Block-wise stepping of the reduced two-blade system with carried state.

    Parameters
    ----------
    system
        The reduced system (from :func:`rigtools.sim.reduction.reduce_rig_model` or
        :func:`rigtools.sim.reduction.reduce_assumed_modes`).
    dt
        Time step, s. Must resolve the contact period with at least 20 steps.
    shaker
        If given, the input of :meth:`step` is the coil voltage (V) and the armature mass and
        suspension are added at the force point; otherwise the input is the force (N).
    force_scale
        Force (N) at which a Hertz contact's tangent stiffness is taken for the step check.
    attached
        With ``shaker``: ``system`` with the armature already attached
        (:meth:`rigtools.sim.reduction.ReducedSystem.with_attached`), if the caller holds it (a
        periodic-orbit map builds a stepper per fe and gap, the attachment's eigen-solve once).
    """

    def __init__(
        self,
        system: ReducedSystem,
        dt: float,
        shaker: ShakerCoupling | None = None,
        force_scale: float = 100.0,
        attached: ReducedSystem | None = None,
    ):
        self.contact_period = check_time_step(system, dt, force_scale)
        if shaker is not None:
            system = (
                attached
                if attached is not None
                else system.with_attached(shaker.armature_mass, shaker.suspension_stiffness)
            )
        self.system = system
        self.dt = float(dt)
        self.shaker = shaker
        self._P = np.empty((8, system.n_modes))
        _props(system.omega, system.zeta, self.dt, self._P)
        self.events = True
        self._phi = [np.ascontiguousarray(system.shapes[i]) for i in range(3)]
        self._contact = kernel_contact(system.contact)
        if shaker is None:
            self._shaker = np.zeros(8)
        else:
            e, c0, c1 = _coil_coefficients(shaker, self.dt)
            self._shaker = np.array(
                [
                    1.0,
                    shaker.force_factor,
                    e,
                    c0,
                    c1,
                    shaker.suspension_damping,
                    shaker.armature_mass,
                    shaker.suspension_stiffness,
                ]
            )
        self.state = StepperState(np.zeros(system.n_modes), np.zeros(system.n_modes), np.zeros(5))

    def reset(self) -> None:
        """Back to rest at t = 0."""
        self.state = StepperState(np.zeros(self.system.n_modes), np.zeros(self.system.n_modes), np.zeros(5))

    @property
    def time(self) -> float:
        return self.state.time

    def step(self, u: np.ndarray, out: np.ndarray | None = None) -> StepOutput:
        """Advance ``len(u)`` steps.

        Parameters
        ----------
        u
            Input at the end of each step: force at the force point (N), or coil voltage (V)
            with a shaker.
        out
            Optional preallocated ``(len(u), N_OUT)`` array to write into.

        Returns
        -------
        StepOutput
            Time and outputs at the end of each step.
        """
        u = np.ascontiguousarray(u, dtype=float).ravel()
        if out is None:
            out = np.empty((u.size, N_OUT))
        t0 = self.state.time
        self.advance(u, out)
        return StepOutput(t0 + self.dt * np.arange(1, u.size + 1), out)

    def advance(self, u: np.ndarray, out: np.ndarray) -> None:
        """:meth:`step` without the time array: ``u`` a contiguous float array, ``out`` a
        ``(len(u), N_OUT)`` array written in place. Allocates nothing per step.

        Raises
        ------
        SimulationInputError
            A non-finite input.
        SimulationDivergedError
            A non-finite or absurd output (the message names the likely parameters).
        """
        st = self.state
        gap, kc, cc, p, code = self._contact
        if not np.isfinite(u).all():
            raise SimulationInputError(
                f"the input ({'coil voltage' if self.shaker else 'force'}) holds a non-finite value"
            )
        bad = _kernel(
            self._P,
            self.system.omega,
            self.system.zeta,
            self._phi[0],
            self._phi[1],
            self._phi[2],
            st.q,
            st.v,
            st.scalars,
            u,
            out,
            self.dt,
            gap,
            kc,
            cc,
            p,
            code,
            self._shaker,
            self.events,
        )
        if bad >= 0:
            self._diverged(st.time + self.dt * (bad + 1))
        st.time = st.time + self.dt * u.size

    def advance_rows(
        self, q: np.ndarray, v: np.ndarray, scalars: np.ndarray, u: np.ndarray, excitation: np.ndarray
    ) -> None:
        """:meth:`advance` from each row of ``q, v, scalars`` (carried states at time zero,
        C-contiguous ``(m, n_modes)``, ``(m, n_modes)``, ``(m, 5)``, overwritten with the end
        states) in one compiled call, the same arithmetic per row as :meth:`advance` (the same
        bits). The carried ``state`` is not used or changed.

        Parameters
        ----------
        u
            ``(m, steps)`` input of each row, or ``(1, steps)`` shared by all (C-contiguous).
        excitation
            ``(m, steps)``: written with each row's excitation-force output (the only output
            kept); ``(0, steps)``: no output kept.

        Raises
        ------
        SimulationInputError, SimulationDivergedError
            As :meth:`advance` would for the first row that fails, rows taken in order.
        """
        gap, kc, cc, p, code = self._contact
        finite = np.isfinite(u).all(axis=1)
        # the rows before the first non-finite input are integrated (a divergence among them is
        # reported first, as one advance per row reports it)
        stop = q.shape[0] if finite.all() else (int(np.argmin(finite)) if u.shape[0] > 1 else 0)
        out = np.empty((u.shape[1], N_OUT))
        row, bad = _kernel_columns(
            self._P,
            self.system.omega,
            self.system.zeta,
            self._phi[0],
            self._phi[1],
            self._phi[2],
            q[:stop],
            v[:stop],
            scalars[:stop],
            u,
            out,
            excitation[:stop] if excitation.shape[0] else excitation,
            self.dt,
            gap,
            kc,
            cc,
            p,
            code,
            self._shaker,
            self.events,
        )
        if row >= 0:
            self._diverged(0.0 + self.dt * (bad + 1))
        if stop < q.shape[0]:
            raise SimulationInputError(
                f"the input ({'coil voltage' if self.shaker else 'force'}) holds a non-finite value"
            )

    def _diverged(self, time: float) -> None:
        """Raise :class:`SimulationDivergedError` for a divergence at ``time``."""
        gap, kc, cc, _, _ = self._contact
        # the values the kernel ran with (the same as system.contact unless overridden)
        ran = _ContactSystem(self.system, replace(self.system.contact, gap=gap, stiffness=kc, damping=cc))
        raise SimulationDivergedError(diverged_message(ran, self.dt, time))


class _ContactSystem:
    """A system seen with other contact values (for :func:`diverged_message`)."""

    def __init__(self, system, contact):
        self._system = system
        self.contact = contact
        self.zeta = getattr(system, "zeta", np.zeros(1))

    def contact_effective_mass(self) -> float:
        return self._system.contact_effective_mass()


def diverged_message(system, dt: float, time: float) -> str:
    """One line naming the parameters that most likely made a run diverge at ``time``."""
    c = system.contact
    meff = system.contact_effective_mass()
    zeta_c = effective_contact_damping(c) / (2 * math.sqrt(c.stiffness * meff))
    suspects = []
    if zeta_c > 1:
        suspects.append(f"contact damping {c.damping:.3g} ({zeta_c:.3g} of critical)")
    zeta = getattr(system, "zeta", np.zeros(1))
    if np.max(zeta) > 10:
        suspects.append(f"modal damping (ratio up to {np.max(zeta):.3g}: Rayleigh alpha/beta?)")
    suspects.append(f"contact stiffness {c.stiffness:.3g} N/m and time step {dt * 1e6:.3g} us")
    return (
        f"the simulation diverged (non-finite or > {DIVERGED_DISPLACEMENT:g} m displacement) at "
        f"t = {time:.6g} s; likely cause: {'; '.join(suspects)}"
    )


def validate_contact(system: HasContact) -> None:
    """Refuse a negative gap or a non-positive stiffness / negative damping with one line."""
    c = system.contact
    if not c.gap >= 0:
        raise SimulationInputError(f"gap must be >= 0, got {c.gap * 1e3:g} mm")
    if not c.stiffness > 0:
        raise SimulationInputError(f"contact stiffness must be > 0, got {c.stiffness:g} N/m")
    if not c.damping >= 0:
        raise SimulationInputError(f"contact damping must be >= 0, got {c.damping:g} N s/m")
