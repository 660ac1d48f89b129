"""Bifurcations between neighbouring orbits of a continued branch, by their definitions.

A smooth bifurcation is a property of the monodromy matrix on one smooth piece of the orbit map,
so it is tested only between orbits of one contact-event structure
(:mod:`rigtools.sim.contact_events`): where the structure changes, the map has a kink and its
Jacobian jumps, and that change is a non-smooth event, labelled as such. On one structure:

* period doubling: a real multiplier crosses -1 (``det(M + I)`` changes sign);
* Neimark-Sacker: a complex pair crosses the unit circle (the number of complex multipliers
  outside it changes);
* fold: the branch turns in the parameter (the tangent's parameter component changes sign; a
  multiplier is at +1 there).

Each is located by regula falsi on its test function along the arclength (:func:`locate`) and kept
only if the located orbit's critical multiplier is within :data:`CRITICAL_TOLERANCE` of its value
(-1, the unit circle); a sign change that cannot be located so is a jump of the test function, not
a bifurcation. A turning of the branch in the parameter is a fold wherever it happens (at a
grazing hairpin too, where no multiplier is +1: :func:`mark_turning_points`). :class:`Bifurcation`
records each labelled point with its critical multiplier and, once
:mod:`rigtools.sim.bifurcation_refine` has refined the time step, its converged location.

Entries are the tracer's (``point``: a :class:`rigtools.sim.continuation.BranchPoint`-like object
with ``value``, ``multipliers``, ``labels``, ``contact``, ``tangent_param``; ``tangent`` the unit
tangent); ``correct(s)`` is the orbit at arclength ``s`` from the bracket's start, or ``None``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rigtools.sim.contact_events import EVENTS

FOLD, PERIOD_DOUBLING, NEIMARK_SACKER = "fold", "period-doubling", "neimark-sacker"
SMOOTH = (FOLD, PERIOD_DOUBLING, NEIMARK_SACKER)
# a located period doubling has a real multiplier this close to -1, a Neimark-Sacker a complex
# pair this close to the unit circle (regula falsi brings them to 1e-4 or closer; a monodromy jump
# across a contact event leaves the nearest multiplier 0.3 or more away)
CRITICAL_TOLERANCE = 1e-2
_REAL = 1e-9  # |imag| / |mu| below this: a real multiplier
# a located fold stands for the turning of the points this close to it in branch order and within
# 1e-4 of the span in value (the test's zero and the largest value may differ by a point: the
# tangent comes from a finite-difference Jacobian)
TURNING_NEIGHBOURS = 3
HAIRPIN_POINTS = 30  # how far back from a hairpin's tip its grazing may have been labelled


def _real(mu: np.ndarray) -> np.ndarray:
    return np.abs(mu.imag) <= _REAL * np.maximum(np.abs(mu), 1e-300)


def test_value(kind: str, multipliers: np.ndarray, tangent_param: float) -> float:
    """The test function of ``kind`` at one orbit: fold the tangent's parameter component, period
    doubling ``det(M + I)`` (from the multipliers), Neimark-Sacker ``|mu| - 1`` of the complex
    multiplier nearest the unit circle (NaN without one)."""
    mu = np.asarray(multipliers)
    if kind == FOLD:
        return float(tangent_param)
    if kind == PERIOD_DOUBLING:
        return float(np.prod(1.0 + mu).real)
    cplx = ~_real(mu)
    if not np.any(cplx):
        return math.nan
    d = np.abs(mu[cplx]) - 1.0
    return float(d[np.argmin(np.abs(d))])


def _complex_outside(mu: np.ndarray) -> int:
    return int(np.count_nonzero(~_real(mu) & (np.abs(mu) > 1.0)))


def critical_multiplier(kind: str, multipliers: np.ndarray) -> complex:
    """The multiplier that defines ``kind`` at an orbit: nearest -1 (period doubling), the complex
    one nearest the unit circle (Neimark-Sacker; the one nearest it if none is complex), nearest +1
    (fold); NaN without multipliers."""
    mu = np.asarray(multipliers, dtype=complex)
    if not mu.size:
        return complex(math.nan, math.nan)
    if kind == PERIOD_DOUBLING:
        return complex(mu[np.argmin(np.abs(mu + 1.0))])
    if kind == NEIMARK_SACKER:
        pool = mu[~_real(mu)] if np.any(~_real(mu)) else mu
        return complex(pool[np.argmin(np.abs(np.abs(pool) - 1.0))])
    return complex(mu[np.argmin(np.abs(mu - 1.0))])


def critical_distance(kind: str, multipliers: np.ndarray) -> float:
    """How far the critical multiplier is from its value at ``kind`` (-1, the unit circle, +1)."""
    c = critical_multiplier(kind, multipliers)
    if kind == NEIMARK_SACKER:
        return abs(abs(c) - 1.0) if c.imag != 0.0 else math.inf
    return abs(c - (-1.0 if kind == PERIOD_DOUBLING else 1.0))


def crossed(kind: str, a: Any, b: Any) -> bool:
    """The test of ``kind`` changes sign between entries ``a`` and ``b`` (one structure)."""
    ma, mb = a.point.multipliers, b.point.multipliers
    fa = test_value(kind, ma, a.tangent[-1])
    fb = test_value(kind, mb, b.tangent[-1])
    if kind == NEIMARK_SACKER:
        return _complex_outside(ma) != _complex_outside(mb) and fa * fb < 0
    return fa * fb < 0


def accepted(kind: str, entry: Any) -> bool:
    """A located orbit is the bifurcation its test says: the critical multiplier within
    :data:`CRITICAL_TOLERANCE` of -1, the unit circle or +1 (a fold: where the tangent turns at a
    kink of the map, next to a grazing, no multiplier is at +1; that turning is labelled from the
    values, :func:`mark_turning_points`)."""
    return critical_distance(kind, entry.point.multipliers) <= CRITICAL_TOLERANCE


def locate(
    correct: Callable[[float], Any | None], a: Any, b: Any, h: float, kind: str, iterations: int = 12
) -> Any | None:
    """Regula falsi (Illinois) on the arclength in ``(0, h)`` for the test of ``kind`` between the
    entries ``a`` (at 0) and ``b`` (at ``h``); the located entry, or ``None`` where the test does
    not come down to a thousandth of its end values (it jumps: no bifurcation) or an orbit fails."""

    def value(e: Any) -> float:
        return test_value(kind, e.point.multipliers, e.tangent[-1])

    f0, f1 = value(a), value(b)
    if not (math.isfinite(f0) and math.isfinite(f1)) or f0 * f1 > 0:
        return None
    scale = abs(f0) + abs(f1)
    lo, hi = 0.0, h
    best, best_f = None, math.inf
    side = 0
    for _ in range(iterations):
        s = (lo * f1 - hi * f0) / (f1 - f0) if f1 != f0 else 0.5 * (lo + hi)
        if not (min(lo, hi) < s < max(lo, hi)):
            s = 0.5 * (lo + hi)
        e = correct(s)
        if e is None:
            break
        fs = value(e)
        if not math.isfinite(fs):
            break
        if abs(fs) < best_f:
            best, best_f = e, abs(fs)
        if abs(fs) <= 1e-8 * scale or abs(hi - lo) < 1e-5 * abs(h):
            break
        if fs * f0 > 0:
            lo, f0 = s, fs
            if side == -1:
                f1 *= 0.5
            side = -1
        else:
            hi, f1 = s, fs
            if side == 1:
                f0 *= 0.5
            side = 1
    if best is None or (best_f > 1e-3 * scale and abs(hi - lo) >= 1e-5 * abs(h)):
        return None
    return best


def bisect_event(
    correct: Callable[[float], Any | None],
    a: Any,
    h: float,
    iterations: int = 14,
    width: float = 0.0,
    value_width: float = 0.0,
) -> tuple[Any, Any | None, float, float]:
    """Where the contact structure of entry ``a`` (at 0) ends along the arclength towards ``h``
    (where it differs): ``(last entry with a's structure, first with another or None where no
    orbit converges, their arclengths)``, the bracket shrunk ``iterations`` times or until it is
    no wider than ``width`` in arclength or, with an orbit on both sides, ``value_width`` in the
    parameter."""
    lo, hi = 0.0, h
    last, first = a, None
    for _ in range(iterations):
        if abs(hi - lo) <= width:
            break
        if first is not None and abs(first.point.value - last.point.value) <= value_width:
            break
        s = 0.5 * (lo + hi)
        e = correct(s)
        if e is not None and e.point.contact == a.point.contact:
            lo, last = s, e
        else:
            hi, first = s, e
    return last, first, lo, hi


def mark_turning_points(
    points: Sequence[Any], relabel: Callable[[int, str], None], unlabel: Callable[[int, str], None]
) -> None:
    """Label ``fold`` every point where the branch turns in the parameter (a strict local extreme
    of the values, neighbours within a millionth of the span not counted) unless a fold is
    labelled within :data:`TURNING_NEIGHBOURS` points and 1e-4 of the span of it: a turning point
    is a fold wherever it happens, whichever way the tracer reached it.

    Where the branch turns at a contact event (no multiplier at +1) the fold goes with the event:
    on the event's point if the extreme point's neighbour has another structure; at a grazing
    hairpin, whose sampled contact ends up to :data:`HAIRPIN_POINTS` points before the tip (the
    grazing impact grows shorter than a step), the event's label moves to the tip, as the tracer
    labels a hairpin it turns at (both refine to one location)."""
    v = np.array([p.value for p in points], float)
    if v.size < 3:
        return
    span = float(np.ptp(v))
    tiny = 1e-6 * span
    for i in range(1, v.size - 1):
        before = next((v[k] for k in range(i - 1, -1, -1) if abs(v[k] - v[i]) > tiny), None)
        after = next((v[k] for k in range(i + 1, v.size) if abs(v[k] - v[i]) > tiny), None)
        if before is None or after is None or (v[i] - before) * (after - v[i]) >= 0:
            continue
        if (v[i] - before) * (v[i] - v[i - 1]) < 0 or (v[i] - after) * (v[i] - v[i + 1]) < 0:
            continue  # not the extreme of its run of near-equal values
        lo, hi = max(0, i - TURNING_NEIGHBOURS), min(v.size, i + TURNING_NEIGHBOURS + 1)
        if any(FOLD in points[k].labels and abs(v[k] - v[i]) <= 1e-4 * span for k in range(lo, hi)):
            continue
        neighbour = next((k for k in (i + 1, i - 1) if points[k].contact != points[i].contact), None)
        if neighbour is not None:
            # the event's labelled point is the first of the new structure in branch order
            relabel(max(i, neighbour), FOLD)
            continue
        relabel(i, FOLD)
        k = _hairpin_event(points, i)
        if k is not None:
            for label in set(points[k].labels) & set(EVENTS):
                unlabel(k, label)
                relabel(i, label)


def _hairpin_event(points: Sequence[Any], i: int) -> int | None:
    """The event labelled on the way into the turning point ``i`` (within :data:`HAIRPIN_POINTS`
    points, every point from it to ``i`` of ``i``'s contact structure), or ``None``."""
    for k in range(i - 1, max(-1, i - HAIRPIN_POINTS - 1), -1):
        if points[k].contact != points[i].contact:
            return None
        if set(points[k].labels) & set(EVENTS):
            return k
        if set(points[k].labels) & set(SMOOTH):
            return None
    return None


@dataclass(frozen=True)
class Bifurcation:
    """A labelled point of a branch and its location at a converged time step.

    Attributes
    ----------
    label
        ``fold``, ``period-doubling``, ``neimark-sacker`` or a non-smooth event
        (:data:`rigtools.sim.contact_events.EVENTS`).
    index
        The labelled point's index on the branch.
    value
        Its parameter value at the branch's steps per period (Hz, N or V, m).
    multiplier
        The critical multiplier there (nearest -1, the complex one nearest the unit circle, nearest
        +1 for a fold; for an event the multiplier nearest the unit circle after it).
    smooth
        A smooth bifurcation (located on its test function); ``False``: a non-smooth event, or a
        fold at one (the branch turns at a grazing, no multiplier at +1).
    contact_before, contact_after
        The contact structure on either side (:meth:`rigtools.sim.contact_events.ContactStructure.describe`; equal for a smooth
        bifurcation).
    converged, change, steps_per_period
        The location at the finest time step refined to, its change from the refinement before,
        and that step's steps per period (NaN, NaN, 0 if not refined).
    refinements
        ``(steps per period, value)`` at each time step tried, from the branch's.
    converged_ok
        The last change is within the tolerance asked for.
    multiplier_converged
        The critical multiplier at the converged location.
    """

    label: str
    index: int
    value: float
    multiplier: complex
    smooth: bool
    contact_before: str = ""
    contact_after: str = ""
    converged: float = math.nan
    change: float = math.nan
    steps_per_period: int = 0
    refinements: tuple[tuple[int, float], ...] = field(default=())
    converged_ok: bool = False
    multiplier_converged: complex = complex(math.nan, math.nan)

    def as_dict(self) -> dict:
        """JSON-ready fields (complex numbers as ``[real, imag]``)."""

        def cx(z: complex) -> list[float | None]:
            return [None if math.isnan(z.real) else z.real, None if math.isnan(z.imag) else z.imag]

        def num(x: float) -> float | None:
            return None if math.isnan(x) else float(x)

        return {
            "label": self.label,
            "index": self.index,
            "value": self.value,
            "multiplier": cx(self.multiplier),
            "smooth": self.smooth,
            "contact_before": self.contact_before,
            "contact_after": self.contact_after,
            "converged": num(self.converged),
            "change": num(self.change),
            "steps_per_period": self.steps_per_period,
            "refinements": [[n, v] for n, v in self.refinements],
            "converged_ok": self.converged_ok,
            "multiplier_converged": cx(self.multiplier_converged),
        }


def records(points: Sequence[Any]) -> list[Bifurcation]:
    """One :class:`Bifurcation` per bifurcation or event label on the points (branch order)."""
    out = []
    for i, p in enumerate(points):
        events = [lab for lab in p.labels if lab in EVENTS]
        before = _structure_before(points, i)
        for lab in p.labels:
            if lab not in SMOOTH and lab not in EVENTS:
                continue
            smooth = lab in SMOOTH and not events
            mult = critical_multiplier(lab, p.multipliers) if smooth else _nearest_circle(p.multipliers)
            out.append(
                Bifurcation(
                    label=lab,
                    index=i,
                    value=float(p.value),
                    multiplier=mult,
                    smooth=smooth,
                    contact_before=before.describe(),
                    contact_after=p.contact.describe(),
                )
            )
    return out


def _structure_before(points: Sequence[Any], i: int) -> Any:
    """The contact structure before point ``i``: its predecessor's, or at a grazing hairpin's tip
    (reached on points of its own sampled structure, the grazing impact shorter than a step) the
    last other one within :data:`HAIRPIN_POINTS` points."""
    p = points[i]
    if i == 0:
        return p.contact
    if FOLD in p.labels and set(p.labels) & set(EVENTS):
        for k in range(i - 1, max(-1, i - HAIRPIN_POINTS - 1), -1):
            if points[k].contact != p.contact:
                return points[k].contact
    return points[i - 1].contact


def merge_hairpin_grazing(points: Sequence[Any], unlabel: Callable[[int, str], None]) -> None:
    """One grazing per hairpin: where the tracer turned at a grazing hairpin (its tip labelled
    fold and grazing), a grazing labelled on the way to it within :data:`HAIRPIN_POINTS` points
    (the sampled contact ended a little before the tip: the impact grew shorter than a step) is
    the same event, and its label is dropped (both refine to one location)."""
    for i, p in enumerate(points):
        if not (FOLD in p.labels and EVENTS[0] in p.labels):
            continue
        for k in range(i - 1, max(-1, i - HAIRPIN_POINTS - 1), -1):
            if set(points[k].labels) & set(SMOOTH):
                break
            if EVENTS[0] in points[k].labels and points[k].contact == p.contact:
                unlabel(k, EVENTS[0])
                break


def _nearest_circle(multipliers: np.ndarray) -> complex:
    mu = np.asarray(multipliers, dtype=complex)
    if not mu.size:
        return complex(math.nan, math.nan)
    return complex(mu[np.argmin(np.abs(np.abs(mu) - 1.0))])
