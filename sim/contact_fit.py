"""Contact from impacts: fit the shroud contact's stiffness and damping to the harmonic content of
force-controlled dwells (or the points of a gap study), with the vibro-impact integrator in the loop.

Each target is one dwell: excitation frequency ``fe``, force amplitude ``F0`` (the fundamental of
the force into the blade), gap, and the measured acceleration amplitudes of the harmonics
``k = 1..K`` at the shrouds. The model runs :func:`rigtools.sim.vibro_impact.run_harmonic` on the reduced
system of the (linearly updated) rig with the trial contact, from rest to its periodic steady
state, and takes the same harmonics from whole periods of the shroud velocities (``k w |V_k|``:
the velocity is continuous at an impact, the acceleration is not).

Residuals are ``ln(A_model / A_target) / sigma`` per harmonic and location, over the harmonics
above ``floor`` times the largest of their location (the rest is noise on a real rig). The fit is
:func:`scipy.optimize.least_squares` in ``ln k_c`` and ``ln c_c`` with bounds; the time step is
fixed over the fit (sized for the stiffest contact the bounds allow), so that a trial change of the
stiffness does not also change the discretisation. Identifiability is reported as in
:mod:`rigtools.sim.parameter_fit`. ``law="hertz"`` fits a Hertz contact instead (stiffness in N/m^p), so the two
laws can be compared by their residuals.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
import scipy.optimize

from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL, PASSIVE_SHROUD_ACCEL
from rigtools.sim.fit_identifiability import (
    central_jacobian,
    forward_jacobian,
    identifiability,
)
from rigtools.sim.fit_parameters import UpdateParameter
from rigtools.sim.fit_results import FitResult
from rigtools.sim.params import ContactLaw, ContactParams, RigParams
from rigtools.sim.reduction import ReducedSystem, reduced_system
from rigtools.sim.vibro_impact import run_harmonic, steps_per_period_for

LOCATIONS = {ACTIVE_SHROUD_ACCEL: "active_tip_velocity", PASSIVE_SHROUD_ACCEL: "passive_tip_velocity"}
# penetration at which a Hertz start is made equal in force to the linear contact it replaces
HERTZ_REFERENCE_PENETRATION = 1e-5  # m
# finite-difference step in ln k_c, ln c_c: the harmonics jitter by ~1e-4 (relative) from one trial
# contact to the next (impacts resolved on a fixed step), so steps of 0.1 % would differentiate noise
FD_STEP = 0.02

CONTACT_PARAMETERS: dict[str, UpdateParameter] = {
    p.name: p
    for p in (
        UpdateParameter(
            "contact.stiffness",
            "N/m (linear) or N/m^p (hertz)",
            "shroud contact stiffness",
            True,
            (0.1, 10.0),
            True,
            lambda p: p.contact.stiffness,
            lambda p, v: replace(p, contact=replace(p.contact, stiffness=v)),
        ),
        UpdateParameter(
            "contact.damping",
            "N*s/m",
            "shroud contact damping",
            True,
            (0.01, 100.0),
            True,
            lambda p: p.contact.damping,
            lambda p, v: replace(p, contact=replace(p.contact, damping=v)),
        ),
    )
}


@dataclass(frozen=True)
class HarmonicTarget:
    """The harmonic content of one settled dwell.

    Attributes
    ----------
    fe
        Excitation frequency, Hz.
    force_amplitude
        Force amplitude F0 (fundamental of the force into the active blade), N.
    gap
        Shroud gap, m.
    amplitudes
        Location (``"active_shroud_accel"``, ``"passive_shroud_accel"``) -> acceleration
        amplitudes (m/s^2, peak) of the harmonics ``k = 1, 2, ..., K``.
    sigma
        1-sigma uncertainty of ``ln A`` (relative amplitude); default 5 %.
    floor
        Harmonics below ``floor`` times the largest of their location are not fitted.
    """

    fe: float
    force_amplitude: float
    gap: float
    amplitudes: Mapping[str, np.ndarray]
    sigma: float = 0.05
    floor: float = 0.01

    def __post_init__(self) -> None:
        if not (self.fe > 0 and self.force_amplitude > 0 and self.gap >= 0):
            raise ValueError("harmonic target: fe and force must be > 0 and the gap >= 0")
        if not self.amplitudes:
            raise ValueError("harmonic target: give the amplitudes of at least one location")
        amps = {}
        for loc, a in self.amplitudes.items():
            if loc not in LOCATIONS:
                raise ValueError(f"harmonic target: location must be one of {tuple(LOCATIONS)}, got {loc!r}")
            a = np.atleast_1d(np.asarray(a, dtype=float))
            if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)) or np.any(a < 0):
                raise ValueError(f"harmonic target: amplitudes of {loc} must be finite and >= 0")
            amps[loc] = a
        if not (self.sigma > 0 and 0 <= self.floor < 1):
            raise ValueError("harmonic target: sigma must be > 0 and floor in [0, 1)")
        object.__setattr__(self, "amplitudes", amps)

    def mask(self, location: str) -> np.ndarray:
        """Which harmonics of ``location`` are fitted."""
        a = self.amplitudes[location]
        return a > self.floor * a.max() if a.max() > 0 else np.zeros(a.size, bool)


def harmonic_amplitudes(
    system: ReducedSystem,
    target: HarmonicTarget,
    *,
    steps_per_period: int | None = None,
    record_periods: int = 4,
    tol: float = 1e-7,
) -> tuple[dict[str, np.ndarray], bool]:
    """The model's shroud acceleration harmonics ``k = 1..K`` at a target's dwell.

    Returns
    -------
    amplitudes, steady
        Location -> amplitudes (m/s^2) of the harmonics the target holds; whether the run
        reached a periodic steady state.
    """
    run = run_harmonic(
        system.with_contact(gap=target.gap),
        target.fe,
        target.force_amplitude,
        record_periods=record_periods,
        steps_per_period=steps_per_period,
        tol=tol,
    )
    out = {}
    for loc, a in target.amplitudes.items():
        v = run.outputs[LOCATIONS[loc]]
        k = np.arange(1, a.size + 1)
        spec = np.fft.rfft(v) * 2.0 / v.size
        if k[-1] * record_periods >= spec.size:
            raise ValueError(f"harmonic {k[-1]} is beyond the model's sample rate at {target.fe} Hz")
        out[loc] = np.abs(spec[k * record_periods]) * 2.0 * np.pi * target.fe * k
    return out, bool(run.steady_state)


@dataclass
class ContactFitResult(FitResult):
    """The outcome of :func:`fit_contact` (the fields of :class:`rigtools.sim.fit_results.FitResult`
    as :class:`rigtools.sim.parameter_fit.UpdateResult` has them, and the contact law, the dwell
    harmonics before and after, whether the fitted run was steady, the vibro-impact runs)."""

    law: str
    harmonics_before: list[dict[str, np.ndarray]]
    harmonics_after: list[dict[str, np.ndarray]]
    steady: bool
    n_runs: int
    targets: list[HarmonicTarget] = field(default_factory=list)

    @property
    def rms_log_error_after(self) -> float:
        """RMS of ``ln(A_model / A_target)`` over the fitted harmonics after the fit."""
        sig = np.concatenate(
            [np.full(int(t.mask(loc).sum()), t.sigma) for t in self.targets for loc in t.amplitudes]
        )
        return float(np.sqrt(np.mean((self.residuals_after * sig) ** 2)))

    def rig_file_values(self) -> dict[str, float | str]:
        """Rig-file keys (``[contact]`` section) and SI values to write."""
        c = self.params.contact
        return {"contact.law": c.law, "contact.stiffness": c.stiffness, "contact.damping": c.damping}

    def as_dict(self) -> dict:
        """JSON-ready summary (plain floats, lists and strings)."""
        ident = self.identifiability
        return {
            "law": self.law,
            "parameters": self.parameter_entries(),
            "rig_file": self.rig_file_values(),
            "cost_before": self.cost_before,
            "cost_after": self.cost_after,
            "rms_log_error_after": self.rms_log_error_after,
            "steady": self.steady,
            "model_evaluations": self.n_evaluations,
            "vibro_impact_runs": self.n_runs,
            "wall_time_s": self.wall_time,
            "success": self.success,
            "message": self.message,
            "identifiability": {
                "rank": ident.rank,
                "condition": ident.condition,
                "unresolved": list(ident.unresolved),
            },
        }

    def report(self) -> str:
        """Plain-text report: fitted values with 95 % intervals, fit quality, identifiability."""
        ident = self.identifiability
        lines = [
            f"contact fit ({self.law} law): {len(self.names)} parameters, {len(self.targets)} dwells, "
            f"{len(self.residual_labels)} harmonics, {self.n_runs} vibro-impact runs, {self.wall_time:.1f} s"
            + ("" if self.success else f" (optimiser: {self.message})")
            + ("" if self.steady else " -- at the optimum, a run did not reach a periodic steady state")
        ]
        for n, u in zip(self.names, self.units, strict=True):
            lo, hi = ident.confidence[n]
            lines.append(
                f"{n:<20} start {self.initial[n]:<11.5g} fitted {self.fitted[n]:<11.5g} "
                f"95 % [{lo:.4g}, {hi:.4g}]  {u}"
            )
        rms0 = math.sqrt(2 * self.cost_before / max(1, self.residuals_before.size))
        rms1 = math.sqrt(2 * self.cost_after / max(1, self.residuals_after.size))
        lines.append(
            f"rms residual (in sigmas) before {rms0:.3g}, after {rms1:.3g}; "
            f"rms amplitude error after {100 * self.rms_log_error_after:.2f} %"
        )
        lines.append(f"Jacobian rank {ident.rank} of {len(self.names)}, condition {ident.condition:.3g}")
        if ident.unresolved:
            lines.append("the data cannot separate or determine:")
            lines += [f"  {line}" for line in ident.unresolved]
        return "\n".join(lines)


def _equivalent_contact(contact: ContactParams, law: ContactLaw) -> ContactParams:
    """``contact`` under another law, equal in spring and in damping force to it at
    :data:`HERTZ_REFERENCE_PENETRATION`: the stiffness is in N/m (linear) or N/m**p (Hertz,
    Hunt-Crossley), the damping in N*s/m, or N*s/m**(p+1) for Hunt-Crossley (``c g**p dg/dt``)."""
    ref, p = HERTZ_REFERENCE_PENETRATION, contact.hertz_exponent

    def spring(law: str) -> float:  # spring force per unit stiffness at the reference penetration
        return ref if law == "linear" else ref**p

    def damper(law: str) -> float:  # damping force per unit damping and unit speed there
        return ref**p if law == "hunt-crossley" else 1.0

    return replace(
        contact,
        law=law,
        stiffness=contact.stiffness * spring(contact.law) / spring(law),
        damping=contact.damping * damper(contact.law) / damper(law),
    )


#: first simplex step (ln units) of the derivative-free polish after the least-squares solve
POLISH_STEP = 0.02


def fit_contact(
    params: RigParams,
    targets: Sequence[HarmonicTarget],
    names: Sequence[str] = ("contact.stiffness", "contact.damping"),
    *,
    law: Literal["linear", "hertz"] | None = None,
    start: dict[str, float] | None = None,
    bounds: dict[str, tuple[float, float]] | None = None,
    system: ReducedSystem | None = None,
    record_periods: int = 4,
    steps_per_period: Sequence[int] | None = None,
    max_evaluations: int = 60,
) -> ContactFitResult:
    """Fit the contact's stiffness and/or damping to the harmonics of dwells with impacts.

    Parameters
    ----------
    params
        The rig (its linear part updated first, e.g. by :func:`rigtools.sim.parameter_fit.update_model`).
    targets
        :class:`HarmonicTarget` items (dwells, or the points of a gap study).
    names
        ``"contact.stiffness"``, ``"contact.damping"`` or both.
    law
        Contact law to fit (default: the rig's). A law other than the rig's starts from the
        stiffness and damping equal in force to the rig's at 10 um penetration (or ``start``).
    start, bounds
        By name; default bounds 0.1-10 times the start for the stiffness, 0.01-100 times for the
        damping (fitted in log scale).
    system
        The reduced linear system of ``params`` (default: built here).
    record_periods
        Whole periods per run from which the harmonics are taken.
    steps_per_period
        Integer steps per period, one per target (default: :func:`fit_steps_per_period`, fixed
        over the fit).
    max_evaluations
        Limit on the optimiser's function evaluations.

    Returns
    -------
    ContactFitResult
    """
    t0 = time.perf_counter()
    names, targets = _checked(names, targets)
    fit_law: ContactLaw = law if law is not None else params.contact.law
    base = params
    if fit_law != params.contact.law:
        base = replace(params, contact=_equivalent_contact(params.contact, fit_law))
    specs = [CONTACT_PARAMETERS[n] for n in names]
    v0, b_all = _start_and_bounds(base, names, specs, start or {}, bounds or {})
    for s, v in zip(specs, v0, strict=True):
        base = s.set(base, float(v))
    linear = system if system is not None else reduced_system(base, "fem")
    linear = replace(linear, contact=base.contact)
    k_max = b_all["contact.stiffness"][1] if "contact.stiffness" in names else base.contact.stiffness
    steps = (
        fit_steps_per_period(linear, targets, k_max)
        if steps_per_period is None
        else [int(n) for n in steps_per_period]
    )
    if len(steps) != len(targets):
        raise ValueError("give one steps_per_period per target")
    prob = _ContactProblem(base, linear, specs, v0, targets, steps, record_periods)
    x0 = np.zeros(len(names))
    lo = np.log(np.array([b_all[n][0] for n in names]) / v0)
    hi = np.log(np.array([b_all[n][1] for n in names]) / v0)
    lo, hi = np.minimum(lo, -1e-12), np.maximum(hi, 1e-12)
    r0, h0, _ = prob.evaluate(x0)
    x, sol = _minimise(prob.residuals, x0, lo, hi, max_evaluations)
    r1, h1, steady1 = prob.evaluate(x)
    ident = identifiability(central_jacobian(prob.residuals, x, lo, hi, FD_STEP), names, specs, x, v0, 1.0, 0)
    fitted = {n: float(v) for n, v in zip(names, prob.to_v(x), strict=True)}
    out_params = base
    for s, n in zip(specs, names, strict=True):
        out_params = s.set(out_params, fitted[n])
    return ContactFitResult(
        names=names,
        units=[CONTACT_PARAMETERS[n].unit for n in names],
        law=fit_law,
        initial={n: float(v) for n, v in zip(names, v0, strict=True)},
        fitted=fitted,
        bounds=b_all,
        params=out_params,
        residual_labels=_residual_labels(targets),
        residuals_before=r0,
        residuals_after=r1,
        harmonics_before=h0,
        harmonics_after=h1,
        steady=bool(steady1),
        n_evaluations=prob.n_evaluations,
        n_runs=prob.n_runs,
        wall_time=time.perf_counter() - t0,
        success=bool(sol.success),
        message=str(sol.message),
        identifiability=ident,
        targets=targets,
    )


def _checked(
    names: Sequence[str], targets: Sequence[HarmonicTarget]
) -> tuple[list[str], list[HarmonicTarget]]:
    """The names (duplicates dropped) and targets of a contact fit, or a one-line ``ValueError``."""
    names = list(dict.fromkeys(names))
    if not names or any(n not in CONTACT_PARAMETERS for n in names):
        bad = [n for n in names if n not in CONTACT_PARAMETERS]
        raise ValueError(
            f"unknown contact parameter {bad[0] if bad else ''!r} (known: {', '.join(CONTACT_PARAMETERS)})"
        )
    targets = list(targets)
    if not targets:
        raise ValueError("give at least one dwell target")
    return names, targets


def _start_and_bounds(
    base: RigParams,
    names: list[str],
    specs: list[UpdateParameter],
    start: dict[str, float],
    bounds: dict[str, tuple[float, float]],
) -> tuple[np.ndarray, dict[str, tuple[float, float]]]:
    """Start values (clipped into the bounds) and bounds by name (default: the parameter's)."""
    v0 = np.array([float(start.get(n, s.get(base))) for n, s in zip(names, specs, strict=True)])
    if np.any(v0 <= 0):
        raise ValueError("contact stiffness and damping must start > 0 to be fitted in log scale")
    b_all: dict[str, tuple[float, float]] = {}
    for n, s, v in zip(names, specs, v0, strict=True):
        lo_n, hi_n = bounds.get(n, s.default_bounds(v))
        b_all[n] = (float(lo_n), float(hi_n))
    for n, (lo_n, hi_n) in b_all.items():
        if not 0 < lo_n < hi_n:
            raise ValueError(f"{n}: bounds ({lo_n}, {hi_n}) must satisfy 0 < low < high")
    v0 = np.array([min(max(v, b_all[n][0]), b_all[n][1]) for n, v in zip(names, v0, strict=True)])
    return v0, b_all


class _ContactProblem:
    """The fit's residuals at scaled values ``x = ln(v / v0)``: one settled run per target, each
    ``x`` evaluated once (cached), the evaluations and runs counted."""

    def __init__(
        self,
        base: RigParams,
        linear: ReducedSystem,
        specs: list[UpdateParameter],
        v0: np.ndarray,
        targets: list[HarmonicTarget],
        steps: list[int],
        record_periods: int,
    ) -> None:
        self.base, self.linear, self.specs, self.v0 = base, linear, specs, v0
        self.targets, self.steps, self.record_periods = targets, steps, record_periods
        self.n_evaluations = 0
        self.n_runs = 0
        self._cache: dict[bytes, tuple[np.ndarray, list[dict[str, np.ndarray]], bool]] = {}

    def to_v(self, x: np.ndarray) -> np.ndarray:
        return self.v0 * np.exp(x)

    def system_at(self, x: np.ndarray) -> ReducedSystem:
        p = self.base
        for s, v in zip(self.specs, self.to_v(x), strict=True):
            p = s.set(p, float(v))
        return replace(self.linear, contact=p.contact)

    def evaluate(self, x: np.ndarray) -> tuple[np.ndarray, list[dict[str, np.ndarray]], bool]:
        """``(residuals, harmonics per target, every run steady)`` at ``x``."""
        key = np.asarray(x, dtype=float).tobytes()
        if key not in self._cache:
            self.n_evaluations += 1
            sysx = self.system_at(x)
            res, harms, all_steady = [], [], True
            for t, n in zip(self.targets, self.steps, strict=True):
                amps, steady = harmonic_amplitudes(
                    sysx, t, steps_per_period=n, record_periods=self.record_periods
                )
                self.n_runs += 1
                all_steady &= steady
                harms.append(amps)
                for loc, a in t.amplitudes.items():
                    m = t.mask(loc)
                    res.append(np.log(np.maximum(amps[loc][m], 1e-300) / a[m]) / t.sigma)
            self._cache[key] = (np.concatenate(res), harms, all_steady)
        return self._cache[key]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        return self.evaluate(x)[0]


def _minimise(
    residuals: Callable[[np.ndarray], np.ndarray],
    x0: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    max_evaluations: int,
) -> tuple[np.ndarray, scipy.optimize.OptimizeResult]:
    """Least squares from ``x0`` within ``[lo, hi]``, then a derivative-free polish; ``(x, the
    least-squares result)``.

    The harmonics of a vibro-impact orbit are a slightly jittery function of the contact (impact
    times fall between time steps): finite-difference gradients can stop the trust region short
    of the minimum (the model's last bits alone moved the fitted damping by up to 21 %). A
    derivative-free polish from there, on a simplex of :data:`POLISH_STEP` steps, finishes the
    descent.
    """
    sol = scipy.optimize.least_squares(
        residuals,
        x0,
        jac=lambda x: forward_jacobian(residuals, x, hi, FD_STEP),
        bounds=(lo, hi),
        method="trf",
        x_scale=1.0,
        max_nfev=max_evaluations,
        xtol=1e-8,
        ftol=1e-8,
        gtol=1e-8,
    )
    x = sol.x
    polish = scipy.optimize.minimize(
        lambda x: 0.5 * float(np.sum(residuals(x) ** 2)),
        x,
        method="Nelder-Mead",
        bounds=list(zip(lo, hi, strict=True)),
        options={
            "initial_simplex": np.vstack([x, x + POLISH_STEP * np.eye(x.size)]),
            "xatol": 1e-5,
            "fatol": 1e-12,
            "maxfev": max_evaluations,
        },
    )
    if polish.fun < sol.cost:
        x = polish.x
    return x, sol


def _residual_labels(targets: list[HarmonicTarget]) -> list[str]:
    """One label per residual, in the residuals' order."""
    return [
        f"{t.fe:g} Hz {t.force_amplitude:g} N gap {1e3 * t.gap:g} mm {loc} k={k}"
        for t in targets
        for loc in t.amplitudes
        for k in np.flatnonzero(t.mask(loc)) + 1
    ]


def fit_steps_per_period(
    system: ReducedSystem, targets: Sequence[HarmonicTarget], stiffness_max: float
) -> list[int]:
    """Steps per period per target that resolve the stiffest contact a fit may try."""
    stiff = system.with_contact(stiffness=stiffness_max)
    return [
        steps_per_period_for(
            stiff.with_contact(gap=t.gap), t.fe, force_scale=max(100.0, 10 * t.force_amplitude)
        )
        for t in targets
    ]


def targets_from_model(
    params: RigParams,
    dwells: Sequence[tuple[float, float, float]],
    n_harmonics: int = 10,
    *,
    system: ReducedSystem | None = None,
    steps_per_period: Sequence[int] | None = None,
    **target_kwargs,
) -> list[HarmonicTarget]:
    """Synthetic targets: the model's own harmonics at the dwells ``(fe, F0, gap)`` (a known contact),
    at the given steps per period (default: the integrator's own choice)."""
    system = system if system is not None else reduced_system(params, "fem")
    system = replace(system, contact=params.contact)
    out = []
    steps = steps_per_period if steps_per_period is not None else [None] * len(dwells)
    for (fe, f0, gap), n in zip(dwells, steps, strict=True):
        probe = HarmonicTarget(fe, f0, gap, {loc: np.ones(n_harmonics) for loc in LOCATIONS})
        amps, _ = harmonic_amplitudes(system, probe, steps_per_period=n)
        out.append(HarmonicTarget(fe, f0, gap, amps, **target_kwargs))
    return out
