"""The shooting map of a forced periodic orbit (:class:`PeriodMap`) and what it is evaluated at.

The orbit is the fixed point of the map over ``periods`` forcing periods of
:class:`rigtools.sim.vibro_impact.VibroImpactStepper` (the same compiled kernel as every time
integration in the toolkit). The state is taken at force phase zero: the modal displacements and
velocities of the reduced system (plus the coil current when a shaker drives it,
:class:`ShakerDrive`; under force control the drive amplitude too, corrected after the periods by
``F0 / |F1|``). Derivatives are forward finite differences of the map, relative perturbation
:data:`FD_RELATIVE_STEP` of the orbit's size; at a converged orbit they are the monodromy matrix
whose eigenvalues are the Floquet multipliers (:mod:`rigtools.sim.orbit_solver`); the state
columns are integrated in one compiled call (:meth:`PeriodMap.flows`, bit for bit the flows one
by one). The continuation built on this map is :mod:`rigtools.sim.continuation`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from rigtools.sim.contact import law, law_code
from rigtools.sim.contact_events import ContactStructure, contact_structure
from rigtools.sim.reduction import ReducedSystem
from rigtools.sim.vibro_impact import (
    OUT_COLUMNS,
    ShakerCoupling,
    SimulationInputError,
    StepperState,
    VibroImpactStepper,
    steps_per_period_for,
    validate_contact,
    validate_harmonic_input,
)

PARAMETERS = ("fe", "force", "gap")
UNITS = {"fe": "Hz", "force": "N", "gap": "m"}
FD_RELATIVE_STEP = 1e-6
N_HARMONICS = 10
STEPPERS_KEPT = 4  # steppers kept per map (PeriodMap._stepper_for)
# column of each output of the kernel (rigtools.sim.vibro_impact.OUT_COLUMNS) by name
COL = {name: i for i, name in enumerate(OUT_COLUMNS)}


class ContinuationError(SimulationInputError):
    """A branch could not be started (no periodic orbit found at its first parameter value)."""


@dataclass(frozen=True)
class Forcing:
    """The fixed quantities of a forced orbit (SI): frequency, force amplitude (with a shaker the
    force fundamental held or the drive amplitude, V, :class:`ShakerDrive`), gap."""

    fe: float
    force: float
    gap: float

    def value(self, param: str) -> float:
        return float(getattr(self, param))

    def with_value(self, param: str, value: float) -> Forcing:
        if param not in PARAMETERS:
            raise ValueError(f"parameter must be one of {PARAMETERS}, got {param!r}")
        return replace(self, **{param: float(value)})


@dataclass(frozen=True)
class ShakerDrive:
    """The simulated rig's model: the blades driven through the electrodynamic shaker.

    Attributes
    ----------
    coupling
        The shaker at the force point (armature and suspension added to the active blade, coil
        current a state, back-EMF), as the simulated rig integrates it.
    amplifier_gain
        Coil volts per drive volt (the power amplifier).
    force_control
        ``True``: the forcing amplitude is the force fundamental the drive is adjusted to (N), as
        the rig's procedures hold it, and the drive amplitude is solved with the orbit (one
        more unknown and equation: after the periods the drive is scaled by ``F0 / |F1|``).
        ``False``: the forcing amplitude is the drive amplitude (V).

    Notes
    -----
    Stability is the orbit's at a fixed drive (the rig holds the drive during a dwell and
    corrects it between measurements): the Floquet multipliers are those of the blades and the
    coil, never of the correction.
    """

    coupling: ShakerCoupling
    amplifier_gain: float = 1.0
    force_control: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.amplifier_gain) and self.amplifier_gain > 0):
            raise SimulationInputError(f"amplifier gain must be > 0, got {self.amplifier_gain!r}")


@dataclass(frozen=True)
class OrbitMeasures:
    """Response measures of one periodic orbit (SI, y direction).

    Attributes
    ----------
    accel_harmonics_active, accel_harmonics_passive
        (10,) peak acceleration of each shroud at ``k fe``, k = 1..10, m/s^2 (from the velocity,
        ``k w |V_k|``, as :data:`rigtools.simulation.HARMONIC_SOURCES` does).
    peak_contact_force
        Largest contact force over the orbit's time steps, N, as the time integrations report it
        (a damped penalty force peaks in a kink, so a parabola between samples overshoots; along
        a branch the value ripples by about 1 % as the steps move against the impact).
    peak_contact_force_per_period
        Largest contact force in each forcing period of the orbit, N.
    tip_amplitude_active, tip_amplitude_passive
        Half the peak-to-peak shroud displacement, m.
    impacts_per_period
        Contact onsets per forcing period.
    min_gap
        Smallest distance between the shrouds over the orbit, m (negative: they overlap in the
        penalty contact; zero: grazing).
    force_fundamental
        Fundamental amplitude of the force into the blade (the sensor's), N.
    drive_amplitude
        Drive amplitude (V) with a shaker (:class:`ShakerDrive`), 0 without.
    """

    accel_harmonics_active: np.ndarray
    accel_harmonics_passive: np.ndarray
    peak_contact_force: float
    peak_contact_force_per_period: tuple[float, ...]
    tip_amplitude_active: float
    tip_amplitude_passive: float
    impacts_per_period: float
    min_gap: float
    force_fundamental: float
    drive_amplitude: float = 0.0

    def as_dict(self) -> dict:
        return {
            "accel_harmonics_active": [float(a) for a in self.accel_harmonics_active],
            "accel_harmonics_passive": [float(a) for a in self.accel_harmonics_passive],
            "peak_contact_force": self.peak_contact_force,
            "peak_contact_force_per_period": list(self.peak_contact_force_per_period),
            "tip_amplitude_active": self.tip_amplitude_active,
            "tip_amplitude_passive": self.tip_amplitude_passive,
            "impacts_per_period": self.impacts_per_period,
            "min_gap": self.min_gap,
            "force_fundamental": self.force_fundamental,
            "drive_amplitude": self.drive_amplitude,
        }


class PeriodMap:
    """The state after ``periods`` forcing periods as a function of the state at force phase zero.

    Parameters
    ----------
    system
        Reduced system (its contact law and stiffness are used; the gap comes with the forcing).
    steps_per_period
        Time steps per forcing period, fixed along a branch so that the map is smooth in the
        frequency (``dt = 1 / (fe n)``).
    periods
        Forcing periods of the map.
    shaker
        With a shaker (:class:`ShakerDrive`) the coil current is part of the state; the forcing
        amplitude is the drive amplitude (V) or, under force control, the force fundamental (N),
        the drive amplitude then the state's last component.
    force_scale
        Force (N) at which a Hertz contact's tangent stiffness is taken for the step check.

    Notes
    -----
    The map works on the scaled state ``y = (omega q, v[, i[, a]])`` (all in velocity units but
    the coil current, A, and the drive, V), which keeps Newton and the arclength norm balanced
    between slow and fast modes.
    """

    def __init__(
        self,
        system: ReducedSystem,
        steps_per_period: int,
        periods: int = 1,
        shaker: ShakerDrive | None = None,
        force_scale: float = 100.0,
    ):
        validate_contact(system)
        self.base = system
        self.steps_per_period = int(steps_per_period)
        self.periods = int(periods)
        self.shaker = shaker
        self.force_scale = float(force_scale)
        coupling = shaker.coupling if shaker is not None else None
        self.system = (
            system
            if coupling is None
            else system.with_attached(coupling.armature_mass, coupling.suspension_stiffness)
        )
        n = self.system.n_modes
        self.n_modes = n
        # the physical state (modes, coil current) and, under force control, the drive amplitude
        self.n_physical = 2 * n + (1 if shaker is not None else 0)
        self.force_control = shaker is not None and shaker.force_control
        self.dim = self.n_physical + (1 if self.force_control else 0)
        self.scale = np.concatenate([self.system.omega, np.ones(n), np.ones(self.dim - 2 * n)])
        shapes = self.system.shapes
        self._d = shapes[0] - shapes[1]
        self._phi_f = shapes[2]
        c = system.contact
        self._law = (float(c.stiffness), float(c.damping), float(c.hertz_exponent), law_code(c))
        # the steppers of the last few (fe, gap): a point's own flows are interleaved with the
        # Jacobian's parameter column at a perturbed fe or gap (each stepper is the object it
        # was, so the results do not change)
        self._steppers: dict[tuple[float, float], VibroImpactStepper] = {}
        self._systems: dict[float, tuple[ReducedSystem, ReducedSystem | None]] = {}
        k = np.arange(1, self.steps_per_period * self.periods + 1)
        gain = shaker.amplifier_gain if shaker is not None else 1.0
        self._unit_drive = gain * np.sin(2.0 * np.pi * k / self.steps_per_period)
        self._out = np.empty((k.size, len(OUT_COLUMNS)))
        self.evaluations = 0

    def with_periods(self, periods: int) -> PeriodMap:
        return PeriodMap(self.base, self.steps_per_period, periods, self.shaker, self.force_scale)

    def with_steps(self, steps_per_period: int) -> PeriodMap:
        """The same map at another time step."""
        return PeriodMap(self.base, steps_per_period, self.periods, self.shaker, self.force_scale)

    def contact_structure(self, data: np.ndarray, p: Forcing) -> ContactStructure:
        """The contact-event structure of the orbit whose :meth:`flow` outputs are ``data``."""
        st = self._stepper_for(p)
        closure = data[:, COL["active_tip_displacement"]] - data[:, COL["passive_tip_displacement"]]
        return contact_structure(closure, data[:, COL["contact_force"]], p.gap, st.contact_period / st.dt)

    def _stepper_for(self, p: Forcing) -> VibroImpactStepper:
        key = (p.fe, p.gap)
        stepper = self._steppers.get(key)
        if stepper is None:
            validate_harmonic_input(p.fe, abs(p.force), p.gap)
            dt = 1.0 / (p.fe * self.steps_per_period)
            coupling = self.shaker.coupling if self.shaker is not None else None
            base, attached = self._systems_at(p.gap)
            stepper = VibroImpactStepper(base, dt, coupling, self.force_scale, attached=attached)
            if len(self._steppers) >= STEPPERS_KEPT:
                del self._steppers[next(iter(self._steppers))]  # the oldest
            self._steppers[key] = stepper
        return stepper

    def _systems_at(self, gap: float) -> tuple[ReducedSystem, ReducedSystem | None]:
        """The system at ``gap`` and, with a shaker, the one with the armature attached (once
        for the map: the attachment does not see the gap), kept for the last few gaps (a branch
        in fe or force has one gap, so the steppers at each new fe are built without them)."""
        systems = self._systems.get(gap)
        if systems is None:
            coupling = self.shaker.coupling if self.shaker is not None else None
            systems = (
                self.base.with_contact(gap=gap),
                None if coupling is None else self.system.with_contact(gap=gap),
            )
            if len(self._systems) >= STEPPERS_KEPT:
                del self._systems[next(iter(self._systems))]  # the oldest
            self._systems[gap] = systems
        return systems

    def carried_loads(self, x: np.ndarray, gap: float) -> np.ndarray:
        """The loads the kernel carries into the first step, from the state (force phase zero)."""
        n = self.n_modes
        q, v = x[:n], x[n : 2 * n]
        kc, cc, pexp, code = self._law
        fc = law(float(self._d @ q) - gap, float(self._d @ v), kc, cc, pexp, code)
        s = np.zeros(5)
        s[1] = fc
        if self.shaker is not None:
            coupling = self.shaker.coupling
            vf = float(self._phi_f @ v)
            s[2] = x[2 * n]
            s[4] = vf
            s[0] = coupling.force_factor * x[2 * n] - coupling.suspension_damping * vf
        return s

    def drive(self, y: np.ndarray, p: Forcing) -> float:
        """Drive amplitude (V) of the scaled state ``y`` at ``p`` (0 without a shaker)."""
        if self.shaker is None:
            return 0.0
        return float(y[-1] / self.scale[-1]) if self.force_control else float(p.force)

    def force_fundamental(self, data: np.ndarray) -> float:
        """Fundamental amplitude of the force into the blade over the outputs of one flow, N."""
        n_total = data.shape[0]
        return float(np.abs(np.fft.rfft(data[:, COL["excitation_force"]])[self.periods]) * 2.0 / n_total)

    def flow(self, y: np.ndarray, p: Forcing) -> tuple[np.ndarray, np.ndarray]:
        """``(y after the periods, outputs (steps, len(OUT_COLUMNS)))``; the outputs array is
        reused by the next call (copy it to keep it)."""
        st = self._stepper_for(p)
        x = np.asarray(y, dtype=float) / self.scale
        n = self.n_modes
        st.state = StepperState(x[:n].copy(), x[n : 2 * n].copy(), self.carried_loads(x, p.gap), 0.0)
        a = x[-1] if self.force_control else p.force
        st.advance(a * self._unit_drive, self._out)  # step() without its time array
        self.evaluations += 1
        end = [st.state.q, st.state.v]
        if self.shaker is not None:
            end.append(st.state.scalars[2:3])
        if self.force_control:
            # the drive corrected towards the force: a fixed point holds |F1| = F0
            f1 = self.force_fundamental(self._out)
            if not f1 > 0:
                raise SimulationInputError("no force into the blade: the drive amplitude is zero")
            end.append(np.array([a * p.force / f1]))
        return np.concatenate(end) * self.scale, self._out

    def flows(self, ys: np.ndarray, p: Forcing) -> np.ndarray:
        """``Phi`` of each row of ``ys`` (``(m, dim)`` scaled states) at ``p``: the rows of the
        result are :meth:`flow`'s end states, computed in one compiled call with the same
        arithmetic per row, so the same bits (the outputs are not kept)."""
        st = self._stepper_for(p)
        n = self.n_modes
        m = ys.shape[0]
        xs = np.asarray(ys, dtype=float) / self.scale
        q = np.ascontiguousarray(xs[:, :n])
        v = np.ascontiguousarray(xs[:, n : 2 * n])
        scalars = np.empty((m, 5))
        for r in range(m):
            scalars[r] = self.carried_loads(xs[r].copy(), p.gap)
        if self.force_control:
            a = xs[:, -1]
            u = a[:, None] * self._unit_drive
            excitation = np.empty((m, self._unit_drive.size))
        else:
            u = (p.force * self._unit_drive)[None, :]
            excitation = np.empty((0, self._unit_drive.size))
        st.advance_rows(q, v, scalars, u, excitation)
        self.evaluations += m
        end = [q, v]
        if self.shaker is not None:
            end.append(scalars[:, 2:3])
        if self.force_control:
            # force_fundamental of each row (numpy's FFT of each row is its 1-D FFT, the same bits)
            n_total = excitation.shape[1]
            f1 = np.abs(np.fft.rfft(excitation, axis=1)[:, self.periods]) * 2.0 / n_total
            if not np.all(f1 > 0):
                raise SimulationInputError("no force into the blade: the drive amplitude is zero")
            end.append((a * p.force / f1)[:, None])
        return np.concatenate(end, axis=1) * self.scale

    def jacobian(
        self,
        y: np.ndarray,
        p: Forcing,
        param: str | None = None,
        fy: np.ndarray | None = None,
        batched: bool = True,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """``(Phi(y), dPhi/dy, dPhi/dparam)`` by forward differences (``param`` None: no
        parameter column). ``fy``: ``Phi(y)`` if already known.

        ``batched``: the state columns' flows in one compiled call (:meth:`flows`); ``False``
        (or a subclass redefining :meth:`flow`): one :meth:`flow` per column, the reference the
        batched path equals bit for bit
        (``tests/sim/test_orbit_map_batched.py``, ``benchmarks/bench_continuation_speed.py``).
        """
        y = np.asarray(y, dtype=float)
        f0 = self.flow(y, p)[0] if fy is None else fy
        size = max(float(np.linalg.norm(y)) / math.sqrt(y.size), 1e-300)
        jac = np.empty((y.size, y.size))
        steps = np.empty(y.size)
        perturbed = np.repeat(y[None, :], y.size, axis=0)
        for j in range(y.size):
            steps[j] = FD_RELATIVE_STEP * max(abs(y[j]), size)
            perturbed[j, j] += steps[j]
        # a map that redefines flow (a stand-in in a test) is differenced through its own flow
        if batched and type(self).flow is PeriodMap.flow:
            jac[:] = ((self.flows(perturbed, p) - f0) / steps[:, None]).T
        else:
            for j in range(y.size):
                jac[:, j] = (self.flow(perturbed[j], p)[0] - f0) / steps[j]
        dpar = None
        if param is not None:
            lam = p.value(param)
            h = FD_RELATIVE_STEP * max(abs(lam), _PARAM_FLOOR[param])
            dpar = (self.flow(y, p.with_value(param, lam + h))[0] - f0) / h
        return f0, jac, dpar

    def linear_orbit(self, p: Forcing) -> np.ndarray:
        """Scaled state of the steady response without contact (force ``F0 sin``, or drive
        ``a sin`` through the shaker, phase zero)."""
        s = self.system
        w = 2.0 * np.pi * p.fe
        den = s.omega**2 - w**2 + 2j * s.zeta * s.omega * w
        if self.shaker is None:
            # q_j = Im(a_j exp(i w t)), a_j = phi_F,j F0 / (w_j^2 - w^2 + 2 i zeta_j w_j w)
            a = self._phi_f * p.force / den
            return np.concatenate([a.imag, (1j * w * a).imag]) * self.scale
        # the coupled harmonic balance: D Q = phi_F (Bl I - c_s i w X_F), X_F = phi_F . Q,
        # (R + i w L) I + Bl i w X_F = G a, with a unit drive first
        c = self.shaker.coupling
        h = np.sum(self._phi_f**2 / den)
        coil = (
            c.coil_resistance
            + 1j * w * c.coil_inductance
            + 1j * w * c.force_factor**2 * h / (1.0 + 1j * w * c.suspension_damping * h)
        )
        current = self.shaker.amplifier_gain / coil
        x_f = h * c.force_factor * current / (1.0 + 1j * w * c.suspension_damping * h)
        load = c.force_factor * current - 1j * w * c.suspension_damping * x_f
        sensor = load + (c.armature_mass * w**2 - c.suspension_stiffness) * x_f
        drive = p.force / abs(sensor) if self.force_control else p.force
        q = self._phi_f * load / den * drive
        x = [q.imag, (1j * w * q).imag, [(current * drive).imag]]
        if self.force_control:
            x.append([drive])
        return np.concatenate(x) * self.scale

    def measures(self, data: np.ndarray, p: Forcing, drive: float = 0.0) -> OrbitMeasures:
        """:class:`OrbitMeasures` of the outputs of one :meth:`flow` over the orbit (``drive``:
        its drive amplitude, V, :meth:`drive`)."""
        n_total = data.shape[0]
        per = self.periods
        w = 2.0 * np.pi * p.fe
        k = np.arange(1, N_HARMONICS + 1)

        def accel(col: str) -> np.ndarray:
            spec = np.fft.rfft(data[:, COL[col]]) * 2.0 / n_total
            return k * w * np.abs(spec[k * per])

        fc = data[:, COL["contact_force"]]
        closed = fc > 0
        onsets = int(np.count_nonzero(closed & ~np.roll(closed, 1)))
        closure = data[:, COL["active_tip_displacement"]] - data[:, COL["passive_tip_displacement"]]
        force = np.fft.rfft(data[:, COL["excitation_force"]]) * 2.0 / n_total
        xa = data[:, COL["active_tip_displacement"]]
        xp = data[:, COL["passive_tip_displacement"]]
        return OrbitMeasures(
            accel_harmonics_active=accel("active_tip_velocity"),
            accel_harmonics_passive=accel("passive_tip_velocity"),
            peak_contact_force=float(fc.max()),
            peak_contact_force_per_period=tuple(float(c.max()) for c in np.split(fc, per)),
            tip_amplitude_active=0.5 * float(np.ptp(xa)),
            tip_amplitude_passive=0.5 * float(np.ptp(xp)),
            impacts_per_period=onsets / per,
            min_gap=p.gap - _periodic_max(closure),
            force_fundamental=float(np.abs(force[per])),
            drive_amplitude=float(drive),
        )


_PARAM_FLOOR = {"fe": 1.0, "force": 1e-3, "gap": 1e-6}


def _periodic_max(x: np.ndarray) -> float:
    """Maximum of a periodic sampled signal, refined by the parabola through the largest sample
    and its neighbours."""
    i = int(np.argmax(x))
    a, b, c = x[i - 1], x[i], x[(i + 1) % x.size]
    den = a - 2.0 * b + c
    if den >= 0:
        return float(b)
    return float(b - 0.125 * (c - a) ** 2 / den)


def map_for_range(
    system: ReducedSystem,
    param: str,
    start: float,
    stop: float,
    fe: float,
    force: float,
    gap: float,
    periods: int,
    shaker: ShakerDrive | None,
    steps_per_period: int | None,
) -> tuple[PeriodMap, Forcing]:
    """The map a branch over ``param`` from ``start`` to ``stop`` is traced on (its time step
    held over the range: ``steps_per_period``, or the steps the range's lowest frequency and
    largest force need) and the forcing at ``start``; one-line errors for a bad range."""
    if param not in PARAMETERS:
        raise SimulationInputError(
            f"the continued parameter must be one of {', '.join(PARAMETERS)}, got {param!r}"
        )
    if not (math.isfinite(start) and math.isfinite(stop)) or start == stop:
        raise SimulationInputError(
            f"the {param} range needs two different finite values, got {start:g} and {stop:g}"
        )
    forcing = Forcing(fe, force, gap).with_value(param, start)
    for value in (start, stop):
        f = forcing.with_value(param, value)
        validate_harmonic_input(f.fe, abs(f.force), f.gap)
    # n ~ 1 / fe keeps the time step: the lowest frequency needs the most steps per period
    fe_min = min(start, stop) if param == "fe" else fe
    force_max = max(abs(start), abs(stop)) if param == "force" else abs(force)
    # the contact scale from the force (a drive in volts says nothing of it: 100 N)
    force_scale = 100.0 if shaker is not None and not shaker.force_control else max(100.0, 10.0 * force_max)
    n = steps_per_period or steps_per_period_for(system, fe_min, force_scale=force_scale)
    return PeriodMap(system, n, periods, shaker, force_scale=force_scale), forcing
