"""Up-front cost estimate of a harmonic run against the run itself (no timing asserted)."""

import math

import numpy as np
import pytest

from rigtools.config import load_rig
from rigtools.sim.reduction import estimate_reduction_seconds, reduced_system
from rigtools.sim.vibro_impact import SimulationInputError, estimate_steps, run_harmonic


@pytest.fixture(scope="module")
def system():
    return reduced_system(load_rig().to_params())


@pytest.mark.parametrize(
    "stiffness, damping, limited",
    [
        (1e6, 200.0, "contact stiffness"),
        (1e8, 200.0, "contact stiffness"),
        (1e6, 1e4, "contact damping"),
    ],
)
def test_estimate_matches_the_run(system, stiffness, damping, limited):
    sy = system.with_contact(stiffness=stiffness, damping=damping, gap=0.9e-3)
    est = estimate_steps(sy, 60.0, 15.0)
    run = run_harmonic(sy, 60.0, 15.0)
    assert est.steps_per_period == run.steps_per_period
    assert est.time_step == pytest.approx(run.dt, rel=1e-12)
    assert est.limited_by == limited
    # settling: the modal-damping decay bound ln(1e5) / (zeta w1) = 3.44 s = 210 periods at
    # 60 Hz; the runs settle in 3.1-4.3 s (the check runs every 5 periods): within a factor 1.5
    settled = run.settle_time * run.fe
    assert est.settle_periods == 210
    assert settled / 1.5 <= est.settle_periods <= 1.5 * settled
    assert est.total_steps == (est.settle_periods + 20) * est.steps_per_period
    assert est.mode_steps == est.total_steps * sy.n_modes
    assert "steps" in est.describe() and "\n" not in est.describe()


def test_stiff_contact_is_flagged_before_running(system):
    """Issue 8: 1e12 N/m took 255 s; the estimate says so without integrating: 30 steps per
    contact period 2 pi sqrt(m/k) of the shrouds' 59.08 g."""
    est = estimate_steps(system.with_contact(stiffness=1e12), 60.0, 15.0)
    tc = 2 * math.pi * math.sqrt(system.contact_effective_mass() / 1e12)
    assert est.steps_per_period == math.ceil(30 / (60.0 * tc))
    assert est.total_steps > 5e7 and est.seconds > 10
    # it does not settle in 30 s (measured: nearly elastic contact, 4e-4 of critical): worst case
    assert est.worst_case_steps == (1800 + 20) * est.steps_per_period
    assert est.worst_case_seconds > 200  # issue 8 measured 255 s
    with pytest.raises(SimulationInputError, match="frequency"):
        estimate_steps(system, -1.0)


def test_reduction_estimate_grows_with_elements():
    from dataclasses import replace

    p = load_rig().to_params()
    big = replace(p, active=replace(p.active, elements=2000), passive=replace(p.passive, elements=2000))
    assert estimate_reduction_seconds(p) == pytest.approx(0.1)
    assert estimate_reduction_seconds(big) == pytest.approx(0.1 * 20**0.7)  # ~0.8 s (sparse build)
    assert np.isfinite(estimate_reduction_seconds(big))
