"""Bifurcation labels that mean what they say, at a converged time step (issue 29).

* a failure inside the tracer (an integration that diverges) ends the branch "failed" with its
  points: a stand-in map that raises after a number of evaluations;
* the gap branch at 60 Hz, 15 N: the period doubling refined by doubling the steps per period
  until it moves less than 0.05 % (the must-have: converged within 0.1 %), and against brute-force
  time integration at the finest step (the project's integrator run for hundreds of periods from
  the orbit): period 1 stays at 1.550 mm, period 2 takes over at 1.570 mm;
* 0.5 mm, 60.2-60.7 Hz: where the contact force starts to release and re-engage (contact-split)
  and where the re-engagement becomes a second impact (grazing) the monodromy matrix jumps and no
  period doubling is labelled (the defect: a PD at 60.55 Hz with no multiplier near -1); the one
  period doubling has a real multiplier at -1;
* 0.7 mm frequency branch from three starts (55, 60, 63 Hz at one time step): the same labels,
  each at the same converged location.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigtools.sim import continuation as C
from rigtools.sim import orbit_tracer
from rigtools.sim.bifurcations import CRITICAL_TOLERANCE
from rigtools.sim.vibro_impact import SimulationDivergedError, run_harmonic


@pytest.fixture(scope="module")
def system(fem_model):
    return fem_model[2]


def test_a_failure_inside_the_tracer_ends_the_branch_failed_with_its_points(system, monkeypatch):
    """The crash of `rig continuation --from 62 --to 76 --gap "0.7 mm"` (Newton ran away in the
    grazing-corner crossing and the diverged integration's error escaped, losing the branch):
    any error inside the tracer now ends the branch "failed", one line, the points kept."""
    calls = {"n": 0}
    point = orbit_tracer.orbit_point

    def failing(*args, **kwargs):  # the orbit's outputs of a run that diverged
        calls["n"] += 1
        if calls["n"] > 20:
            raise SimulationDivergedError(
                "the simulation diverged at t = 1 s (likely cause: contact stiffness)"
            )
        return point(*args, **kwargs)

    monkeypatch.setattr(orbit_tracer, "orbit_point", failing)
    found: list = []
    b = C.continue_orbits(system, "fe", 56.0, 57.0, gap=5e-3, found=found)
    assert found == [b] and b.status == "failed" and len(b.points) > 1
    assert "\n" not in b.message and "diverged" in b.message and "last good point" in b.message
    assert C.FAILED in b.points[-1].labels


def test_period_doubling_is_located_at_a_converged_time_step(system):
    """The gap branch's period doubling (issue 29: 1.532 mm at the default 328 steps per period,
    1.555 and 1.559 mm at 2x and 4x) refined until the last doubling of the steps moves it by
    less than 0.05 %; brute force at that step brackets it."""
    b = C.continue_orbits(system, "gap", 0.5e-3, 1.6e-3, fe=60.0, force=15.0)
    (pd,) = [r for r in b.bifurcations if r.label == C.PERIOD_DOUBLING]
    assert pd.smooth and abs(pd.multiplier + 1) < 1e-4  # a real multiplier at -1 where labelled
    steps = [n for n, _ in pd.refinements]
    assert steps[0] == b.steps_per_period == 328 and steps == [328 * 2**k for k in range(len(steps))]
    # converged within 0.1 % (the tolerance is half of it: a second-order step's last change is
    # about three times the error left)
    assert pd.converged_ok and abs(pd.change) <= 5e-4 * pd.converged
    assert abs(pd.multiplier_converged + 1) < 1e-4
    assert pd.converged == pytest.approx(1.5591e-3, rel=1e-3)  # the value of the must-show
    # brute force at the finest step, from the orbit: period 1 stays below the doubling, period 2
    # takes over above it (its multiplier there is below -1). 10 um either side: 0.6 % of it
    n = pd.steps_per_period
    for gap, period in ((pd.converged - 10e-6, 1), (pd.converged + 10e-6, 2)):
        (orbit,) = C.orbit_at(system, b, gap)
        run = run_harmonic(
            system.with_contact(gap=gap),
            60.0,
            15.0,
            initial=C.initial_state(system, orbit),
            steps_per_period=n,
            min_settle_periods=300,
        )
        assert run.steady_state and run.period_multiple == period, gap


def test_no_period_doubling_where_the_contact_structure_changes(system):
    """0.5 mm, 15 N: the contact-split at 60.39 Hz and the grazing at 60.55 Hz are labelled as
    what they are, with the contact structure on either side; the only period doubling, at 60.59
    Hz, has a real multiplier at -1 (within CRITICAL_TOLERANCE; located to 1e-4)."""
    b = C.continue_orbits(system, "fe", 60.2, 60.7, force=15.0, gap=0.5e-3)
    got = [(r.label, r.converged) for r in b.bifurcations]
    assert [lab for lab, _ in got] == [C.CONTACT_SPLIT, C.GRAZING, C.PERIOD_DOUBLING]
    # converged locations within 0.01 Hz of the must-show's (the refinement tolerance, 0.05 %, is
    # 0.03 Hz; reruns agree to 1e-6 Hz)
    np.testing.assert_allclose([v for _, v in got], [60.390, 60.550, 60.592], atol=0.01)
    split, graze, _ = b.bifurcations
    assert (split.contact_before, split.contact_after) == ("1 overlap: 1 contact", "1 overlap: 2 contacts")
    assert graze.contact_after == "2 overlaps: 1+1 contacts" and not graze.smooth
    for p in b.labelled(C.PERIOD_DOUBLING):
        mu = p.multipliers[np.argmin(np.abs(p.multipliers + 1))]
        assert abs(mu + 1) < 1e-4 and mu.imag == 0
    # where the structure changes the multiplier nearest -1 is far from it: no smooth label there
    ev = b.points[graze.index]
    assert np.min(np.abs(ev.multipliers + 1)) > CRITICAL_TOLERANCE
    assert not set(ev.labels) & {C.PERIOD_DOUBLING, C.NEIMARK_SACKER}


def _labels(branch, lo, hi):
    """``(label, converged location)`` of the labels over ``[lo, hi]``, in order of location
    (the labels of one point in name order)."""
    got = [(r.label, r.converged) for r in branch.bifurcations if lo <= r.value <= hi]
    return sorted(got, key=lambda x: (round(x[1], 2), x[0]))


def test_same_labels_from_three_starts(system, fem_frequency_branch):
    """0.7 mm, 15 N at one time step (the default's for 55 Hz, 357 steps per period; the default
    step follows the range's lowest frequency): the branch started at 55, 60 and 63 Hz carries
    the same labels over 63-76 Hz (issue 29: from 60 Hz the lower turning point was labelled only
    grazing), each at the same converged location within the refinement tolerance (0.05 %)."""
    ref = _labels(fem_frequency_branch, 63.0, 76.0)
    # the grazing hairpin (fold and grazing, 64.406 Hz), two period doublings, the upper fold
    assert [lab for lab, _ in ref] == [C.FOLD, C.GRAZING, C.PERIOD_DOUBLING, C.PERIOD_DOUBLING, C.FOLD]
    settings = C.ContinuationSettings(steps_per_period=fem_frequency_branch.steps_per_period)
    for start in (60.0, 63.0):
        b = C.continue_orbits(system, "fe", start, 76.0, force=15.0, gap=0.7e-3, settings=settings)
        got = _labels(b, 63.0, 76.0)
        assert [lab for lab, _ in got] == [lab for lab, _ in ref], start
        np.testing.assert_allclose([v for _, v in got], [v for _, v in ref], rtol=5e-4)
