"""The contact-event structure of an orbit (rigtools.sim.contact_events) on signals built by hand,
whose intervals are known exactly; and the turning points of a branch by their definition."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from rigtools.sim import bifurcations as bif
from rigtools.sim.contact_events import (
    CONTACT_SPLIT,
    GRAZING,
    STICKING,
    ContactStructure,
    contact_structure,
    event_kind,
)

N = 400
GAP = 1e-3


def _orbit(overlaps: list[tuple[int, int, list[tuple[int, int]]]]) -> tuple[np.ndarray, np.ndarray]:
    """Closure and force over N samples: each overlap ``(start, stop, contacts)`` puts the closure
    above the gap on ``[start, stop)`` and the force on each contact ``[a, b)`` inside it."""
    closure = np.full(N, 0.5 * GAP)
    force = np.zeros(N)
    for start, stop, contacts in overlaps:
        idx = np.arange(start, stop) % N
        closure[idx] = 1.5 * GAP
        for a, b in contacts:
            force[np.arange(a, b) % N] = 10.0
    return closure, force


def test_one_impact_two_impacts_and_a_split():
    one = contact_structure(*_orbit([(100, 130, [(100, 120)])]), GAP, 40.0)
    assert one == ContactStructure((1,))
    two = contact_structure(*_orbit([(100, 130, [(100, 120)]), (300, 310, [(300, 305)])]), GAP, 40.0)
    assert two == ContactStructure((1, 1))
    split = contact_structure(*_orbit([(100, 140, [(100, 115), (120, 130)])]), GAP, 40.0)
    assert split == ContactStructure((2,))
    assert event_kind(one, two) == GRAZING  # an overlap appears: a second impact grazes in
    assert event_kind(one, split) == CONTACT_SPLIT  # the force falls to zero and re-engages
    assert event_kind(one, one) is None
    assert event_kind(ContactStructure(), one) == GRAZING  # impacts begin


def test_sticking_is_a_contact_longer_than_two_contact_periods():
    short = contact_structure(*_orbit([(100, 190, [(100, 179)])]), GAP, 40.0)
    long = contact_structure(*_orbit([(100, 190, [(100, 181)])]), GAP, 40.0)
    assert short.sticking == 0 and long.sticking == 1
    assert event_kind(short, long) == STICKING


def test_an_overlap_without_force_is_no_impact():
    """A closure sample just past the gap at a grazing peak with no contact force (the force is
    taken at step ends) is not an impact."""
    closure, force = _orbit([(100, 130, [(100, 120)])])
    closure[250] = 1.01 * GAP
    assert contact_structure(closure, force, GAP, 40.0) == ContactStructure((1,))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, N - 1), st.lists(st.integers(1, 3), min_size=1, max_size=4))
def test_structure_does_not_depend_on_where_the_orbit_starts(shift, pattern):
    """Rotating the samples (the same orbit started at another phase, an interval wrapping round
    the end) leaves the structure unchanged: the cyclic pattern is named by its first rotation."""
    overlaps = []
    for i, k in enumerate(pattern):
        start = 20 + 90 * i
        contacts = [(start + 6 * j, start + 6 * j + 4) for j in range(k)]
        overlaps.append((start, start + 6 * k, contacts))
    closure, force = _orbit(overlaps)
    ref = contact_structure(closure, force, GAP, 40.0)
    got = contact_structure(np.roll(closure, shift), np.roll(force, shift), GAP, 40.0)
    assert got == ref and ref.impacts == sum(pattern) and len(ref.pattern) == len(pattern)


@dataclass
class _P:
    value: float
    labels: tuple[str, ...] = ()
    contact: ContactStructure = field(default_factory=lambda: ContactStructure((1,)))


def _turning(values, contacts=None, labels=None):
    pts = [_P(v) for v in values]
    for i, c in (contacts or {}).items():
        pts[i].contact = c
    for i, lab in (labels or {}).items():
        pts[i].labels = lab

    def relabel(i, label):
        pts[i].labels = (*pts[i].labels, label)

    def unlabel(i, label):
        pts[i].labels = tuple(lab for lab in pts[i].labels if lab != label)

    bif.mark_turning_points(pts, relabel, unlabel)
    return [i for i, p in enumerate(pts) if bif.FOLD in p.labels]


def test_turning_points_are_folds_and_a_turning_at_an_event_is_labelled_there():
    assert _turning([1.0, 2.0, 3.0, 2.5, 2.0, 2.2, 2.6]) == [2, 4]
    # a fold already located next to the extreme stands for it
    assert _turning([1.0, 2.0, 3.0, 2.99999, 2.5], labels={3: (bif.FOLD,)}) == [3]
    assert _turning([1.0, 2.0, 3.0, 2.9, 2.5], labels={3: (bif.FOLD,)}) == [2, 3]
    # the branch turns at a grazing: the extreme is the last orbit of the old structure, the
    # event is labelled on the first of the new one, and so is the fold
    new = ContactStructure((1, 1))
    assert _turning([3.0, 2.0, 1.0, 1.01, 2.0], contacts={3: new, 4: new}, labels={3: (GRAZING,)}) == [3]
    assert _turning([1.0, 2.0, 3.0, 4.0]) == []
    # a hairpin whose sampled contact ended two points before the tip: the grazing moves there
    none = ContactStructure()
    pts = {2: none, 3: none, 4: none, 5: none}
    assert _turning([3.0, 2.0, 1.02, 1.01, 1.0, 1.5], contacts=pts, labels={2: (GRAZING,)}) == [4]
