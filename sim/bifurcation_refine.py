"""Bifurcation locations at a converged time step.

A branch is traced at a fixed number of time steps per forcing period; its located bifurcations
move with that step (the period doubling of the gap branch at 60 Hz: 1.532 mm at 328 steps,
1.555 at 656, 1.559 at 1312). :func:`refine` relocates one labelled point with the steps per
period doubled, again and again, until the location moves by less than ``tolerance`` (relative)
between two refinements, or :data:`MAX_REFINEMENTS` doublings: at each time step the orbit is
solved on the arclength plane through the last location, then

* a smooth bifurcation (fold, period doubling, Neimark-Sacker) by a secant iteration along the
  arclength on its test function (:func:`rigtools.sim.bifurcations.test_value`), kept only where
  the critical multiplier is at its value (:func:`rigtools.sim.bifurcations.accepted`);
* a non-smooth event (and a fold at one) by bisection on the contact structure
  (:func:`rigtools.sim.bifurcations.bisect_event`), a side where no orbit converges counting as
  the other side (a hairpin's tip).

The tracer is reached through ``make(steps_per_period)``, an object with ``enter(state, value)``
(the refined orbit nearest a point, or ``None``) and ``correct(entry, s)`` (the orbit at arclength
``s`` from an entry along its tangent, or ``None``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any, Protocol

import numpy as np

from rigtools.sim import bifurcations as bif
from rigtools.sim.bifurcations import Bifurcation

# relative change of a location between two doublings of the steps per period below which it
# is converged (the must-have accuracy is 0.1 %; the last change of a second-order scheme is
# about three times the remaining error, so half of that)
REFINE_TOLERANCE = 5e-4
MAX_REFINEMENTS = 4  # up to 16 times the branch's steps per period
# an event's bracket is bisected until its two sides are this close in the parameter (relative):
# a tenth of the convergence tolerance, so the bisection's own error never decides convergence
EVENT_VALUE_PRECISION = REFINE_TOLERANCE / 10
START_POINTS = 6  # points either side of a labelled one tried as starts at a finer step
_SEARCH = tuple(1e-4 * 2.0**j for j in range(10))  # arclengths tried to bracket an event


class Relocator(Protocol):
    def enter(self, state: np.ndarray, value: float) -> Any | None: ...

    def correct(self, entry: Any, s: float) -> Any | None: ...


def refine(
    record: Bifurcation,
    points: Sequence[Any],
    make: Callable[[int], Relocator],
    steps_per_period: int,
    tolerance: float = REFINE_TOLERANCE,
    max_refinements: int = MAX_REFINEMENTS,
) -> Bifurcation:
    """``record`` (of the branch's ``points``) with its location at a converged time step
    (``converged``, ``change``, ``steps_per_period``, ``refinements``, ``converged_ok``,
    ``multiplier_converged``); the refinements stop where an orbit or the location is not found at
    the finer step (the last location found is kept, ``converged_ok`` false)."""
    i = record.index
    point = points[i]
    history = [(steps_per_period, record.value)]
    # an event: the structures on either side in branch order, and which way the parameter went
    before = points[i - 1].contact if i > 0 else point.contact
    approach = float(np.sign(point.value - points[i - 1].value)) if i > 0 else 0.0
    turning = bif.FOLD in point.labels  # the branch turns at the event: either way along it
    # where the refined branch no longer reaches the point (a hairpin's tip moves with the step),
    # the points beside it, nearest first
    near = sorted(
        range(max(0, i - START_POINTS), min(len(points), i + START_POINTS + 1)), key=lambda k: abs(k - i)
    )
    starts = [(np.asarray(points[k].state, float), float(points[k].value)) for k in near]
    order = list(range(len(starts)))
    multiplier = record.multiplier
    ok = False
    for k in range(1, max_refinements + 1):
        n = steps_per_period * 2**k
        relocator = make(n)
        found = None
        no_orbit = []  # starts from which no orbit converged at this step
        for j in order:
            start = relocator.enter(*starts[j])
            if start is None:
                no_orbit.append(j)
                continue
            if record.smooth:
                found = _smooth(relocator, start, record.label)
            else:
                found = _event(relocator, start, before, point.contact, approach, turning)
            if found is not None:
                break
        if found is None:
            break
        entry, value = found
        starts.append((np.asarray(entry.point.state, float), float(entry.point.value)))
        # at the finer step next: the location found, the start it came from, the others, and last
        # those beyond a hairpin's tip here (the tip moves one way as the step shrinks: at the gap
        # branch's period-two fold they failed again at every step, 0.3-0.6 s each)
        order = [len(starts) - 1, j, *(i for i in order if i != j and i not in no_orbit), *no_orbit]
        kind = record.label if record.smooth else bif.NEIMARK_SACKER
        multiplier = bif.critical_multiplier(kind, entry.point.multipliers)
        history.append((n, value))
        if abs(history[-1][1] - history[-2][1]) <= tolerance * max(abs(value), 1e-300):
            ok = True
            break
    if len(history) == 1:
        return record
    last = history[-1]
    return replace(
        record,
        converged=last[1],
        change=last[1] - history[-2][1],
        steps_per_period=last[0],
        refinements=tuple(history),
        converged_ok=ok,
        multiplier_converged=multiplier,
    )


def _smooth(relocator: Relocator, start: Any, kind: str) -> tuple[Any, float] | None:
    """The nearest sign change of the test of ``kind`` along the arclength from ``start`` (both
    ways, growing steps), located by regula falsi and kept where the test has come down to its
    zero: the multiplier at -1 or on the circle within 1e-4, or the tangent's parameter component
    below 1e-4."""

    def f(e: Any) -> float:
        return bif.test_value(kind, e.point.multipliers, e.tangent[-1])

    f0 = f(start)
    if not math.isfinite(f0):
        return None
    if _at_zero(kind, start):
        return start, float(start.point.value)
    open_ways = {1.0: True, -1.0: True}
    for s in _SEARCH:
        for way in (1.0, -1.0):
            if not open_ways[way]:
                continue
            e = relocator.correct(start, way * s)
            if e is None or not math.isfinite(f(e)):
                open_ways[way] = False
                continue
            if f(e) * f0 > 0:
                continue
            found = bif.locate(lambda t: relocator.correct(start, t), start, e, way * s, kind, 20)
            if found is None or not _at_zero(kind, found):
                return None
            return found, float(found.point.value)
    return None


def _at_zero(kind: str, e: Any) -> bool:
    if kind == bif.FOLD:
        return abs(float(e.tangent[-1])) <= 1e-4
    return bif.critical_distance(kind, e.point.multipliers) <= 1e-4


def _event(
    relocator: Relocator, start: Any, before: Any, after: Any, approach: float, turning: bool = False
) -> tuple[Any, float] | None:
    """Bisection on the contact structure from ``start`` to the change ``before -> after`` (in
    branch order; ``approach`` the sign of the parameter's motion into it; ``turning``: the branch
    turns there, either order) nearest along the arclength, or to where no orbit converges (a
    turning at the event)."""
    here = start.point.contact
    forward = approach * (1.0 if start.tangent[-1] >= 0 else -1.0) or 1.0
    # from the side before the event go forward, from the side after it back; then the other way
    ways = (forward, -forward) if here != after else (-forward, forward)
    for way in ways:
        for s in _SEARCH:
            e = relocator.correct(start, way * s)
            if e is not None and e.point.contact == here:
                continue
            new = None if e is None else e.point.contact
            wanted = (here == before and new == after and way == forward) or (
                here == after and new == before and way == -forward
            )
            wanted = wanted or (turning and {here, new} == {before, after})
            if new is not None and not wanted:
                break  # another event first this way
            last, first, _, _ = bif.bisect_event(
                lambda t: relocator.correct(start, t),
                start,
                way * s,
                24,
                value_width=EVENT_VALUE_PRECISION * abs(float(start.point.value)),
            )
            if first is None:
                return last, float(last.point.value)
            return last, 0.5 * float(last.point.value + first.point.value)
    return None
