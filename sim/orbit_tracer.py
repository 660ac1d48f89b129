"""The tracer that follows one branch of periodic orbits (:class:`BranchTracer`).

Pseudo-arclength continuation in the scaled vector ``(y / Y, lambda / L)`` (``y`` the state with
displacements times their mode's frequency, ``Y`` its size, ``L`` the parameter range): a tangent
predictor, a chord-Newton corrector on the arclength plane (:class:`rigtools.sim.orbit_solver.Solver`),
step control on the iteration count. Between consecutive points the labels are located by
:class:`rigtools.sim.orbit_events.EventSearch`. Where an impact grazes the map has a kink and the
branch may turn sharply: past a grazing where impacts begin or end
(:meth:`BranchTracer.cross_grazing_corner`), or at a hairpin where a sheet with one more impact
meets one without it (:meth:`BranchTracer.turn_at_hairpin`: labelled fold and grazing). A point
that does not converge ends the branch at the last good point (``Branch.status``, ``message``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from rigtools.sim.bifurcation_refine import MAX_REFINEMENTS, REFINE_TOLERANCE
from rigtools.sim.bifurcations import FOLD
from rigtools.sim.branch_points import END, FAILED, Branch, relabel
from rigtools.sim.contact_events import GRAZING
from rigtools.sim.orbit_events import EventSearch, grazing_margin, half_difference, period_one_distance
from rigtools.sim.orbit_map import UNITS, Forcing, PeriodMap
from rigtools.sim.orbit_solver import Entry, Solution, Solver, orbit_point
from rigtools.sim.vibro_impact import SimulationInputError

# a branch passing this close to its first point (scaled arclength units) has closed
CLOSURE_TOLERANCE = 2e-3
# a closure maximum this close to the gap (relative to the tip amplitude) grazes
GRAZING_TOLERANCE = 1e-3


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


class BranchTracer:
    """Follows one branch on a :class:`rigtools.sim.orbit_map.PeriodMap` by pseudo-arclength steps
    (:meth:`run`), with step control, the turns at grazings, the end of the range and, for a
    switched branch, the excursions out of the range asked for (``window``)."""

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
        self.solver = Solver(pmap, param, forcing, 1.0, lam_scale)
        self.y_floor = 1e-12
        self._left_start = False

    def entry(self, sol: Solution, tangent: np.ndarray, labels: Sequence[str] = ()) -> Entry:
        """The entry of a converged orbit with its tangent (its branch point labelled ``labels``)."""
        return Entry(sol, tangent, orbit_point(self.pmap, self.param, sol, self.forcing, tangent[-1], labels))

    def enter(self, state: np.ndarray, value: float) -> Entry | None:
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
            t = s.tangent(Solution(y, value, fy, jac, dpar, np.empty((0, 0)), 0), None)
            res = s.arclength(s.scaled(y, value), t, jac, dpar) or s.arclength(
                s.scaled(y, value), t, None, None, full=True
            )
            if res is None:
                return None
            sol = s.finish(*res)
            return self.entry(sol, s.tangent(sol, t))
        except (SimulationInputError, np.linalg.LinAlgError):
            return None

    def correct(self, prev: Entry, h: float) -> Entry | None:
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

    def run(self, first: Entry, branch: Branch, direction_sign: float) -> Branch:
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
                relabel(branch, -1, FAILED)
            return branch
        except KeyboardInterrupt:
            # the caller may keep the points followed so far (``found`` of :func:`rigtools.sim.continuation.trace`)
            branch.status = "interrupted"
            if branch.points:
                branch.message = (
                    f"interrupted after {self.param} = {branch.points[-1].value:.6g} "
                    f"{UNITS[self.param]}; the branch ends at the last point computed"
                )
            raise

    def _follow(self, first: Entry, branch: Branch, direction_sign: float) -> Branch:
        """Step along the branch from ``first`` until it ends (the status and message say how)."""
        st = self.settings
        h_max = st.max_step if st.max_step is not None else 1.0 / 50.0
        h = st.initial_step if st.initial_step is not None else h_max / 5.0
        h_max = max(h_max, h)
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
                h_next = self._after_failed_step(entries, branch, h, h_max)
                if h_next is None:
                    break
                h = h_next
                continue
            at_edge = self._window_crossing(prev, nxt, h, entries, branch)
            if at_edge is not None:
                if at_edge:
                    break
                continue
            if self._leaves(prev, nxt, h, entries, branch, direction_sign):
                break
            if self._take(first, prev, nxt, h, h_max, entries, branch):
                break
            # step control on the corrector's work
            it = nxt.sol.iterations
            if it <= 3:
                h = min(h * 1.5, h_max)
            elif it > 6:
                h *= 0.5
        return branch

    def _range(self) -> tuple[float, float, float]:
        """``(lo, hi, margin)``: the bounds the branch is followed within, and the tolerance on them."""
        lo, hi = min(self.bounds), max(self.bounds)
        return lo, hi, 1e-9 * abs(self.bounds[1] - self.bounds[0])

    def _after_failed_step(
        self, entries: list[Entry], branch: Branch, h: float, h_max: float
    ) -> float | None:
        """The next step after the corrector failed at ``h``: half of it; below the smallest step,
        the turn at a grazing hairpin or the jump across a grazing corner (then a tenth of the
        largest step); ``None`` where neither applies (the branch has failed)."""
        st = self.settings
        prev = entries[-1]
        h *= 0.5
        if h < st.min_step and len(entries) > 1:
            if self.turn_at_hairpin(entries, branch):
                return h_max / 10.0
            corner = self.cross_grazing_corner(entries)
            if corner is not None:
                self._detect(prev, corner, branch)
                entries.append(corner)
                branch.points.append(corner.point)
                return h_max / 10.0
        if h < st.min_step:
            branch.status = "failed"
            branch.message = (
                f"no convergence past {self.param} = {prev.sol.lam:.6g} {UNITS[self.param]} "
                f"(step below {st.min_step:g}); the branch ends at the last good point"
            )
            relabel(branch, -1, FAILED)
            return None
        return h

    def _window_crossing(
        self, prev: Entry, nxt: Entry, h: float, entries: list[Entry], branch: Branch
    ) -> bool | None:
        """A switched branch's step ``prev -> nxt`` across an edge of the range asked for: the orbit
        at the edge appended; ``True`` if that was its third crossing (the branch ends), ``False``
        if it goes on from the edge, ``None`` if the step crosses no edge (or none converged)."""
        lo, hi, margin = self._range()
        lam_next = nxt.sol.lam
        if self.window is None or lam_next < lo - margin or lam_next > hi + margin:
            return None
        edge = self.window_edge(prev, nxt, h, branch)
        if edge is None:
            return None
        entries.append(edge)
        branch.points.append(edge.point)
        if len(self._crossings) >= 3:  # out, back in, and out again: the end
            relabel(branch, -1, END)
            branch.message = self._excursion_message()
            return True
        return False

    def _leaves(
        self, prev: Entry, nxt: Entry, h: float, entries: list[Entry], branch: Branch, direction_sign: float
    ) -> bool:
        """``True`` if the step ``prev -> nxt`` ends the branch: past its end value or out of its
        bounds (the orbit there appended, ``_end_at``), or a period-2 branch crossing onto the
        period-1 one."""
        lo, hi, margin = self._range()
        lam_next = nxt.sol.lam
        past_end = self.window is None and (lam_next - self.stop) * direction_sign > 0
        outside = lam_next < lo - margin or lam_next > hi + margin
        if past_end or outside:
            self._end_at(prev, nxt, h, entries, branch, past_end)
            return True
        if self.pmap.periods > 1 and half_difference(prev) @ half_difference(nxt) < 0:
            # through a period doubling of the period-1 branch (the map over two periods has a
            # pitchfork there; the step is the orbit crossing onto its own shift by a period)
            branch.status = "merged"
            branch.message = (
                f"the period-{self.pmap.periods} orbit returned onto the period-1 branch between "
                f"{self.param} = {prev.sol.lam:.6g} and {nxt.sol.lam:.6g} {UNITS[self.param]}"
            )
            relabel(branch, -1, END)
            return True
        return False

    def _end_at(
        self, prev: Entry, nxt: Entry, h: float, entries: list[Entry], branch: Branch, past_end: bool
    ) -> None:
        """End the branch at its end value (``past_end``) or at the bound the step left through:
        the orbit exactly there, by Newton at fixed parameter from the interpolated state."""
        lo, hi, _ = self._range()
        lam_next = nxt.sol.lam
        target = self.stop if past_end else (lo if lam_next < lo else hi)
        w = (target - prev.sol.lam) / (lam_next - prev.sol.lam)
        y0 = prev.sol.y + w * (nxt.sol.y - prev.sol.y)
        res = self.solver.fixed(y0, target, prev.sol.jac)
        if res is None:
            branch.status = "failed"
            branch.message = f"no orbit at the end value {target:.6g} {UNITS[self.param]}"
            relabel(branch, -1, FAILED)
            return
        sol = self.solver.finish(res[0], target, res[1])
        t = self.solver.tangent(sol, prev.tangent)
        end = self.entry(sol, t)
        self._detect(prev, end, branch)
        entries.append(end)
        branch.points.append(end.point)
        relabel(branch, -1, END)
        if not past_end:
            branch.status = "left range"
            branch.message = self._left_range_message(prev, target)

    def _left_range_message(self, prev: Entry, target: float) -> str:
        """Where and how the branch left its bounds at ``target`` (a switched branch: the crossing
        of the range asked for recorded if this step made it)."""
        u = UNITS[self.param]
        if self.window is None:
            return f"the branch turned back and left the range at {target:.6g} {u}"
        if target in self.window:
            # the range asked for ends here on this side too (fe is followed upwards only, force
            # downwards only): left in one step, from inside
            return f"the branch left the range at {target:.6g} {u}, where it is followed no further"
        if min(self.window) <= prev.sol.lam <= max(self.window):
            # out of the range asked for and of the bounds in this one step
            self._crossings.append(min(self.window) if target < prev.sol.lam else max(self.window))
        return (
            f"the branch left the range at {self._crossings[-1]:.6g} {u} and had not returned at "
            f"{target:.6g} {u}, where it is followed no further"
        )

    def _take(
        self,
        first: Entry,
        prev: Entry,
        nxt: Entry,
        h: float,
        h_max: float,
        entries: list[Entry],
        branch: Branch,
    ) -> bool:
        """Append ``nxt`` (and the labels located since ``prev``); ``True`` if the branch ends there:
        closed on itself, or a period-2 orbit back on the period-1 branch."""
        self._detect(prev, nxt, branch)
        entries.append(nxt)
        branch.points.append(nxt.point)
        if self._closes(first, prev, nxt, h_max):
            branch.points.append(replace(first.point, labels=(END,)))
            branch.status = "closed"
            branch.message = (
                f"the branch closed on itself: back at its first orbit, {self.param} = "
                f"{first.sol.lam:.6g} {UNITS[self.param]}"
            )
            return True
        self._rescale(nxt)
        if self.pmap.periods > 1 and len(branch.points) > 5 and period_one_distance(nxt) < 1e-5:
            branch.status = "merged"
            branch.message = (
                f"the period-{self.pmap.periods} orbit returned onto the period-1 branch at "
                f"{self.param} = {nxt.sol.lam:.6g} {UNITS[self.param]}"
            )
            relabel(branch, -1, END)
            return True
        if self.progress is not None:
            self.progress(len(branch.points), nxt.sol.lam)
        return False

    def _detect(self, prev: Entry, nxt: Entry, branch: Branch) -> list[Entry]:
        """The labels between ``prev`` and ``nxt`` appended (:meth:`rigtools.sim.orbit_events.EventSearch.detect`)."""
        st = self.settings
        return EventSearch(self.correct, self.solver, st.locate, st.locate_iterations).detect(
            prev, nxt, branch
        )

    def _closes(self, first: Entry, prev: Entry, nxt: Entry, h_max: float) -> bool:
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

    def _rescale(self, e: Entry) -> None:
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

    def window_edge(self, prev: Entry, nxt: Entry, h: float, branch: Branch) -> Entry | None:
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
        self._detect(prev, edge, branch)
        return edge

    def _excursion_message(self) -> str:
        u = UNITS[self.param]
        x = self._crossings
        return (
            f"the branch left the range at {x[0]:.6g} {u}, came back at {x[1]:.6g} {u} and ends where "
            f"it leaves it again, at {x[2]:.6g} {u}"
        )

    def turn_at_hairpin(self, entries: list[Entry], branch: Branch) -> bool:
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
        if grazing_margin(last) > GRAZING_TOLERANCE or FOLD in last.point.labels:
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
        tip = Entry(
            last.sol, tangent, replace(last.point, labels=(FOLD, GRAZING), tangent_param=float(tangent[-1]))
        )
        del entries[k:]
        entries.append(tip)
        branch.points.append(tip.point)
        if back is not None:
            entries.append(back)
            branch.points.append(back.point)
        return True

    def _returning_orbit(self, tip: Entry, before: Entry, travel: float) -> Entry | None:
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

    def cross_grazing_corner(self, entries: list[Entry]) -> Entry | None:
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
