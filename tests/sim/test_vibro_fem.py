"""The fast reduced integrator on the default rig against the full-order reference and the
assumed-modes model (issue 3 "must show"), at fe = 60 Hz, F0 = 15 N, gap 0.5 mm.

Acceleration harmonics are taken from the sampled velocity (:func:`rigtools.analysis.harmonics.
derivative_harmonics`): the damped contact makes the acceleration jump at each impact, so its
point samples converge only to first order in the step, the velocity's to second.
"""

import numpy as np
import pytest

from rigtools.analysis.harmonics import derivative_harmonics, harmonic_amplitudes
from rigtools.config import load_rig
from rigtools.sim.full_order import run_full_order
from rigtools.sim.reduction import reduced_system
from rigtools.sim.rig_model import build_rig_model
from rigtools.sim.steady_state import check_periodic
from rigtools.sim.vibro_impact import SimulationInputError, run_harmonic

FE, F0 = 60.0, 15.0
TIPS = ("active_tip", "passive_tip")


def accel_harmonics(outputs, sample_rate, fe=FE, k_max=30):
    return {
        tip: derivative_harmonics(
            harmonic_amplitudes(outputs[f"{tip}_velocity"], sample_rate, fe, k_max)
        ).amplitude
        for tip in TIPS
    }


@pytest.fixture(scope="module")
def model():
    return build_rig_model(load_rig().to_params())


@pytest.fixture(scope="module")
def fem_run(model):
    system = reduced_system(model.params, rig_model=model)
    return run_harmonic(system, FE, F0)


@pytest.fixture(scope="module")
def fem_run_half_step(model, fem_run):
    system = reduced_system(model.params, rig_model=model)
    return run_harmonic(system, FE, F0, steps_per_period=2 * fem_run.steps_per_period)


def test_default_case_is_periodic_with_impacts(fem_run):
    assert fem_run.steady_state and fem_run.period_multiple == 1
    assert fem_run.impacts_per_period == 1.0
    assert fem_run.peak_contact_force > 10.0


def test_halving_the_step_changes_harmonics_1_6_8_by_under_half_a_percent(fem_run, fem_run_half_step):
    a = accel_harmonics(fem_run.outputs, fem_run.sample_rate)
    b = accel_harmonics(fem_run_half_step.outputs, fem_run_half_step.sample_rate)
    for tip in TIPS:
        for k in (1, 6, 8):
            assert a[tip][k - 1] == pytest.approx(b[tip][k - 1], rel=5e-3), (tip, k)


def test_agrees_with_full_order_reference_within_one_percent(model, fem_run):
    """Full-order HHT (average acceleration) on the full FE matrices, 1760 steps per period, from
    rest for 4 s (steady by then: the fast run settled in about 3 s)."""
    ref = run_full_order(model, FE, F0, 4.0, 1 / (FE * 1760), record_periods=5)
    # the reference must itself be settled (measured period-to-period mismatch 6e-7)
    tips = np.vstack([ref[f"{tip}_{q}"] for tip in TIPS for q in ("displacement", "velocity")])
    assert check_periodic(tips, 1760, tol=1e-5, max_multiple=1).steady
    h_ref = accel_harmonics(ref, FE * 1760)
    h = accel_harmonics(fem_run.outputs, fem_run.sample_rate)
    for tip in TIPS:
        for k in (1, 6, 8):
            assert h[tip][k - 1] == pytest.approx(h_ref[tip][k - 1], rel=1e-2), (tip, k)
    assert fem_run.peak_contact_force == pytest.approx(ref["contact_force"].max(), rel=2e-2)


def test_energy_balance_over_a_steady_period(fem_run):
    """Input work F v at the force point = modal damping + contact damping (1 %)."""
    e = fem_run.energy_balance()
    assert e["contact_damping"] > 0.1 * e["input"]  # the impacts do dissipate
    assert abs(e["imbalance"]) < 1e-2


def test_fem_and_am_vibro_impact_agree(model, fem_run):
    """Paper's Figure 9: FEM vs AM, harmonics k = 1..10 of both shroud accelerations and the
    peak contact force within 5 %."""
    am = run_harmonic(reduced_system(model.params, "am"), FE, F0, steps_per_period=fem_run.steps_per_period)
    h_fem = accel_harmonics(fem_run.outputs, fem_run.sample_rate)
    h_am = accel_harmonics(am.outputs, am.sample_rate)
    for tip in TIPS:
        np.testing.assert_allclose(h_am[tip][:10], h_fem[tip][:10], rtol=5e-2)
    assert am.peak_contact_force == pytest.approx(fem_run.peak_contact_force, rel=5e-2)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"fe": -60.0}, "frequency"),
        ({"force_amplitude": -1.0}, "force"),
        ({"gap": -1e-4}, "gap"),
        ({"steps_per_period": 40}, "too coarse"),
        ({"record_periods": 0}, "period"),
    ],
)
def test_invalid_physical_input_is_refused_with_one_line(model, kwargs, match):
    system = reduced_system(model.params, rig_model=model)
    args = {"fe": FE, "force_amplitude": F0, **kwargs}
    with pytest.raises(SimulationInputError, match=match) as err:
        if "gap" in kwargs:  # refused by ContactParams itself
            system = system.with_contact(gap=args.pop("gap"))
        run_harmonic(system, args.pop("fe"), args.pop("force_amplitude"), **args)
    assert "\n" not in str(err.value)
