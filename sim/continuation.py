"""Periodic orbits of the reduced vibro-impact model: shooting, pseudo-arclength continuation,
Floquet stability and bifurcations (as NLvib's shooting and COCO's ``po`` toolbox do it).

The orbit is the fixed point of the map over ``periods`` forcing periods of
:class:`rigtools.sim.vibro_impact.VibroImpactStepper` (the same compiled kernel as every time
integration in the toolkit, so a branch and a settled run differ only by how they find the orbit).
The state is taken at force phase zero: the modal displacements and velocities of the reduced
system (plus the coil current when a shaker drives it, :class:`ShakerDrive`; under force control
the drive amplitude too, corrected after the periods by ``F0 / |F1|`` so that a fixed point holds
the force fundamental as the rig's procedures do). The contact force and the other loads the
kernel carries from step to step are functions of that state (the penalty force is consistent
with the closure at each step end), so the map depends on ``(q, v)`` alone and is smooth except
where an impact moves across a step boundary, a change of the order of the time step's own error.

Derivatives are forward finite differences of the map (one integration per state component and
one for the parameter), relative perturbation :data:`FD_RELATIVE_STEP` of the orbit's size. They
serve the Newton corrector and, at each converged point, are the monodromy matrix whose
eigenvalues are the Floquet multipliers. Measured accuracy (tests/sim/test_continuation.py): the
multipliers of the linear response agree with ``exp(lambda T)`` of each mode to 1e-6, those of a
one-mode impact oscillator with the exact piecewise-linear solution to 1e-4.

Continuation is pseudo-arclength in the scaled vector ``(y / Y, lambda / L)`` (``y`` the state with
displacements times their mode's frequency, ``Y`` its size at the start, ``L`` the parameter range):
a tangent predictor, a chord-Newton corrector on the arclength plane (the previous point's
Jacobian, refreshed when it converges slowly), step control on the iteration count. Between
consecutive points the labels follow their definitions (:mod:`rigtools.sim.bifurcations`):

* a non-smooth event where the orbit's contact-event structure changes
  (:mod:`rigtools.sim.contact_events`: grazing, contact-split, sticking), bracketed by bisection;
  the monodromy matrix jumps there, so no smooth test is taken across it;
* on one structure: period doubling where a real multiplier crosses -1 (``det(M + I)`` changes
  sign), Neimark-Sacker where a complex pair crosses the unit circle, fold where the tangent's
  parameter component changes sign, each kept only where the located orbit's critical
  multiplier is at -1, on the circle or at +1;
* every turning of the branch in the parameter is a fold (at a grazing hairpin too).

Each bifurcation is then relocated with the steps per period doubled until it moves by less than
``ContinuationSettings.refine_tolerance`` (:mod:`rigtools.sim.bifurcation_refine`; ``Branch.bifurcations``).
Smooth ones are located by regula falsi along the arclength and inserted as labelled points. Where an
impact grazes the map has a kink, and the branch may turn there sharply: past a grazing where
impacts begin or end (``_Tracer.cross_grazing_corner``), or at a hairpin where a sheet with
one more impact meets one without it (``_Tracer.turn_at_hairpin``: labelled fold and
grazing). At a period doubling, :func:`switch_period_doubling` starts the period-2 branch (the map
over two periods has a pitchfork there; its new direction is the -1 eigenvector); a switched
branch is followed out of the range and back (``_followed_range``). A point that does not
converge is reported (``Branch.status``, ``Branch.message``) and the branch ends at the last good
point.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from rigtools.sim import bifurcations as bif
from rigtools.sim.bifurcation_refine import MAX_REFINEMENTS, REFINE_TOLERANCE, refine
from rigtools.sim.bifurcations import FOLD, NEIMARK_SACKER, PERIOD_DOUBLING, SMOOTH, Bifurcation
from rigtools.sim.contact import law, law_code
from rigtools.sim.contact_events import (
    CONTACT_SPLIT,
    GRAZING,
    STICKING,
    ContactStructure,
    contact_structure,
    event_kind,
)
from rigtools.sim.reduction import ReducedSystem
from rigtools.sim.vibro_impact import (
    OUT_COLUMNS,
    RunState,
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
# a branch passing this close to its first point (scaled arclength units) has closed
CLOSURE_TOLERANCE = 2e-3
# a closure maximum this close to the gap (relative to the tip amplitude) grazes
GRAZING_TOLERANCE = 1e-3
# a contact event is bracketed to this scaled arclength, and the orbits on its two sides are taken
# that far outside it: 100 times the finite-difference step of the monodromy matrix (1e-6)
EVENT_BRACKET = 1e-4
# period doublings closer than this (fraction of the range) are one: a multiplier lingering at -1
# makes det(M + I) change sign several times; one period-2 branch is switched onto per cluster
PD_CLUSTER = 1e-2
N_HARMONICS = 10
# labels a point may carry: the smooth bifurcations (rigtools.sim.bifurcations), the non-smooth
# events (rigtools.sim.contact_events: grazing, contact-split, sticking) and these
START, END, FAILED, SWITCH = "start", "end", "failed", "branch-switch"
BIFURCATIONS = (FOLD, PERIOD_DOUBLING, NEIMARK_SACKER, GRAZING, CONTACT_SPLIT, STICKING)

_COL = {name: i for i, name in enumerate(OUT_COLUMNS)}


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


@dataclass(frozen=True)
class BranchPoint:
    """One periodic orbit on a branch.

    Attributes
    ----------
    param, value
        The continued parameter (``"fe"``, ``"force"``, ``"gap"``) and its value (Hz, N or V, m).
    forcing
        All three quantities at this point.
    periods
        Forcing periods of the orbit (1, or 2 on a period-2 branch).
    state
        ``(q, v)`` (plus the coil current with a shaker, and the drive amplitude under force
        control) at force phase zero, modal coordinates of :attr:`PeriodMap.system`.
    multipliers
        Floquet multipliers (eigenvalues of the monodromy matrix), sorted by decreasing modulus.
    stable
        Every multiplier has modulus below 1.
    labels
        ``start``, ``end``, ``failed`` (last good point before a failure), ``branch-switch``, the
        smooth bifurcations (``fold``, ``period-doubling``, ``neimark-sacker``) and the non-smooth
        events (``grazing``, ``contact-split``, ``sticking``), see :data:`BIFURCATIONS`.
    measures
        :class:`OrbitMeasures`.
    tangent_param
        Parameter component of the unit tangent (scaled), which changes sign at a fold.
    newton_iterations
        Corrector iterations it took.
    contact
        The orbit's contact-event structure (:class:`rigtools.sim.contact_events.ContactStructure`).
    """

    param: str
    value: float
    forcing: Forcing
    periods: int
    state: np.ndarray = field(repr=False)
    multipliers: np.ndarray = field(repr=False)
    stable: bool
    labels: tuple[str, ...]
    measures: OrbitMeasures = field(repr=False)
    tangent_param: float = 0.0
    newton_iterations: int = 0
    contact: ContactStructure = field(default=ContactStructure(), repr=False)

    @property
    def max_multiplier(self) -> float:
        return float(np.max(np.abs(self.multipliers))) if self.multipliers.size else 0.0


@dataclass
class Branch:
    """A continued branch: points in arclength order, how it ended.

    ``status`` is ``"complete"`` (reached the end value; a switched branch: left the range for the
    last time, after coming back into it if it went out), ``"failed"`` (a point did not converge;
    ``message`` says where and why, the last point is the last good one), ``"left range"`` (the
    branch turned back out of the range; a switched branch: went out and did not come back where
    it is followed, see :func:`switch_period_doubling`), ``"max points"``, ``"merged"`` (a period-2
    branch returned onto the period-1 branch), ``"closed"`` (the branch came back to its first
    point: a closed loop, its last point that first orbit again) or ``"interrupted"``
    (:class:`KeyboardInterrupt` while it was followed: its points so far). A failure inside the
    tracer (a diverged integration, a singular matrix) is ``"failed"`` too, with its reason.

    ``bifurcations`` holds one :class:`rigtools.sim.bifurcations.Bifurcation` per labelled
    bifurcation or event, in branch order, with its critical multiplier and its location refined
    to a converged time step (:mod:`rigtools.sim.bifurcation_refine`).
    """

    param: str
    periods: int
    points: list[BranchPoint] = field(default_factory=list)
    status: str = "complete"
    message: str = ""
    steps_per_period: int = 0
    bifurcations: list[Bifurcation] = field(default_factory=list)

    def values(self) -> np.ndarray:
        return np.array([p.value for p in self.points])

    def stable(self) -> np.ndarray:
        return np.array([p.stable for p in self.points], dtype=bool)

    def measure(self, name: str) -> np.ndarray:
        """One :class:`OrbitMeasures` field per point (arrays stack, e.g. ``(n, 10)`` harmonics)."""
        return np.array([getattr(p.measures, name) for p in self.points])

    def labelled(self, label: str | None = None) -> list[BranchPoint]:
        """The points carrying ``label`` (any bifurcation label if ``None``)."""
        want = BIFURCATIONS if label is None else (label,)
        return [p for p in self.points if any(lab in want for lab in p.labels)]


# --------------------------------------------------------------------------- the shooting map


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
        self._key: tuple[float, float] | None = None
        self._stepper: VibroImpactStepper | None = None
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
        closure = data[:, _COL["active_tip_displacement"]] - data[:, _COL["passive_tip_displacement"]]
        return contact_structure(closure, data[:, _COL["contact_force"]], p.gap, st.contact_period / st.dt)

    def _stepper_for(self, p: Forcing) -> VibroImpactStepper:
        key = (p.fe, p.gap)
        if self._stepper is None or key != self._key:
            validate_harmonic_input(p.fe, abs(p.force), p.gap)
            dt = 1.0 / (p.fe * self.steps_per_period)
            self._stepper = VibroImpactStepper(
                self.base.with_contact(gap=p.gap),
                dt,
                self.shaker.coupling if self.shaker is not None else None,
                self.force_scale,
            )
            self._key = key
        return self._stepper

    def _scalars(self, x: np.ndarray, gap: float) -> np.ndarray:
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
        return float(np.abs(np.fft.rfft(data[:, _COL["excitation_force"]])[self.periods]) * 2.0 / n_total)

    def flow(self, y: np.ndarray, p: Forcing) -> tuple[np.ndarray, np.ndarray]:
        """``(y after the periods, outputs (steps, len(OUT_COLUMNS)))``; the outputs array is
        reused by the next call (copy it to keep it)."""
        st = self._stepper_for(p)
        x = np.asarray(y, dtype=float) / self.scale
        n = self.n_modes
        st.state = StepperState(x[:n].copy(), x[n : 2 * n].copy(), self._scalars(x, p.gap), 0.0)
        a = x[-1] if self.force_control else p.force
        o = st.step(a * self._unit_drive, self._out)
        self.evaluations += 1
        end = [st.state.q, st.state.v]
        if self.shaker is not None:
            end.append(st.state.scalars[2:3])
        if self.force_control:
            # the drive corrected towards the force: a fixed point holds |F1| = F0
            f1 = self.force_fundamental(o.data)
            if not f1 > 0:
                raise SimulationInputError("no force into the blade: the drive amplitude is zero")
            end.append(np.array([a * p.force / f1]))
        return np.concatenate(end) * self.scale, o.data

    def jacobian(
        self, y: np.ndarray, p: Forcing, param: str | None = None, fy: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """``(Phi(y), dPhi/dy, dPhi/dparam)`` by forward differences (``param`` None: no
        parameter column). ``fy``: ``Phi(y)`` if already known."""
        y = np.asarray(y, dtype=float)
        f0 = self.flow(y, p)[0] if fy is None else fy
        size = max(float(np.linalg.norm(y)) / math.sqrt(y.size), 1e-300)
        jac = np.empty((y.size, y.size))
        for j in range(y.size):
            h = FD_RELATIVE_STEP * max(abs(y[j]), size)
            yp = y.copy()
            yp[j] += h
            jac[:, j] = (self.flow(yp, p)[0] - f0) / h
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
            spec = np.fft.rfft(data[:, _COL[col]]) * 2.0 / n_total
            return k * w * np.abs(spec[k * per])

        fc = data[:, _COL["contact_force"]]
        closed = fc > 0
        onsets = int(np.count_nonzero(closed & ~np.roll(closed, 1)))
        closure = data[:, _COL["active_tip_displacement"]] - data[:, _COL["passive_tip_displacement"]]
        force = np.fft.rfft(data[:, _COL["excitation_force"]]) * 2.0 / n_total
        xa = data[:, _COL["active_tip_displacement"]]
        xp = data[:, _COL["passive_tip_displacement"]]
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


# --------------------------------------------------------------------------- one orbit


@dataclass
class _Solution:
    """A converged orbit with what the next step needs."""

    y: np.ndarray
    lam: float
    fy: np.ndarray
    jac: np.ndarray  # dPhi/dy at the solution (the monodromy matrix)
    dpar: np.ndarray
    data: np.ndarray
    iterations: int


class _Solver:
    """Newton (fixed parameter) and pseudo-arclength correctors on one :class:`PeriodMap`."""

    def __init__(self, pmap: PeriodMap, param: str, forcing: Forcing, y_scale: float, lam_scale: float):
        self.pmap = pmap
        self.param = param
        self.forcing = forcing
        self.Y = y_scale
        self.L = lam_scale
        self.tol = 1e-9
        self.max_iter = 12

    def at(self, lam: float) -> Forcing:
        return self.forcing.with_value(self.param, lam)

    def scaled(self, y: np.ndarray, lam: float) -> np.ndarray:
        return np.concatenate([y / self.Y, [lam / self.L]])

    def finish(self, y: np.ndarray, lam: float, iterations: int) -> _Solution:
        p = self.at(lam)
        fy, data = self.pmap.flow(y, p)
        data = data.copy()
        fy, jac, dpar = self.pmap.jacobian(y, p, self.param, fy=fy)
        assert dpar is not None
        return _Solution(y, lam, fy, jac, dpar, data, iterations)

    def fixed(
        self, y: np.ndarray, lam: float, jac: np.ndarray | None = None
    ) -> tuple[np.ndarray, int] | None:
        """Newton on ``Phi(y) - y = 0`` at a fixed parameter; ``None`` if it does not converge
        (an integration that diverges on the way included: a Newton step that ran away)."""
        p = self.at(lam)
        eye = np.eye(y.size)
        for it in range(1, self.max_iter + 1):
            try:
                if jac is None or it % 4 == 0:
                    fy, jac, _ = self.pmap.jacobian(y, p)
                else:
                    fy = self.pmap.flow(y, p)[0]
            except SimulationInputError:
                return None
            r = fy - y
            try:
                dy = np.linalg.solve(jac - eye, -r)
            except np.linalg.LinAlgError:
                return None
            y = y + dy
            if not np.all(np.isfinite(y)):
                return None
            if np.linalg.norm(dy) <= self.tol * self.Y and np.linalg.norm(r) <= 1e3 * self.tol * self.Y:
                return y, it
        return None

    def arclength(
        self,
        u_pred: np.ndarray,
        tangent: np.ndarray,
        jac: np.ndarray | None,
        dpar: np.ndarray | None,
        full: bool = False,
    ) -> tuple[np.ndarray, float, int] | None:
        """Chord Newton on ``Phi(y, lam) - y = 0``, ``tangent . (u - u_pred) = 0`` starting from
        the Jacobian given (refreshed after 4 slow iterations); ``None`` if no convergence."""
        u = u_pred.copy()
        m = u.size - 1
        eye = np.eye(m)
        fresh = False
        prev_rate = math.inf
        ratio = 0.0
        for it in range(1, self.max_iter + 1):
            y, lam = u[:m] * self.Y, u[m] * self.L
            p = self.at(lam)
            try:
                if full or jac is None or dpar is None or (it > 1 and not fresh and (ratio > 0.3 or it >= 5)):
                    fy, jac, dpar_new = self.pmap.jacobian(y, p, self.param)
                    assert dpar_new is not None
                    dpar = dpar_new
                    fresh = True
                else:
                    fy = self.pmap.flow(y, p)[0]
            except SimulationInputError:
                return None
            r = np.concatenate([(fy - y) / self.Y, [tangent @ (u - u_pred)]])
            a = np.zeros((m + 1, m + 1))
            a[:m, :m] = jac - eye
            a[:m, m] = dpar * self.L / self.Y
            a[m] = tangent
            try:
                du = np.linalg.solve(a, -r)
            except np.linalg.LinAlgError:
                return None
            rate = float(np.linalg.norm(du))
            u = u + du
            if not np.all(np.isfinite(u)):
                return None
            if rate <= self.tol:
                return u[:m] * self.Y, u[m] * self.L, it
            ratio = rate / prev_rate if math.isfinite(prev_rate) else 0.0
            prev_rate = rate
        return None

    def tangent(self, sol: _Solution, previous: np.ndarray | None, direction: float = 1.0) -> np.ndarray:
        """Unit tangent (scaled) at a solution: orientation kept from ``previous`` or, without
        one, pointing to increasing parameter times ``direction``."""
        m = sol.y.size
        a = np.zeros((m + 1, m + 1))
        a[:m, :m] = sol.jac - np.eye(m)
        a[:m, m] = sol.dpar * self.L / self.Y
        if previous is None:
            a[m, m] = 1.0
        else:
            a[m] = previous
        rhs = np.zeros(m + 1)
        rhs[m] = 1.0
        t = np.linalg.solve(a, rhs)
        t /= np.linalg.norm(t)
        if previous is None:
            if t[m] * direction < 0:
                t = -t
        elif t @ previous < 0:
            t = -t
        return t


def _settle(pmap: PeriodMap, y: np.ndarray, p: Forcing, max_periods: int = 400) -> np.ndarray:
    """Integrate the map until it repeats to 1e-6 (or ``max_periods`` forcing periods)."""
    for _ in range(max(1, max_periods // pmap.periods)):
        y1 = pmap.flow(y, p)[0]
        if np.linalg.norm(y1 - y) <= 1e-6 * max(float(np.linalg.norm(y1)), 1e-300):
            return y1
        y = y1
    return y


def _point(
    pmap: PeriodMap, param: str, sol: _Solution, forcing: Forcing, tangent_param: float, labels=()
) -> BranchPoint:
    p = forcing.with_value(param, sol.lam)
    k = pmap.n_physical  # the blades and the coil at a fixed drive, never the force control
    mult = np.linalg.eigvals(sol.jac[:k, :k])
    mult = mult[np.argsort(-np.abs(mult))]
    return BranchPoint(
        param=param,
        value=float(sol.lam),
        forcing=p,
        periods=pmap.periods,
        state=sol.y / pmap.scale,
        multipliers=mult,
        stable=bool(np.max(np.abs(mult)) < 1.0),
        labels=tuple(labels),
        measures=pmap.measures(sol.data, p, pmap.drive(sol.y, p)),
        tangent_param=float(tangent_param),
        newton_iterations=sol.iterations,
        contact=pmap.contact_structure(sol.data, p),
    )


def solve_orbit(
    pmap: PeriodMap, forcing: Forcing, y0: np.ndarray | None = None, settle_periods: int = 400
) -> BranchPoint:
    """The periodic orbit at fixed ``forcing``: Newton from ``y0`` (default: the response
    without contact, settled by integrating the map), with its multipliers and measures.

    Raises :class:`ContinuationError` if Newton does not converge.
    """
    y = pmap.linear_orbit(forcing) if y0 is None else np.asarray(y0, dtype=float)
    y_scale = max(float(np.linalg.norm(y)), 1e-12)
    solver = _Solver(pmap, "fe", forcing, y_scale, 1.0)
    res = solver.fixed(y, forcing.fe)
    if res is None:
        y = _settle(pmap, y, forcing, settle_periods)
        solver.Y = max(float(np.linalg.norm(y)), 1e-12)
        res = solver.fixed(y, forcing.fe)
    if res is None:
        raise ContinuationError(
            f"no periodic orbit found at fe = {forcing.fe:g} Hz, force = {forcing.force:g}, "
            f"gap = {forcing.gap * 1e3:g} mm (Newton did not converge from the settled response)"
        )
    sol = solver.finish(res[0], forcing.fe, res[1])
    return _point(pmap, "fe", sol, forcing, 0.0)


# --------------------------------------------------------------------------- continuation


@dataclass
class _Entry:
    sol: _Solution
    tangent: np.ndarray
    point: BranchPoint


@dataclass
class ContinuationSettings:
    """Step control and limits (step lengths in the scaled arclength, see the module docstring).

    ``max_step`` defaults to a fiftieth of the range; ``initial_step`` to a fifth of it.
    """

    initial_step: float | None = None
    min_step: float = 1e-6
    max_step: float | None = None
    max_points: int = 2000
    locate: bool = True
    locate_iterations: int = 12
    steps_per_period: int | None = None
    # each labelled point relocated at doubled steps per period until it moves less than this
    # (relative), :mod:`rigtools.sim.bifurcation_refine`; ``refine=False``: not at all
    refine: bool = True
    refine_tolerance: float = REFINE_TOLERANCE
    max_refinements: int = MAX_REFINEMENTS


class _Tracer:
    def __init__(
        self,
        pmap: PeriodMap,
        param: str,
        forcing: Forcing,
        stop: float,
        lam_scale: float,
        settings: ContinuationSettings,
        progress: Callable[[int, float], None] | None,
        bounds: tuple[float, float],
        window: tuple[float, float] | None = None,
    ):
        self.pmap = pmap
        self.param = param
        self.forcing = forcing
        self.stop = stop
        self.settings = settings
        self.progress = progress
        self.bounds = bounds
        # a switched branch is followed within ``bounds`` (wider) and ends where it leaves the
        # ``window`` (the range asked for) for the second time, or for good
        self.window = window
        self._crossings: list[float] = []
        self.solver = _Solver(pmap, param, forcing, 1.0, lam_scale)
        self.y_floor = 1e-12
        self._left_start = False

    def entry(self, sol: _Solution, tangent: np.ndarray, labels=()) -> _Entry:
        return _Entry(sol, tangent, _point(self.pmap, self.param, sol, self.forcing, tangent[-1], labels))

    def enter(self, state: np.ndarray, value: float) -> _Entry | None:
        """The orbit of this tracer's map on the arclength plane through ``(state, value)``
        (unscaled state), normal to this map's branch there: a point of a branch traced at another
        time step carried onto this one (:mod:`rigtools.sim.bifurcation_refine`); ``None`` if
        none converges."""
        s = self.solver
        y = np.asarray(state, dtype=float) * self.pmap.scale
        s.Y = max(float(np.linalg.norm(y)), 1e-12)
        try:
            fy, jac, dpar = self.pmap.jacobian(y, s.at(value), self.param)
            assert dpar is not None
            t = s.tangent(_Solution(y, value, fy, jac, dpar, np.empty((0, 0)), 0), None)
            res = s.arclength(s.scaled(y, value), t, jac, dpar) or s.arclength(
                s.scaled(y, value), t, None, None, full=True
            )
            if res is None:
                return None
            sol = s.finish(*res)
            return self.entry(sol, s.tangent(sol, t))
        except (SimulationInputError, np.linalg.LinAlgError):
            return None

    def correct(self, prev: _Entry, h: float) -> _Entry | None:
        """The point at arclength ``h`` from ``prev`` along its tangent."""
        s = self.solver
        u_pred = s.scaled(prev.sol.y, prev.sol.lam) + h * prev.tangent
        res = s.arclength(u_pred, prev.tangent, prev.sol.jac, prev.sol.dpar)
        if res is None:  # chord iterations failed: full Newton before the step is cut
            res = s.arclength(u_pred, prev.tangent, None, None, full=True)
        if res is None:
            return None
        y, lam, it = res
        if np.linalg.norm(s.scaled(y, lam) - u_pred) > 2.0 * abs(h):
            return None  # converged far from the predictor: onto another part of the curve
        try:
            sol = s.finish(y, lam, it)
            t = s.tangent(sol, prev.tangent)
        except (SimulationInputError, np.linalg.LinAlgError):
            return None
        return self.entry(sol, t)

    def run(self, first: _Entry, branch: Branch, direction_sign: float) -> Branch:
        """Follow the branch from ``first``; any failure inside (an integration that diverges, a
        singular matrix, a non-finite value) ends it ``"failed"`` with the reason in one line and
        the points so far kept."""
        try:
            return self._follow(first, branch, direction_sign)
        except (SimulationInputError, np.linalg.LinAlgError, FloatingPointError, ValueError) as exc:
            last = branch.points[-1].value if branch.points else first.sol.lam
            reason = " ".join(str(exc).split()) or type(exc).__name__
            branch.status = "failed"
            branch.message = (
                f"failed after {self.param} = {last:.6g} {UNITS[self.param]}: {reason}; the branch ends "
                "at the last good point"
            )
            if branch.points:
                _relabel(branch, -1, FAILED)
            return branch
        except KeyboardInterrupt:
            # the caller may keep the points followed so far (``found`` of :func:`trace`)
            branch.status = "interrupted"
            if branch.points:
                branch.message = (
                    f"interrupted after {self.param} = {branch.points[-1].value:.6g} "
                    f"{UNITS[self.param]}; the branch ends at the last point computed"
                )
            raise

    def _follow(self, first: _Entry, branch: Branch, direction_sign: float) -> Branch:
        st = self.settings
        lam_span = abs(self.bounds[1] - self.bounds[0])
        h_max = st.max_step if st.max_step is not None else 1.0 / 50.0
        h = st.initial_step if st.initial_step is not None else h_max / 5.0
        h_max = max(h_max, h)
        lo, hi = min(self.bounds), max(self.bounds)
        margin = 1e-9 * lam_span
        entries = [first]
        branch.points.append(first.point)
        while True:
            prev = entries[-1]
            if len(branch.points) >= st.max_points:
                branch.status = "max points"
                branch.message = f"stopped after {st.max_points} points"
                break
            nxt = self.correct(prev, h)
            if nxt is None:
                h *= 0.5
                if h < st.min_step and len(entries) > 1:
                    if self.turn_at_hairpin(entries, branch):
                        h = h_max / 10.0
                        continue
                    corner = self.cross_grazing_corner(entries)
                    if corner is not None:
                        self._detect(prev, corner, h, branch)
                        entries.append(corner)
                        branch.points.append(corner.point)
                        h = h_max / 10.0
                        continue
                if h < st.min_step:
                    branch.status = "failed"
                    branch.message = (
                        f"no convergence past {self.param} = {prev.sol.lam:.6g} {UNITS[self.param]} "
                        f"(step below {st.min_step:g}); the branch ends at the last good point"
                    )
                    _relabel(branch, -1, FAILED)
                    break
                continue
            # step control on the corrector's work
            it = nxt.sol.iterations
            lam_next = nxt.sol.lam
            if self.window is not None and not (lam_next < lo - margin or lam_next > hi + margin):
                edge = self.window_edge(prev, nxt, h, branch)
                if edge is not None:
                    entries.append(edge)
                    branch.points.append(edge.point)
                    if len(self._crossings) >= 3:  # out, back in, and out again: the end
                        _relabel(branch, -1, END)
                        branch.message = self._excursion_message()
                        break
                    continue
            past_end = self.window is None and (lam_next - self.stop) * direction_sign > 0
            outside = lam_next < lo - margin or lam_next > hi + margin
            if past_end or outside:
                target = self.stop if past_end else (lo if lam_next < lo else hi)
                # the point exactly at the end value, by Newton at fixed parameter from the
                # interpolated state
                w = (target - prev.sol.lam) / (lam_next - prev.sol.lam)
                y0 = prev.sol.y + w * (nxt.sol.y - prev.sol.y)
                res = self.solver.fixed(y0, target, prev.sol.jac)
                if res is not None:
                    sol = self.solver.finish(res[0], target, res[1])
                    t = self.solver.tangent(sol, prev.tangent)
                    end = self.entry(sol, t)
                    self._detect(prev, end, (target - prev.sol.lam) / (lam_next - prev.sol.lam) * h, branch)
                    entries.append(end)
                    branch.points.append(end.point)
                    _relabel(branch, -1, END)
                else:
                    branch.status = "failed"
                    branch.message = f"no orbit at the end value {target:.6g} {UNITS[self.param]}"
                    _relabel(branch, -1, FAILED)
                    break
                if not past_end:
                    branch.status = "left range"
                    branch.message = (
                        f"the branch turned back and left the range at {target:.6g} {UNITS[self.param]}"
                    )
                    if self.window is not None and target in self.window:
                        # the range asked for ends here on this side too (fe is followed upwards
                        # only, force downwards only): left in one step, from inside
                        branch.message = (
                            f"the branch left the range at {target:.6g} {UNITS[self.param]}, "
                            "where it is followed no further"
                        )
                    elif self.window is not None:
                        if min(self.window) <= prev.sol.lam <= max(self.window):
                            # out of the range asked for and of the bounds in this one step
                            self._crossings.append(
                                min(self.window) if target < prev.sol.lam else max(self.window)
                            )
                        branch.message = (
                            f"the branch left the range at {self._crossings[-1]:.6g} {UNITS[self.param]} "
                            f"and had not returned at {target:.6g} {UNITS[self.param]}, where it is "
                            "followed no further"
                        )
                break
            if self.pmap.periods > 1 and _half_difference(prev) @ _half_difference(nxt) < 0:
                # through a period doubling of the period-1 branch (the map over two periods has a
                # pitchfork there; the step is the orbit crossing onto its own shift by a period)
                branch.status = "merged"
                branch.message = (
                    f"the period-{self.pmap.periods} orbit returned onto the period-1 branch between "
                    f"{self.param} = {prev.sol.lam:.6g} and {nxt.sol.lam:.6g} {UNITS[self.param]}"
                )
                _relabel(branch, -1, END)
                break
            self._detect(prev, nxt, h, branch)
            entries.append(nxt)
            branch.points.append(nxt.point)
            if self._closes(first, prev, nxt, h_max):
                branch.points.append(replace(first.point, labels=(END,)))
                branch.status = "closed"
                branch.message = (
                    f"the branch closed on itself: back at its first orbit, {self.param} = "
                    f"{first.sol.lam:.6g} {UNITS[self.param]}"
                )
                break
            self._rescale(nxt)
            if self.pmap.periods > 1 and len(branch.points) > 5 and _period_one_distance(nxt) < 1e-5:
                branch.status = "merged"
                branch.message = (
                    f"the period-{self.pmap.periods} orbit returned onto the period-1 branch at "
                    f"{self.param} = {nxt.sol.lam:.6g} {UNITS[self.param]}"
                )
                _relabel(branch, -1, END)
                break
            if self.progress is not None:
                self.progress(len(branch.points), nxt.sol.lam)
            if it <= 3:
                h = min(h * 1.5, h_max)
            elif it > 6:
                h *= 0.5
        return branch

    def _closes(self, first: _Entry, prev: _Entry, nxt: _Entry, h_max: float) -> bool:
        """The step ``prev -> nxt`` passes within :data:`CLOSURE_TOLERANCE` (scaled state and
        parameter, plus a tenth of the step) of the branch's first point, after the branch has
        been further than four largest steps from it."""
        s = self.solver
        u0, a, b = (s.scaled(e.sol.y, e.sol.lam) for e in (first, prev, nxt))
        dist = float(np.linalg.norm(b - u0))
        if not self._left_start:
            self._left_start = dist > 4.0 * h_max
            return False
        seg = b - a
        w = float(np.clip((u0 - a) @ seg / max(float(seg @ seg), 1e-300), 0.0, 1.0))
        return float(np.linalg.norm(a + w * seg - u0)) <= CLOSURE_TOLERANCE + 0.1 * float(np.linalg.norm(seg))

    def _rescale(self, e: _Entry) -> None:
        """Measure the state by the current orbit's size (a resonance peak many times the first
        orbit would otherwise take as many steps): the entry's tangent is re-expressed."""
        y_new = max(float(np.linalg.norm(e.sol.y)), self.y_floor)
        if abs(y_new / self.solver.Y - 1.0) < 0.2:
            return
        m = e.sol.y.size
        t = e.tangent.copy()
        t[:m] *= self.solver.Y / y_new
        self.solver.Y = y_new
        e.tangent = t / np.linalg.norm(t)

    def window_edge(self, prev: _Entry, nxt: _Entry, h: float, branch: Branch) -> _Entry | None:
        """The orbit exactly at the edge of :attr:`window` where the step ``prev -> nxt`` crosses
        it (its bifurcations detected and appended to the branch), the crossing recorded; ``None``
        if the step stays on one side or no orbit converges at the edge value (the crossing is then
        recorded at ``nxt``)."""
        assert self.window is not None
        a, b = prev.sol.lam, nxt.sol.lam
        edges = [e for e in self.window if min(a, b) < e <= max(a, b) and e != a]
        if not edges:
            return None
        target = min(edges, key=lambda e: abs(e - a))
        self._crossings.append(target)
        w = (target - a) / (b - a)
        res = self.solver.fixed(prev.sol.y + w * (nxt.sol.y - prev.sol.y), target, prev.sol.jac)
        if res is None:
            return None
        sol = self.solver.finish(res[0], target, res[1])
        edge = self.entry(sol, self.solver.tangent(sol, prev.tangent))
        self._detect(prev, edge, w * h, branch)
        return edge

    def _excursion_message(self) -> str:
        u = UNITS[self.param]
        x = self._crossings
        return (
            f"the branch left the range at {x[0]:.6g} {u}, came back at {x[1]:.6g} {u} and ends where "
            f"it leaves it again, at {x[2]:.6g} {u}"
        )

    def turn_at_hairpin(self, entries: list[_Entry], branch: Branch) -> bool:
        """Turn back at a grazing hairpin: where an impact (a local maximum of the closure) grazes,
        two sheets of the branch, one with that impact and one without, end in a sharp turning
        point. Approaching it the corrector steps from the first sheet onto the second (the
        impacts per period change while the parameter keeps its direction) and then fails at the
        grazing orbit (or it reaches the grazing orbit itself, the change in its last step). The
        points since that change lie on the returning sheet, taken towards the turning point: they
        are dropped, the last point (the grazing orbit) is labelled fold and grazing, and the branch
        goes on from it along the returning sheet, with the tangent of its first point there
        reversed or, if the grazing orbit is the only one, of an orbit of the returning sheet found
        by Newton a little back from it. ``False`` if the last point does not graze or no such
        change precedes it."""
        last = entries[-1]
        if _grazing_margin(last) > GRAZING_TOLERANCE or FOLD in last.point.labels:
            return False  # no grazing, or turned here already and no way on
        lam = [e.sol.lam for e in entries]
        travel = math.copysign(1.0, lam[-1] - lam[-2])
        k = len(entries) - 1
        while k > 0 and (lam[k] - lam[k - 1]) * travel > 0:
            if (
                entries[k].point.measures.impacts_per_period
                != entries[k - 1].point.measures.impacts_per_period
            ):
                break
            k -= 1
        else:
            return False
        if abs(lam[-1] - lam[k]) > abs(lam[k] - lam[k - 1]):
            return False  # a long way on since: impacts changed at a grazing it went through
        # entries[k:] are on the returning sheet; entries[k].tangent is smooth there unless it is
        # the grazing orbit itself
        first_dropped = next((i for i, p in enumerate(branch.points) if p is entries[k].point), None)
        if first_dropped is None:
            return False
        back = None
        if k == len(entries) - 1:
            back = self._returning_orbit(last, entries[k - 1], travel)
            if back is None:
                return False
        tangent = -entries[k].tangent if back is None else back.tangent
        del branch.points[first_dropped:]
        tip = _Entry(
            last.sol, tangent, replace(last.point, labels=(FOLD, GRAZING), tangent_param=float(tangent[-1]))
        )
        del entries[k:]
        entries.append(tip)
        branch.points.append(tip.point)
        if back is not None:
            entries.append(back)
            branch.points.append(back.point)
        return True

    def _returning_orbit(self, tip: _Entry, before: _Entry, travel: float) -> _Entry | None:
        """An orbit with the grazing orbit's impacts (not those of ``before``, the sheet that led
        to it) at a parameter a little back from the grazing orbit, with its tangent leaving it."""
        impacts = tip.point.measures.impacts_per_period
        delta = max(abs(tip.sol.lam - before.sol.lam), 1e-4 * self.solver.L)
        for scale in (0.25, 1.0, 4.0):
            lam = tip.sol.lam - travel * scale * delta
            if not min(self.bounds) <= lam <= max(self.bounds):
                continue
            res = self.solver.fixed(tip.sol.y, lam)
            if res is None:
                continue
            try:
                sol = self.solver.finish(res[0], lam, res[1])
                e = self.entry(sol, self.solver.tangent(sol, None, -travel))
            except (SimulationInputError, np.linalg.LinAlgError):
                continue
            if e.point.measures.impacts_per_period == impacts != before.point.measures.impacts_per_period:
                return e
        return None

    def cross_grazing_corner(self, entries: list[_Entry]) -> _Entry | None:
        """Past a grazing point where the branch turns back sharply (impacts begin or end with
        a kink in the map: no arclength plane meets the continuing branch), the orbit on the other
        side of the grazing at a parameter a little to either side; ``None`` if the last point
        does not graze or no such orbit is found."""
        prev, before = entries[-1], entries[-2]
        amplitude = max(prev.point.measures.tip_amplitude_active, 1e-300)
        if abs(prev.point.measures.min_gap) > 1e-3 * amplitude:
            return None
        side = math.copysign(1.0, before.point.measures.min_gap)
        delta = max(abs(prev.sol.lam - before.sol.lam), 1e-4 * self.solver.L)
        for scale in (1.0, 4.0, 16.0):
            for sign in (1.0, -1.0):
                lam = prev.sol.lam + sign * scale * delta
                if not min(self.bounds) <= lam <= max(self.bounds):
                    continue
                res = self.solver.fixed(prev.sol.y, lam, prev.sol.jac)
                if res is None:
                    continue
                try:
                    sol = self.solver.finish(res[0], lam, res[1])
                    t = self.solver.tangent(sol, None, sign)
                except (SimulationInputError, np.linalg.LinAlgError):
                    continue
                e = self.entry(sol, t)
                if e.point.measures.min_gap * side < 0:  # the other side of the grazing
                    return e
        return None

    def _along(self, a: _Entry, b: _Entry) -> float:
        """The arclength of ``b`` from ``a`` along ``a``'s tangent (where its predictor meets it)."""
        s = self.solver
        return float((s.scaled(b.sol.y, b.sol.lam) - s.scaled(a.sol.y, a.sol.lam)) @ a.tangent)

    def _detect(self, prev: _Entry, nxt: _Entry, h: float, branch: Branch, depth: int = 0) -> list[_Entry]:
        """Append the located bifurcations and events between ``prev`` and ``nxt`` to the branch
        (``nxt`` is appended by the caller) and return them (:mod:`rigtools.sim.bifurcations`).

        Where the contact structure changes, the event is bracketed by bisection and its two
        sides inserted (the first orbit of the new structure labelled with the event); the
        smooth tests run on each side of it, never across it (the monodromy matrix jumps there).
        A smooth bifurcation of the kind just found within 1e-4 of the range is the same one.
        ``h`` is unused: the arclength is measured from the two points."""
        located: list[_Entry] = []
        if prev.point.contact != nxt.point.contact:
            h = self._along(prev, nxt)
            if self.settings.locate and depth < 3 and h > 0:
                last, first = self._bracket_event(prev, nxt, h)
            else:
                last, first = prev, None
            after = first if first is not None else nxt
            kind = _event(last, after)
            after.point = replace(after.point, labels=(*after.point.labels, kind))
            located += self._smooth(prev, last, branch)
            if last is not prev:
                located.append(last)
            if after is not nxt:
                located.append(after)
                located += self._detect(after, nxt, 0.0, branch, depth + 1)
            else:
                located += self._smooth(after, nxt, branch)
        else:
            located += self._smooth(prev, nxt, branch)
        if depth == 0:
            branch.points.extend(e.point for e in located)
        return located

    def _bracket_event(self, prev: _Entry, nxt: _Entry, h: float) -> tuple[_Entry, _Entry | None]:
        """The orbits on either side of the contact event between ``prev`` and ``nxt`` (``None``
        for the second where no orbit converges past it): bisected to :data:`EVENT_BRACKET` and
        taken a bracket's width outside it, so that the finite differences of their monodromy
        matrices do not straddle the event (the matrix jumps there)."""
        correct = functools.partial(self.correct, prev)
        last, first, lo, hi = bif.bisect_event(correct, prev, h, 14, EVENT_BRACKET)
        if first is None:
            return last, None
        w = hi - lo
        if lo > 0.0:
            e = correct(lo - w) if lo - w > 0.0 else prev
            last = e if e is not None and e.point.contact == prev.point.contact else last
        e = correct(hi + w) if hi + w < h else nxt
        if e is not None and e.point.contact == first.point.contact:
            first = e
        return last, first

    def _smooth(self, a: _Entry, b: _Entry, branch: Branch) -> list[_Entry]:
        """The smooth bifurcations between two orbits of one contact structure, located and
        checked on their critical multiplier (:func:`rigtools.sim.bifurcations.accepted`)."""
        if a is b or a.point.contact != b.point.contact:
            return []
        h = self._along(a, b)
        tol = 1e-4 * self.solver.L
        found: list[tuple[float, _Entry]] = []
        for kind in SMOOTH:
            if not bif.crossed(kind, a, b) or _near_last(branch, kind, b.sol.lam, tol):
                continue
            e = bif.locate(lambda s: self.correct(a, s), a, b, h, kind, self.settings.locate_iterations)
            if e is None or not self.settings.locate:
                continue  # the test jumps: no bifurcation (a turning is labelled from the values)
            if not bif.accepted(kind, e) or _near_last(branch, kind, e.sol.lam, tol):
                continue
            e.point = replace(e.point, labels=(kind,))
            found.append((self._along(a, e), e))
        return [e for _, e in sorted(found, key=lambda f: f[0])]


def _event(a: _Entry, b: _Entry) -> str:
    """The non-smooth event between two orbits of different contact structures."""
    return event_kind(a.point.contact, b.point.contact) or GRAZING


def _grazing_margin(e: _Entry) -> float:
    """Smallest distance between a local maximum of the closure (active minus passive shroud
    displacement, sampled) and the gap over the orbit, relative to the active tip amplitude: zero
    where an impact, the first or another one, grazes."""
    data = e.sol.data
    closure = data[:, _COL["active_tip_displacement"]] - data[:, _COL["passive_tip_displacement"]]
    peaks = closure[(closure > np.roll(closure, 1)) & (closure >= np.roll(closure, -1))]
    if not peaks.size:
        return math.inf
    amplitude = max(e.point.measures.tip_amplitude_active, 1e-300)
    return float(np.min(np.abs(peaks - e.point.forcing.gap)) / amplitude)


def _near_last(branch: Branch, label: str, value: float, tol: float) -> bool:
    """The last few points hold ``label`` within ``tol`` of ``value``."""
    return any(label in p.labels and abs(p.value - value) <= tol for p in branch.points[-10:])


def _relabel(branch: Branch, index: int, label: str) -> None:
    p = branch.points[index]
    if label not in p.labels:
        branch.points[index] = replace(p, labels=(*p.labels, label))


def _unlabel(branch: Branch, index: int, label: str) -> None:
    p = branch.points[index]
    branch.points[index] = replace(p, labels=tuple(lab for lab in p.labels if lab != label))


def _half_difference(e: _Entry) -> np.ndarray:
    """The shroud displacements over a period-2 orbit's first period minus its second: it
    changes sign where the branch crosses the period-1 orbit (onto its shift by one period)."""
    data = e.sol.data
    n = data.shape[0] // 2
    x = data[:, [_COL["active_tip_displacement"], _COL["passive_tip_displacement"]]]
    return (x[:n] - x[n:]).ravel()


def _period_one_distance(e: _Entry) -> float:
    """How far a period-2 orbit is from repeating after one period (relative)."""
    data = e.sol.data
    n = data.shape[0] // 2
    x = data[:, [_COL["active_tip_displacement"], _COL["passive_tip_displacement"]]]
    return float(np.max(np.abs(x[:n] - x[n:])) / max(float(np.max(np.abs(x))), 1e-300))


def _prepare(
    system: ReducedSystem,
    param: str,
    start: float,
    stop: float,
    fe: float,
    force: float,
    gap: float,
    periods: int,
    shaker: ShakerDrive | None,
    settings: ContinuationSettings,
) -> tuple[PeriodMap, Forcing]:
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
    n = settings.steps_per_period or steps_per_period_for(system, fe_min, force_scale=force_scale)
    return PeriodMap(system, n, periods, shaker, force_scale=force_scale), forcing


def continue_orbits(
    system: ReducedSystem,
    param: str,
    start: float,
    stop: float,
    *,
    fe: float = 60.0,
    force: float = 15.0,
    gap: float = 0.7e-3,
    periods: int = 1,
    shaker: ShakerDrive | None = None,
    y0: np.ndarray | None = None,
    settings: ContinuationSettings | None = None,
    progress: Callable[[int, float], None] | None = None,
    found: list[Branch] | None = None,
) -> Branch:
    """Continue the periodic orbits of the forced reduced system in ``param`` from ``start`` to
    ``stop``.

    Parameters
    ----------
    system
        Reduced system (FEM or AM, :func:`rigtools.sim.reduction.reduced_system`).
    param
        ``"fe"`` (Hz), ``"force"`` (force amplitude, N; with ``shaker`` the force fundamental
        held, N, or the drive amplitude, V, see :class:`ShakerDrive`) or ``"gap"`` (m).
    start, stop
        Parameter range; the branch starts at ``start`` and ends where it reaches ``stop``, turns
        back out of the range, fails to converge (reported in ``Branch.status``/``message``), or
        after ``settings.max_points``.
    fe, force, gap
        The fixed quantities (the continued one is ignored).
    periods
        Forcing periods of the orbits (1; 2 for a period-2 branch).
    shaker
        Drive through a shaker (the simulated rig's model, :class:`ShakerDrive`).
    y0
        Scaled starting state (:class:`PeriodMap` convention); default: the response without
        contact, settled if Newton does not converge from it.
    settings
        :class:`ContinuationSettings`.
    progress
        ``progress(points_so_far, parameter_value)`` after each point.
    found
        The branch is appended to this list once its first orbit is found and grows there point
        by point: interrupted (:class:`KeyboardInterrupt`), the caller keeps the points computed,
        the branch's status ``"interrupted"``.

    Returns
    -------
    Branch
        Points in arclength order, the located bifurcations inserted between them.

    Raises
    ------
    ContinuationError
        No orbit at ``start``.
    """
    settings = settings or ContinuationSettings()
    pmap, forcing = _prepare(system, param, start, stop, fe, force, gap, periods, shaker, settings)
    tracer = _Tracer(pmap, param, forcing, stop, abs(stop - start), settings, progress, (start, stop))
    orbit = solve_orbit(pmap, forcing, y0)
    y = orbit.state * pmap.scale
    tracer.solver.Y = max(float(np.linalg.norm(y)), 1e-12)
    tracer.y_floor = 0.1 * tracer.solver.Y
    sol = tracer.solver.finish(y, start, orbit.newton_iterations)
    t = tracer.solver.tangent(sol, None, 1.0 if stop > start else -1.0)
    branch = Branch(param=param, periods=pmap.periods, steps_per_period=pmap.steps_per_period)
    if found is not None:
        found.append(branch)
    tracer.run(tracer.entry(sol, t, (START,)), branch, 1.0 if stop > start else -1.0)
    return _finish_branch(tracer, branch)


def switch_period_doubling(
    system: ReducedSystem,
    point: BranchPoint,
    start: float,
    stop: float,
    *,
    shaker: ShakerDrive | None = None,
    settings: ContinuationSettings | None = None,
    progress: Callable[[int, float], None] | None = None,
    offset: float = 0.02,
    found: list[Branch] | None = None,
) -> Branch:
    """The period-2 branch born at a period doubling ``point`` of a period-1 branch.

    Over two periods the period-1 orbit is still a fixed point and the period-2 orbit crosses it
    (a pitchfork); the new branch leaves along the eigenvector ``v`` of the multiplier nearest
    -1. The first point is corrected on the plane ``v . (u - u_pd - h v) = 0`` at ``h = offset``
    (scaled arclength; halved until it converges onto an orbit that does not repeat after one
    period), then continued in the direction leaving the period-1 branch.

    ``[start, stop]`` is the period-1 branch's range. A period-2 branch may leave it and come
    back (a subcritical period doubling's branch that turns at a fold outside): it is followed
    up to the range's width beyond it where the time step chosen for the range holds (the gap
    either way, the frequency upwards, the force downwards; none below zero), its points out
    there kept in order, and it ends where it leaves the range the second time (``"complete"``,
    the message naming the crossings), merges, closes, or at the end of where it is followed
    (``"left range"``).

    Raises
    ------
    ContinuationError
        No period-2 orbit found next to the point.
    """
    settings = settings or ContinuationSettings()
    param = point.param
    lo, hi = min(start, stop), max(start, stop)
    pmap1, _ = _prepare(system, param, start, stop, *_fixed(point), 1, shaker, settings)
    pmap = pmap1.with_periods(2)
    y_pd = point.state * pmap.scale
    _, jac1, _ = pmap1.jacobian(y_pd, point.forcing)
    k = pmap1.n_physical  # under force control the drive does not take part (the doubled
    # orbit's force fundamental changes at second order only)
    mu, vecs = np.linalg.eig(jac1[:k, :k])
    j = int(np.argmin(np.abs(mu + 1.0)))
    v = np.concatenate([vecs[:, j].real, np.zeros(y_pd.size - k)])
    v /= np.linalg.norm(v)
    followed = _followed_range(param, lo, hi)
    tracer = _Tracer(pmap, param, point.forcing, stop, hi - lo, settings, progress, followed, (lo, hi))
    solver = tracer.solver
    solver.Y = max(float(np.linalg.norm(y_pd)), 1e-12)
    tracer.y_floor = 0.1 * solver.Y
    direction = np.concatenate([v, [0.0]])
    h = offset
    first: _Entry | None = None
    while h > 1e-5 and first is None:
        for sign in (1.0, -1.0):
            u_pred = solver.scaled(y_pd, point.value) + sign * h * direction
            # a fresh Jacobian: at the branch point itself the bordered matrix is singular
            res = solver.arclength(u_pred, direction, None, None, full=True)
            if res is None:
                continue
            sol = solver.finish(*res)
            if not lo - 1e-9 * (hi - lo) <= sol.lam <= hi + 1e-9 * (hi - lo):
                continue
            e = tracer.entry(sol, solver.tangent(sol, sign * direction))
            if _period_one_distance(e) > 1e-4:
                first = e
                break
        h *= 0.5
    if first is None:
        raise ContinuationError(
            f"no period-2 orbit found next to the period doubling at {param} = {point.value:.6g} "
            f"{UNITS[param]}"
        )
    first.point = replace(first.point, labels=(SWITCH,))
    going_up = first.tangent[-1] >= 0
    tracer.stop = hi if going_up else lo
    branch = Branch(param=param, periods=2, steps_per_period=pmap.steps_per_period)
    if found is not None:
        found.append(branch)
    tracer.run(first, branch, 1.0 if going_up else -1.0)
    return _finish_branch(tracer, branch)


def _finish_branch(tracer: _Tracer, branch: Branch) -> Branch:
    """Label the branch's turning points ``fold`` (:func:`rigtools.sim.bifurcations.mark_turning_points`)
    and record every bifurcation and event (:attr:`Branch.bifurcations`), each relocated at a
    converged time step unless ``settings.refine`` is off (a failure there keeps it unrefined)."""
    bif.merge_hairpin_grazing(branch.points, lambda i, label: _unlabel(branch, i, label))
    bif.mark_turning_points(
        branch.points,
        lambda i, label: _relabel(branch, i, label),
        lambda i, label: _unlabel(branch, i, label),
    )
    st = tracer.settings

    def make(n: int) -> _Tracer:
        pmap = tracer.pmap.with_steps(n)
        return _Tracer(
            pmap, tracer.param, tracer.forcing, tracer.stop, tracer.solver.L, st, None, tracer.bounds
        )

    done: dict[int, Bifurcation] = {}  # the non-smooth labels of one point share one location
    for r in bif.records(branch.points):
        if not st.refine:
            branch.bifurcations.append(r)
            continue
        if not r.smooth and r.index in done:
            d = done[r.index]
            names = ("converged", "change", "steps_per_period", "refinements", "multiplier_converged")
            shared = {k: getattr(d, k) for k in names}
            branch.bifurcations.append(replace(r, **shared, converged_ok=d.converged_ok))
            continue
        try:
            out = refine(
                r,
                branch.points,
                make,
                branch.steps_per_period,
                st.refine_tolerance,
                st.max_refinements,
            )
        except (SimulationInputError, np.linalg.LinAlgError, FloatingPointError, ValueError):
            out = r
        if not r.smooth:
            done[r.index] = out
        twin = _same_converged(branch.bifurcations, out, st.refine_tolerance)
        if twin is not None:
            # two sign changes of one test at the branch's step (a multiplier lingering at its
            # value) that refine to one location are one bifurcation
            _unlabel(branch, out.index, out.label)
            continue
        branch.bifurcations.append(out)
    return branch


def _same_converged(done: list[Bifurcation], r: Bifurcation, tolerance: float) -> Bifurcation | None:
    """The smooth bifurcation of ``r``'s kind already recorded on the same contact structure, with
    no event between them, whose converged location is ``r``'s (within twice the refinement
    tolerance), or ``None``."""
    if not (r.smooth and r.converged_ok):
        return None
    for j, q in enumerate(done):
        same = q.smooth and q.converged_ok and q.label == r.label and q.contact_after == r.contact_after
        between = any(not x.smooth for x in done[j + 1 :])
        if same and not between and abs(q.converged - r.converged) <= 2.0 * tolerance * abs(r.converged):
            return q
    return None


def _followed_range(param: str, lo: float, hi: float) -> tuple[float, float]:
    """Where a switched branch is followed when it leaves the range ``[lo, hi]``: the range's
    width beyond it on either side where the map's time step (chosen for the range: steps per
    period from the lowest frequency, the contact scale from the largest force) still holds, so
    the gap both ways, the frequency upwards, the force downwards, none below zero."""
    width = hi - lo
    below = max(lo - width, 0.0)
    if param == "gap":
        return below, hi + width
    if param == "fe":
        return lo, hi + width
    return below, hi


def _fixed(point: BranchPoint) -> tuple[float, float, float]:
    f = point.forcing
    return f.fe, f.force, f.gap


def trace(
    system: ReducedSystem,
    param: str,
    start: float,
    stop: float,
    *,
    fe: float = 60.0,
    force: float = 15.0,
    gap: float = 0.7e-3,
    shaker: ShakerDrive | None = None,
    switch: bool = True,
    settings: ContinuationSettings | None = None,
    progress: Callable[[int, float], None] | None = None,
    found: list[Branch] | None = None,
) -> list[Branch]:
    """The period-1 branch over ``[start, stop]`` and, with ``switch``, the period-2 branch born
    at each of its period doublings (:func:`continue_orbits`, :func:`switch_period_doubling`).

    A period-2 branch that cannot be started is returned empty with ``status = "failed"`` and
    the reason in its ``message``. Period doublings within :data:`PD_CLUSTER` of the range of each
    other are one (the best located is switched at); the one nearest to where an earlier
    period-2 branch merged is not switched at again. ``found``: the branches are appended to
    this list as they start and grow there point by point (see :func:`continue_orbits`).
    """
    branches: list[Branch] = [] if found is None else found
    main = continue_orbits(
        system,
        param,
        start,
        stop,
        fe=fe,
        force=force,
        gap=gap,
        shaker=shaker,
        settings=settings,
        progress=progress,
        found=branches,
    )
    if not switch:
        return list(branches)
    clusters = _clusters(main.labelled(PERIOD_DOUBLING), PD_CLUSTER * abs(stop - start))
    spans = [(min(q.value for q in c), max(q.value for q in c)) for c in clusters]
    done: set[int] = set()
    for i, cluster in enumerate(clusters):
        # a period-2 branch that returns onto the period-1 branch does so at a period doubling:
        # the one nearest to where it merged is covered by it
        if i in done:
            continue
        p = min(cluster, key=lambda q: float(np.min(np.abs(q.multipliers + 1.0))))
        try:
            b = switch_period_doubling(
                system, p, start, stop, shaker=shaker, settings=settings, progress=progress, found=branches
            )
        except ContinuationError as exc:
            b = Branch(
                param=param,
                periods=2,
                status="failed",
                message=str(exc),
                steps_per_period=main.steps_per_period,
            )
            branches.append(b)
        if b.points and b.status == "merged":
            m = b.points[-1].value
            done.add(min(range(len(spans)), key=lambda j: max(spans[j][0] - m, m - spans[j][1], 0.0)))
    return list(branches)


def initial_state(
    system: ReducedSystem, point: BranchPoint, *, shaker: ShakerDrive | None = None
) -> RunState:
    """The orbit of ``point`` as the state a time integration starts from (``initial`` of
    :func:`rigtools.sim.vibro_impact.run_harmonic` and the study runners): its modal state at
    force phase zero with the loads the kernel carries, so that a run started there and forced
    at the point's frequency and amplitude (``run_harmonic(system.with_contact(gap=...), fe,
    force, initial=initial_state(system, point))``) stays on the orbit if it is stable.
    """
    pmap = PeriodMap(system, 1, point.periods, shaker)
    x = np.asarray(point.state, dtype=float)
    n = pmap.n_modes
    scalars = pmap._scalars(x, point.forcing.gap)
    return RunState(StepperState(x[:n].copy(), x[n : 2 * n].copy(), scalars, 0.0), 0.0)


def _clusters(points: list[BranchPoint], tol: float) -> list[list[BranchPoint]]:
    """Consecutive points (branch order) within ``tol`` of the one before, grouped."""
    out: list[list[BranchPoint]] = []
    for p in points:
        if out and abs(p.value - out[-1][-1].value) <= tol:
            out[-1].append(p)
        else:
            out.append([p])
    return out


def orbit_at(
    system: ReducedSystem, branch: Branch, value: float, *, shaker: ShakerDrive | None = None
) -> list[BranchPoint]:
    """Every orbit of ``branch`` at the parameter ``value``: Newton at that value from each pair
    of consecutive points that brackets it (with the branch's steps per period and periods).

    Returns the converged points in branch order (a branch that folds holds several).
    """
    pts = branch.points
    if not pts:
        return []
    pmap = PeriodMap(system, branch.steps_per_period, branch.periods, shaker)
    v = np.array([p.value for p in pts])
    out: list[BranchPoint] = []
    for i in range(len(pts) - 1):
        if (v[i] - value) * (v[i + 1] - value) > 0 or v[i] == v[i + 1]:
            continue
        w = (value - v[i]) / (v[i + 1] - v[i])
        y0 = (pts[i].state + w * (pts[i + 1].state - pts[i].state)) * pmap.scale
        forcing = pts[i].forcing.with_value(branch.param, value)
        solver = _Solver(pmap, branch.param, forcing, max(float(np.linalg.norm(y0)), 1e-12), 1.0)
        res = solver.fixed(y0, value)
        if res is None:
            continue
        sol = solver.finish(res[0], value, res[1])
        point = _point(pmap, branch.param, sol, forcing, 0.0)
        if not any(np.allclose(point.state, o.state, rtol=1e-6, atol=1e-12) for o in out):
            out.append(point)
    return out
