"""The analytical model (AM): exact EB frequencies and the assumed-modes blade.

References: the classical tip-mass frequency equation (field notes), the bare cantilever roots
1.87510, 4.69409, 7.85476, and the FE model (an independent implementation).
"""

import numpy as np
import pytest

from rigtools.config import load_rig
from rigtools.sim.analytical import assumed_modes_blade, exact_flexural_frequencies, tip_mass_lambdas
from rigtools.sim.blade import build_blade
from rigtools.sim.modal import flexural_frequencies
from rigtools.sim.params import BladeParams, LumpedMass, RootParams
from rigtools.sim.rig_model import blade_masses, build_rig_model

BLADE = BladeParams(length=0.155, width=0.04, thickness=0.0032, youngs_modulus=2e11, density=7850.0)
SCALE = np.sqrt(BLADE.youngs_modulus * BLADE.i_flexural / (BLADE.density * BLADE.area * BLADE.length**4)) / (
    2 * np.pi
)
RHO_AL = BLADE.density * BLADE.area * BLADE.length


@pytest.mark.parametrize("mu, j", [(0.0, 0.0), (0.5, 0.01), (3.0, 0.0), (10.0, 0.3)])
def test_determinant_matches_classical_tip_mass_equation(mu, j):
    tip = LumpedMass(mu * RHO_AL, j * RHO_AL * BLADE.length**2, BLADE.length)
    f = exact_flexural_frequencies(BLADE, [tip], 4)
    assert f == pytest.approx(tip_mass_lambdas(mu, j, 4) ** 2 * SCALE, rel=1e-10)


def test_bare_cantilever_roots_and_massless_sensor():
    f = exact_flexural_frequencies(BLADE, [LumpedMass(0.0, 0.0, 0.07)], 3)
    assert f / SCALE == pytest.approx(np.array([1.8751040687, 4.6940911330, 7.8547574382]) ** 2, rel=1e-9)


def test_stiff_root_springs_approach_the_clamp():
    masses = [LumpedMass(0.066, 2e-6, 0.085), LumpedMass(0.11, 1e-5, BLADE.length)]
    clamped = exact_flexural_frequencies(BLADE, masses, 3)
    stiff = exact_flexural_frequencies(BLADE, masses, 3, RootParams("springs", 1e9, 1e13))
    soft = exact_flexural_frequencies(BLADE, masses, 3, RootParams("springs", 2e3, 1e7))
    assert stiff == pytest.approx(clamped, rel=1e-5)
    assert np.all(soft < clamped)


@pytest.mark.parametrize("root", [RootParams(), RootParams("springs", 2e3, 1e7)])
def test_exact_matches_fe_with_sensor_and_springs(root):
    """Two independent implementations; the FE (100 EB elements, no distributed rotary inertia)
    is within 1e-5 of the exact values for four modes."""
    masses = [LumpedMass(0.066, 2e-6, 0.085), LumpedMass(0.11, 1e-5, BLADE.length)]
    exact = exact_flexural_frequencies(BLADE, masses, 4, root)
    fe = flexural_frequencies(build_blade("t", BLADE, masses, root, rotary_inertia=False), 4)
    assert fe == pytest.approx(exact, rel=1e-5)


@pytest.mark.parametrize("root", [RootParams(), RootParams("springs", 2e3, 1e7)])
def test_assumed_modes_are_orthogonal_and_reproduce_exact_frequencies(root):
    masses = [LumpedMass(0.066, 2e-6, 0.085), LumpedMass(0.11, 1e-5, BLADE.length)]
    am = assumed_modes_blade(BLADE, masses, root, n_terms=8)
    exact = exact_flexural_frequencies(BLADE, masses, 8, root)
    # generalised matrices come from quadrature: orthogonality is a real check of the shapes
    d = np.sqrt(np.diag(am.mass))
    assert np.abs(am.mass / np.outer(d, d) - np.eye(8)).max() < 1e-9
    assert am.natural_frequencies(8) == pytest.approx(exact, rel=1e-9)
    if root.kind == "clamped":
        assert np.abs(am.shape(0.0)).max() < 1e-12 and np.abs(am.slope(0.0)).max() < 1e-9
    assert np.all(am.shape(BLADE.length) > 0)


def test_fem_versus_am_on_the_default_rig():
    """Must-show: first three flexural frequencies of each blade, FEM (as built, with distributed
    rotary inertia) vs AM (Euler-Bernoulli), within 0.5 %."""
    params = load_rig().to_params()
    rig = build_rig_model(params)
    for name, bp in (("active", params.active), ("passive", params.passive)):
        fem = flexural_frequencies(rig.blade(name), 3)
        am = assumed_modes_blade(bp, blade_masses(params, name), params.root, 6).natural_frequencies(3)
        assert np.abs(fem / am - 1).max() < 5e-3
