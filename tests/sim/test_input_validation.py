"""The physics refuses invalid or absurd input with one line naming the field and its value
(:class:`rigtools.sim.params.SimulationInputError`, a ValueError), before running where it can, and a run
that still produces a non-finite value stops with :class:`rigtools.sim.vibro_impact.SimulationDivergedError`
(issue 8: contact damping 1e5 N*s/m, Rayleigh alpha = inf or 1e300, root springs of 1e20 gave
NaN results or 0 Hz)."""

import math
from dataclasses import replace

import numpy as np
import pytest

from rigtools.config import load_rig
from rigtools.sim.modal import flexural_frequencies
from rigtools.sim.params import (
    BladeParams,
    ContactParams,
    DampingParams,
    LumpedMass,
    RootParams,
    SimulationInputError,
)
from rigtools.sim.reduction import reduced_system
from rigtools.sim.rig_model import build_rig_model
from rigtools.sim.vibro_impact import (
    ShakerCoupling,
    SimulationDivergedError,
    VibroImpactStepper,
    contact_force_harmonics,
    run_harmonic,
)

INF, NAN = math.inf, math.nan
BLADE = dict(length=0.155, width=0.04, thickness=3.2e-3, youngs_modulus=200e9, density=7850.0)
SHAKER = dict(
    armature_mass=0.1,
    suspension_stiffness=2e4,
    suspension_damping=5.0,
    force_factor=10.0,
    coil_resistance=2.5,
    coil_inductance=5e-4,
)


@pytest.fixture(scope="module")
def params():
    return load_rig().to_params()


@pytest.fixture(scope="module")
def system(params):
    return reduced_system(params)


@pytest.mark.parametrize(
    "make, field",
    [
        (lambda: BladeParams(**{**BLADE, "length": INF}), "blade.length"),
        (lambda: BladeParams(**{**BLADE, "thickness": -1e-3}), "blade.thickness"),
        (lambda: BladeParams(**{**BLADE, "youngs_modulus": NAN}), "blade.youngs_modulus"),
        (lambda: BladeParams(**{**BLADE, "density": 0.0}), "blade.density"),
        (lambda: BladeParams(**BLADE, poisson=0.5), "blade.poisson"),
        (lambda: BladeParams(**BLADE, elements=0), "blade.elements"),
        (lambda: BladeParams(**BLADE, elements=2.5), "blade.elements"),
        (lambda: BladeParams(**BLADE, elements=10**6), "blade.elements"),
        (lambda: BladeParams(**BLADE, theory="plate"), "blade.theory"),
        (lambda: RootParams(kind="glued"), "root.kind"),
        (lambda: RootParams(kind="springs", rotational_stiffness=1e4), "root.translational_stiffness"),
        (
            lambda: RootParams(kind="springs", rotational_stiffness=INF, translational_stiffness=1e8),
            "root.rotational_stiffness",
        ),
        (lambda: LumpedMass(mass=NAN, rotary_inertia=0.0, position=0.1), "mass.mass"),
        (lambda: LumpedMass(mass=0.1, rotary_inertia=-1.0, position=0.1), "mass.rotary_inertia"),
        (lambda: ContactParams(gap=INF, stiffness=1e6), "contact.gap"),
        (lambda: ContactParams(gap=-1e-4, stiffness=1e6), "contact.gap"),
        (lambda: ContactParams(gap=1e-4, stiffness=NAN), "contact.stiffness"),
        (lambda: ContactParams(gap=1e-4, stiffness=1e6, damping=-1.0), "contact.damping"),
        (lambda: ContactParams(gap=1e-4, stiffness=1e6, damping=INF), "contact.damping"),
        (lambda: ContactParams(gap=1e-4, stiffness=1e6, law="coulomb"), "contact.law"),
        (
            lambda: ContactParams(gap=1e-4, stiffness=1e6, law="hertz", hertz_exponent=5.0),
            "contact.hertz_exponent",
        ),
        (lambda: DampingParams(ratio=1.0), "damping.ratio"),
        (lambda: DampingParams(ratio=None, alpha=INF), "damping.alpha"),
        (lambda: DampingParams(ratio=None, beta=NAN), "damping.beta"),
        (lambda: ShakerCoupling(**{**SHAKER, "coil_resistance": 0.0}), "shaker.coil_resistance"),
        (lambda: ShakerCoupling(**{**SHAKER, "armature_mass": INF}), "shaker.armature_mass"),
        (lambda: ShakerCoupling(**{**SHAKER, "force_factor": NAN}), "shaker.force_factor"),
    ],
)
def test_parameter_objects_refuse_bad_values_with_one_line(make, field):
    with pytest.raises(SimulationInputError) as err:
        make()
    msg = str(err.value)
    assert isinstance(err.value, ValueError) and "\n" not in msg and field in msg


def test_rig_params_refuse_a_sensor_beyond_the_blade(params):
    with pytest.raises(SimulationInputError, match="force_sensor.position 200 mm lies beyond"):
        replace(params, force_sensor=replace(params.force_sensor, position=0.2))


def test_absurd_root_springs_are_refused_and_the_largest_allowed_one_matches_the_clamp(params):
    """Issue 8: 1e20 N/m springs gave 0 Hz. Springs 1e7 x the root element's stiffness already
    gave a first flexural frequency 43 % high; 1e6 x (the limit) matches the clamp to 1e-6."""
    with pytest.raises(SimulationInputError, match="root.translational_stiffness 1e\\+20 N/m.*clamped"):
        replace(params, root=RootParams("springs", 1e4, 1e20))
    with pytest.raises(SimulationInputError, match="root.rotational_stiffness"):
        replace(params, root=RootParams("springs", 1e12, 3e8))
    b = params.active
    le = b.length / b.elements
    kt, kr = 0.999e6 * b.youngs_modulus * b.area / le, 0.999e6 * b.youngs_modulus * b.i_flexural / le
    stiff = replace(params, root=RootParams("springs", kr, kt))
    f_springs = flexural_frequencies(build_rig_model(stiff).active, 3)
    f_clamp = flexural_frequencies(build_rig_model(params).active, 3)
    np.testing.assert_allclose(f_springs, f_clamp, rtol=1e-6)


def test_absurd_rayleigh_damping_is_refused_before_running(params):
    """alpha = 1e300 (finite: passes the field check) makes the modal ratios absurd."""
    with pytest.raises(SimulationInputError, match="modal damping ratio .*Rayleigh alpha = 1e\\+300"):
        reduced_system(replace(params, damping=DampingParams(ratio=None, alpha=1e300)))


def test_large_contact_damping_gets_a_fine_enough_step(system):
    """1e5 N*s/m at the default 50 us step diverged to 1e227 N. A fixed coarse step is refused
    naming the contact damping; run_harmonic picks a step with c dt / m <= 1. Reference: the
    same run at half that step (contact-force harmonics k = 1..5 within 0.01 %; measured 3e-5)."""
    heavy = system.with_contact(damping=1e4)
    with pytest.raises(SimulationInputError, match="too coarse for the contact damping 1e\\+04") as err:
        VibroImpactStepper(heavy, 5e-5)
    assert "\n" not in str(err.value)
    run = run_harmonic(heavy, 60.0, 15.0)
    assert run.steady_state and np.isfinite(run.outputs["contact_force"]).all()
    assert run.dt * 1e4 <= heavy.contact_effective_mass() * (1 + 1e-9)
    fine = run_harmonic(heavy, 60.0, 15.0, steps_per_period=2 * run.steps_per_period, initial=run.final_state)
    a, b = np.abs(contact_force_harmonics(run, 5)), np.abs(contact_force_harmonics(fine, 5))
    np.testing.assert_allclose(a, b, rtol=1e-4)


def test_a_diverging_run_stops_with_one_line_naming_the_suspects(system):
    """Bypass the step check (private override) to make the damper overshoot: the stepper must
    stop, not return NaN or 1e227."""
    st = VibroImpactStepper(system, 5e-5)
    gap, kc, _cc, p, code = st._contact
    st._contact = (gap, kc, 1e5, p, code)
    u = 15.0 * np.sin(2 * np.pi * 60.0 * 5e-5 * np.arange(1, 200_001))
    with pytest.raises(SimulationDivergedError, match="diverged.*contact damping 1e\\+05") as err:
        st.step(u)
    assert "\n" not in str(err.value)
    with pytest.raises(SimulationInputError, match="non-finite"):
        VibroImpactStepper(system, 5e-5).step(np.array([1.0, np.nan]))


def test_full_order_refuses_non_finite_hht_alpha(params):
    from rigtools.sim.full_order import FullOrderIntegrator

    model = build_rig_model(params)
    for alpha in (INF, NAN, -0.1):
        with pytest.raises(SimulationInputError, match="HHT alpha"):
            FullOrderIntegrator(model, 2e-5, alpha=alpha)
