"""Labels between two neighbouring orbits of a branch: the non-smooth contact events and the
smooth bifurcations (:mod:`rigtools.sim.bifurcations`), located and inserted as branch points.

* a non-smooth event where the orbit's contact-event structure changes
  (:mod:`rigtools.sim.contact_events`: grazing, contact-split, sticking), bracketed by bisection to
  :data:`EVENT_BRACKET`; the monodromy matrix jumps there, so no smooth test is taken across it;
* on one structure: period doubling, Neimark-Sacker and fold by their test functions, each kept
  only where the located orbit's critical multiplier is at -1, on the circle or at +1.

Also the orbit measures the tracer (:mod:`rigtools.sim.orbit_tracer`) reads at a grazing and on a
period-2 branch (:func:`grazing_margin`, :func:`half_difference`, :func:`period_one_distance`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from rigtools.sim import bifurcations as bif
from rigtools.sim.bifurcations import SMOOTH
from rigtools.sim.branch_points import Branch
from rigtools.sim.contact_events import GRAZING, event_kind
from rigtools.sim.orbit_map import COL
from rigtools.sim.orbit_solver import Entry, Solver

# a contact event is bracketed to this scaled arclength, and the orbits on its two sides are taken
# that far outside it: 100 times the finite-difference step of the monodromy matrix (1e-6)
EVENT_BRACKET = 1e-4


@dataclass(frozen=True)
class EventSearch:
    """Locates the labels between orbits of one branch with the tracer's corrector.

    Attributes
    ----------
    correct
        ``correct(entry, s)``: the orbit at arclength ``s`` from ``entry`` along its tangent, or
        ``None`` (:meth:`rigtools.sim.orbit_tracer.BranchTracer.correct`).
    solver
        The tracer's corrector (its scaling measures the arclength).
    locate
        Locate the bifurcations (``False``: events are labelled at the first orbit past them,
        smooth bifurcations not at all).
    iterations
        Regula falsi iterations per smooth bifurcation.
    """

    correct: Callable[[Entry, float], Entry | None]
    solver: Solver
    locate: bool
    iterations: int

    def along(self, a: Entry, b: Entry) -> float:
        """The arclength of ``b`` from ``a`` along ``a``'s tangent (where its predictor meets it)."""
        s = self.solver
        return float((s.scaled(b.sol.y, b.sol.lam) - s.scaled(a.sol.y, a.sol.lam)) @ a.tangent)

    def detect(self, prev: Entry, nxt: Entry, branch: Branch, depth: int = 0) -> list[Entry]:
        """Append the located bifurcations and events between ``prev`` and ``nxt`` to the branch
        (``nxt`` is appended by the caller) and return them (:mod:`rigtools.sim.bifurcations`).

        Where the contact structure changes, the event is bracketed by bisection and its two
        sides inserted (the first orbit of the new structure labelled with the event); the
        smooth tests run on each side of it, never across it (the monodromy matrix jumps there).
        A smooth bifurcation of the kind just found within 1e-4 of the range is the same one."""
        located: list[Entry] = []
        if prev.point.contact != nxt.point.contact:
            h = self.along(prev, nxt)
            if self.locate and depth < 3 and h > 0:
                last, first = self.bracket_event(prev, nxt, h)
            else:
                last, first = prev, None
            after = first if first is not None else nxt
            kind = event_between(last, after)
            after.point = replace(after.point, labels=(*after.point.labels, kind))
            located += self.smooth(prev, last, branch)
            if last is not prev:
                located.append(last)
            if after is not nxt:
                located.append(after)
                located += self.detect(after, nxt, branch, depth + 1)
            else:
                located += self.smooth(after, nxt, branch)
        else:
            located += self.smooth(prev, nxt, branch)
        if depth == 0:
            branch.points.extend(e.point for e in located)
        return located

    def bracket_event(self, prev: Entry, nxt: Entry, h: float) -> tuple[Entry, Entry | None]:
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

    def smooth(self, a: Entry, b: Entry, branch: Branch) -> list[Entry]:
        """The smooth bifurcations between two orbits of one contact structure, located and
        checked on their critical multiplier (:func:`rigtools.sim.bifurcations.accepted`)."""
        if a is b or a.point.contact != b.point.contact:
            return []
        h = self.along(a, b)
        tol = 1e-4 * self.solver.L
        found: list[tuple[float, Entry]] = []
        for kind in SMOOTH:
            if not bif.crossed(kind, a, b) or near_last(branch, kind, b.sol.lam, tol):
                continue
            e = bif.locate(lambda s: self.correct(a, s), a, b, h, kind, self.iterations)
            if e is None or not self.locate:
                continue  # the test jumps: no bifurcation (a turning is labelled from the values)
            if not bif.accepted(kind, e) or near_last(branch, kind, e.sol.lam, tol):
                continue
            e.point = replace(e.point, labels=(kind,))
            found.append((self.along(a, e), e))
        return [e for _, e in sorted(found, key=lambda f: f[0])]


def event_between(a: Entry, b: Entry) -> str:
    """The non-smooth event between two orbits of different contact structures."""
    return event_kind(a.point.contact, b.point.contact) or GRAZING


def grazing_margin(e: Entry) -> float:
    """Smallest distance between a local maximum of the closure (active minus passive shroud
    displacement, sampled) and the gap over the orbit, relative to the active tip amplitude: zero
    where an impact, the first or another one, grazes."""
    data = e.sol.data
    closure = data[:, COL["active_tip_displacement"]] - data[:, COL["passive_tip_displacement"]]
    peaks = closure[(closure > np.roll(closure, 1)) & (closure >= np.roll(closure, -1))]
    if not peaks.size:
        return math.inf
    amplitude = max(e.point.measures.tip_amplitude_active, 1e-300)
    return float(np.min(np.abs(peaks - e.point.forcing.gap)) / amplitude)


def near_last(branch: Branch, label: str, value: float, tol: float) -> bool:
    """The last few points hold ``label`` within ``tol`` of ``value``."""
    return any(label in p.labels and abs(p.value - value) <= tol for p in branch.points[-10:])


def half_difference(e: Entry) -> np.ndarray:
    """The shroud displacements over a period-2 orbit's first period minus its second: it
    changes sign where the branch crosses the period-1 orbit (onto its shift by one period)."""
    data = e.sol.data
    n = data.shape[0] // 2
    x = data[:, [COL["active_tip_displacement"], COL["passive_tip_displacement"]]]
    return (x[:n] - x[n:]).ravel()


def period_one_distance(e: Entry) -> float:
    """How far a period-2 orbit is from repeating after one period (relative)."""
    data = e.sol.data
    n = data.shape[0] // 2
    x = data[:, [COL["active_tip_displacement"], COL["passive_tip_displacement"]]]
    return float(np.max(np.abs(x[:n] - x[n:])) / max(float(np.max(np.abs(x))), 1e-300))
