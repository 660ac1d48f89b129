"""The contact-event structure of a periodic orbit, and the non-smooth events where it changes.

Over one orbit (all its forcing periods) the shrouds overlap (closure above the gap, or a contact
force) in some intervals; inside each, the penalty force is positive in one or more contact
intervals: a damped contact releases where ``k g + c dg/dt`` reaches zero while the shrouds still
overlap, and may re-engage before they part. :class:`ContactStructure` holds, in time order, the
number of contact intervals inside each overlap interval (``(1,)``: one impact per orbit;
``(1, 1)``: two impacts; ``(2,)``: one impact whose force falls to zero and re-engages) and how many
contact intervals last longer than :data:`STICKING_CONTACT_PERIODS` contact periods (the shrouds
move together: sticking).

Between two orbits whose structures differ the orbit map is not smooth (its Jacobian, the
monodromy matrix, jumps), so no smooth-bifurcation test holds there; :func:`event_kind` names the
change:

* ``grazing``: an overlap interval appears or vanishes (an impact, the first or another one, grazes
  the gap);
* ``contact-split``: an overlap interval holds a different number of contact intervals (the
  force releases and re-engages while the shrouds overlap, or stops doing so);
* ``sticking``: a contact interval starts or stops lasting longer than the sticking limit.

Arrays in, small frozen dataclasses out (sampled at the integrator's step ends: an interval
shorter than a step between two samples is not seen).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

GRAZING, CONTACT_SPLIT, STICKING = "grazing", "contact-split", "sticking"
EVENTS = (GRAZING, CONTACT_SPLIT, STICKING)
# a contact interval this many contact periods long (2 pi sqrt(m_eff / k)) is sticking: a free
# impact on a damped penalty spring lasts about half a contact period
STICKING_CONTACT_PERIODS = 2.0


@dataclass(frozen=True)
class ContactStructure:
    """Contact intervals per overlap interval over one orbit, in time order (the rotation that
    sorts first, so that where the orbit starts does not matter), and the sticking ones.

    ``pattern`` is ``()`` for an orbit without contact; ``always`` is true when the shrouds
    overlap over the whole orbit (``pattern`` then counts the contact intervals in it)."""

    pattern: tuple[int, ...] = ()
    sticking: int = 0
    always: bool = False

    @property
    def impacts(self) -> int:
        """Contact intervals (contact onsets) over the orbit."""
        return int(sum(self.pattern))

    def describe(self) -> str:
        """``"2 overlaps: 1+2 contacts"``-style text (``"no contact"``)."""
        if not self.pattern:
            return "no contact"
        text = f"{len(self.pattern)} overlap{'s' if len(self.pattern) > 1 else ''}: " + "+".join(
            str(k) for k in self.pattern
        )
        text += " contact" + ("s" if self.impacts > 1 else "")
        if self.sticking:
            text += f", {self.sticking} sticking"
        return text + (" (always overlapping)" if self.always else "")


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[start, stop)`` of the runs of true values of a 1-d boolean array (not wrapped)."""
    if not mask.size:
        return []
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts = np.flatnonzero(d == 1)
    stops = np.flatnonzero(d == -1)
    return list(zip(starts.tolist(), stops.tolist(), strict=True))


def contact_structure(
    closure: np.ndarray, contact_force: np.ndarray, gap: float, contact_steps: float
) -> ContactStructure:
    """The :class:`ContactStructure` of an orbit sampled at its time steps.

    Parameters
    ----------
    closure
        Active minus passive shroud displacement at each step end over the orbit, m.
    contact_force
        Contact force at each step end, N (>= 0).
    gap
        The gap, m (overlap: ``closure > gap``).
    contact_steps
        The contact period in time steps (the sticking limit is
        :data:`STICKING_CONTACT_PERIODS` of it).
    """
    force = np.asarray(contact_force, dtype=float) > 0.0
    overlap = (np.asarray(closure, dtype=float) > gap) | force
    if not np.any(overlap):
        return ContactStructure()
    always = bool(np.all(overlap))
    # start the orbit at an open sample so that no interval wraps round its end
    start = 0 if always else int(np.flatnonzero(~overlap)[0])
    overlap = np.roll(overlap, -start)
    force = np.roll(force, -start)
    limit = STICKING_CONTACT_PERIODS * contact_steps
    if always:
        contacts = _wrapped_runs(force)
        return ContactStructure((len(contacts),), sum(b - a > limit for a, b in contacts), True)
    pattern = []
    sticking = 0
    for a, b in _runs(overlap):
        inner = _runs(force[a:b])
        if inner:  # an overlap without force (a sample past a grazing peak) is no impact
            pattern.append(len(inner))
            sticking += sum(y - x > limit for x, y in inner)
    return ContactStructure(_first_rotation(tuple(pattern)), sticking)


def _wrapped_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Runs of a periodic boolean array (a run crossing the end joined to the one at the start)."""
    if np.all(mask):
        return [(0, mask.size)]
    start = int(np.flatnonzero(~mask)[0])
    return [(a + start, b + start) for a, b in _runs(np.roll(mask, -start))]


def _first_rotation(pattern: tuple[int, ...]) -> tuple[int, ...]:
    """The rotation of a cyclic sequence that sorts first (one name for one cycle)."""
    if not pattern:
        return pattern
    return min(pattern[i:] + pattern[:i] for i in range(len(pattern)))


def event_kind(before: ContactStructure, after: ContactStructure) -> str | None:
    """The non-smooth event between two orbits (``None``: the same structure): an overlap interval
    appearing or vanishing is ``grazing``, a contact interval splitting or joining inside one
    ``contact-split``, a change in the sticking intervals ``sticking``."""
    if before == after:
        return None
    if len(before.pattern) != len(after.pattern) or before.always != after.always:
        return GRAZING
    if before.pattern != after.pattern:
        return CONTACT_SPLIT
    return STICKING
