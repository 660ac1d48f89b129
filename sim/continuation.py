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
impacts begin or end (:meth:`rigtools.sim.orbit_tracer.BranchTracer.cross_grazing_corner`), or at a hairpin where a sheet with
one more impact meets one without it (:meth:`rigtools.sim.orbit_tracer.BranchTracer.turn_at_hairpin`: labelled fold and
grazing). At a period doubling, :func:`switch_period_doubling` starts the period-2 branch (the map
over two periods has a pitchfork there; its new direction is the -1 eigenvector); a switched
branch is followed out of the range and back (:func:`rigtools.sim.branch_switching.followed_range`). A point that does not
converge is reported (``Branch.status``, ``Branch.message``) and the branch ends at the last good
point.

This module is the public entry (:func:`trace`, :func:`continue_orbits`, :func:`orbit_at`,
:func:`initial_state`; every name below is importable from it). The parts, in the order a branch
uses them:

* :mod:`rigtools.sim.orbit_map`: the shooting map :class:`PeriodMap`, :class:`Forcing`,
  :class:`ShakerDrive`, :class:`OrbitMeasures`;
* :mod:`rigtools.sim.orbit_solver`: Newton and the arclength corrector, one orbit
  (:func:`solve_orbit`), its Floquet multipliers;
* :mod:`rigtools.sim.branch_points`: the result, :class:`Branch` and :class:`BranchPoint`, and
  the labels;
* :mod:`rigtools.sim.orbit_events`: the contact events and smooth bifurcations between two orbits;
* :mod:`rigtools.sim.orbit_tracer`: the tracer that follows one branch
  (:class:`ContinuationSettings`);
* :mod:`rigtools.sim.branch_switching`: the period-2 branch at a period doubling
  (:func:`switch_period_doubling`) and a finished branch's labels and refined bifurcations.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rigtools.sim.bifurcations import FOLD, NEIMARK_SACKER, PERIOD_DOUBLING
from rigtools.sim.branch_points import BIFURCATIONS, END, FAILED, START, SWITCH, Branch, BranchPoint
from rigtools.sim.branch_switching import finish_branch, switch_period_doubling
from rigtools.sim.contact_events import CONTACT_SPLIT, GRAZING, STICKING
from rigtools.sim.orbit_events import EVENT_BRACKET
from rigtools.sim.orbit_map import (
    FD_RELATIVE_STEP,
    N_HARMONICS,
    PARAMETERS,
    UNITS,
    ContinuationError,
    Forcing,
    OrbitMeasures,
    PeriodMap,
    ShakerDrive,
    map_for_range,
)
from rigtools.sim.orbit_solver import Solver, orbit_point, solve_orbit
from rigtools.sim.orbit_tracer import CLOSURE_TOLERANCE, GRAZING_TOLERANCE, BranchTracer, ContinuationSettings
from rigtools.sim.reduction import ReducedSystem
from rigtools.sim.vibro_impact import RunState, StepperState

__all__ = [
    "BIFURCATIONS",
    "CLOSURE_TOLERANCE",
    "CONTACT_SPLIT",
    "END",
    "EVENT_BRACKET",
    "FAILED",
    "FD_RELATIVE_STEP",
    "FOLD",
    "GRAZING",
    "GRAZING_TOLERANCE",
    "NEIMARK_SACKER",
    "N_HARMONICS",
    "PARAMETERS",
    "PD_CLUSTER",
    "PERIOD_DOUBLING",
    "START",
    "STICKING",
    "SWITCH",
    "UNITS",
    "Branch",
    "BranchPoint",
    "ContinuationError",
    "ContinuationSettings",
    "Forcing",
    "OrbitMeasures",
    "PeriodMap",
    "ShakerDrive",
    "continue_orbits",
    "initial_state",
    "orbit_at",
    "solve_orbit",
    "switch_period_doubling",
    "trace",
]

# period doublings closer than this (fraction of the range) are one: a multiplier lingering at -1
# makes det(M + I) change sign several times; one period-2 branch is switched onto per cluster
PD_CLUSTER = 1e-2


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

    Examples
    --------
    The periodic orbits of the default rig from 58 to 62 Hz at 15 N with a 5 mm gap (no impact: every
    orbit stable, the branch reaches its end):

    >>> import rigtools
    >>> from rigtools.sim.continuation import continue_orbits
    >>> from rigtools.sim.reduction import reduced_system
    >>> system = reduced_system(rigtools.load_rig().to_params(), "fem")
    >>> branch = continue_orbits(system, "fe", 58.0, 62.0, force=15.0, gap=5e-3)
    >>> branch.status, branch.values()[[0, -1]], bool(branch.stable().all())
    ('complete', array([58., 62.]), True)
    """
    settings = settings or ContinuationSettings()
    pmap, forcing = map_for_range(
        system, param, start, stop, fe, force, gap, periods, shaker, settings.steps_per_period
    )
    tracer = BranchTracer(pmap, param, forcing, stop, abs(stop - start), settings, progress, (start, stop))
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
    return finish_branch(tracer, branch)


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
    scalars = pmap.carried_loads(x, point.forcing.gap)
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
        solver = Solver(pmap, branch.param, forcing, max(float(np.linalg.norm(y0)), 1e-12), 1.0)
        res = solver.fixed(y0, value)
        if res is None:
            continue
        sol = solver.finish(res[0], value, res[1])
        point = orbit_point(pmap, branch.param, sol, forcing, 0.0)
        if not any(np.allclose(point.state, o.state, rtol=1e-6, atol=1e-12) for o in out):
            out.append(point)
    return out
