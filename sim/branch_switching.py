"""Switching onto the period-2 branch at a period doubling (:func:`switch_period_doubling`) and
finishing a branch (:func:`finish_branch`: its turning points labelled fold, every bifurcation
recorded and relocated at a converged time step, :mod:`rigtools.sim.bifurcation_refine`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from rigtools.sim import bifurcations as bif
from rigtools.sim.bifurcation_refine import refine
from rigtools.sim.bifurcations import Bifurcation
from rigtools.sim.branch_points import SWITCH, Branch, BranchPoint, relabel, unlabel
from rigtools.sim.orbit_events import period_one_distance
from rigtools.sim.orbit_map import UNITS, ContinuationError, ShakerDrive, map_for_range
from rigtools.sim.orbit_solver import Entry
from rigtools.sim.orbit_tracer import BranchTracer, ContinuationSettings
from rigtools.sim.reduction import ReducedSystem
from rigtools.sim.vibro_impact import SimulationInputError


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
    f = point.forcing
    pmap1, _ = map_for_range(
        system, param, start, stop, f.fe, f.force, f.gap, 1, shaker, settings.steps_per_period
    )
    pmap = pmap1.with_periods(2)
    y_pd = point.state * pmap.scale
    _, jac1, _ = pmap1.jacobian(y_pd, point.forcing)
    k = pmap1.n_physical  # under force control the drive does not take part (the doubled
    # orbit's force fundamental changes at second order only)
    mu, vecs = np.linalg.eig(jac1[:k, :k])
    j = int(np.argmin(np.abs(mu + 1.0)))
    v = np.concatenate([vecs[:, j].real, np.zeros(y_pd.size - k)])
    v /= np.linalg.norm(v)
    followed = followed_range(param, lo, hi)
    tracer = BranchTracer(pmap, param, point.forcing, stop, hi - lo, settings, progress, followed, (lo, hi))
    solver = tracer.solver
    solver.Y = max(float(np.linalg.norm(y_pd)), 1e-12)
    tracer.y_floor = 0.1 * solver.Y
    direction = np.concatenate([v, [0.0]])
    h = offset
    first: Entry | None = None
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
            if period_one_distance(e) > 1e-4:
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
    return finish_branch(tracer, branch)


def finish_branch(tracer: BranchTracer, branch: Branch) -> Branch:
    """Label the branch's turning points ``fold`` (:func:`rigtools.sim.bifurcations.mark_turning_points`)
    and record every bifurcation and event (``bifurcations`` of :class:`rigtools.sim.continuation.Branch`), each relocated at a
    converged time step unless ``settings.refine`` is off (a failure there keeps it unrefined)."""
    bif.merge_hairpin_grazing(branch.points, lambda i, label: unlabel(branch, i, label))
    bif.mark_turning_points(
        branch.points,
        lambda i, label: relabel(branch, i, label),
        lambda i, label: unlabel(branch, i, label),
    )
    st = tracer.settings

    def make(n: int) -> BranchTracer:
        pmap = tracer.pmap.with_steps(n)
        return BranchTracer(
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
        twin = same_converged(branch.bifurcations, out, st.refine_tolerance)
        if twin is not None:
            # two sign changes of one test at the branch's step (a multiplier lingering at its
            # value) that refine to one location are one bifurcation
            unlabel(branch, out.index, out.label)
            continue
        branch.bifurcations.append(out)
    return branch


def same_converged(done: list[Bifurcation], r: Bifurcation, tolerance: float) -> Bifurcation | None:
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


def followed_range(param: str, lo: float, hi: float) -> tuple[float, float]:
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
