"""The blade's stiffness and rotary inertia in element-deformation coordinates
(:mod:`rigtools.sim.deformation`), and what they buy: mesh convergence without round-off.

References, all independent of the FE code:

* the assembled matrices (``blade.stiffness``, ``blade.mass``) on random vectors of small meshes,
  where their round-off is negligible: equal to 1e-13 (measured ~2e-16);
* rigid-body motions of a free blade, exact in binary (a 1 m blade of 64 elements): the product
  is the root springs' load and exactly zero elsewhere;
* the clamped-free Euler-Bernoulli beam: static tip deflection ``L^3 / 3EI`` (Timoshenko:
  ``+ L / kappa G A``; both exact for these elements, so only round-off is left: 1e-12, measured
  3e-14 at 6400 elements, where a sparse LU of the assembled matrix is off by 7.5e-4), and
  frequencies ``beta_n^2 sqrt(EI / rho A L^4) / 2 pi`` with ``cos(beta) cosh(beta) = -1``
  (brentq). The discretisation error of the consistent-mass Hermite element is, to leading order,
  ``(beta_n h)^4 / 720`` on ``w^2`` (half that on the frequency: 8.58e-11, 3.37e-9, 2.64e-8 for
  f1-f3 at 100 elements); the test asks each error to be that within 5 % plus a round-off of
  1e-14 (measured below 2.3e-15 at 1600-25600 elements), hence decreasing as h^4 until it
  reaches the round-off.
"""

from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import brentq

from rigtools.sim.blade import build_blade
from rigtools.sim.deformation import blade_inertia, blade_stiffness
from rigtools.sim.modal import DENSE_MAX_ELEMENTS, blade_modes, lowest_modes
from rigtools.sim.params import BladeParams, LumpedMass, RootParams, SimulationInputError

BLADE = BladeParams(length=0.155, width=0.04, thickness=0.0032, youngs_modulus=2e11, density=7850.0)
MASSES = [LumpedMass(0.066, 2e-6, 0.085), LumpedMass(0.11, 1e-5, BLADE.length)]
ROUND_OFF = 1e-14  # relative, on a frequency
UY, RZ = 1, 5


CLAMPED = RootParams()


def _blade(n, theory="euler-bernoulli", masses=(), root=CLAMPED, rotary_inertia=False, **geometry):
    params = replace(BLADE, elements=n, theory=theory, **geometry)
    return build_blade("t", params, list(masses), root, rotary_inertia=rotary_inertia)


@pytest.mark.parametrize("theory", ["euler-bernoulli", "timoshenko"])
@pytest.mark.parametrize("root", [RootParams(), RootParams("springs", 3e3, 1e8)])
def test_products_equal_the_assembled_matrices_on_random_vectors(theory, root):
    blade = _blade(7, theory, MASSES, root, rotary_inertia=True)
    stiffness, inertia = blade_stiffness(blade), blade_inertia(blade)
    x = np.random.default_rng(3).standard_normal((blade.n_dofs, 4))
    kx, mx = blade.stiffness @ x, blade.mass @ x
    assert np.abs(stiffness.product(x) - kx).max() <= 1e-13 * np.abs(kx).max()
    assert np.abs(stiffness.form(x) - x.T @ kx).max() <= 1e-13 * np.abs(x.T @ kx).max()
    assert np.abs(inertia.form(x) - x.T @ mx).max() <= 1e-13 * np.abs(x.T @ mx).max()
    assert stiffness.form(x[:, 0])[0, 0] == pytest.approx(float(x[:, 0] @ kx[:, 0]), rel=1e-13)
    # the solve inverts the assembled matrix (a random load: no smoothness to lean on)
    b = np.random.default_rng(4).standard_normal(blade.n_dofs)
    assert np.abs(blade.stiffness @ stiffness.solve(b) - b).max() <= 1e-9 * np.abs(b).max()


@pytest.mark.parametrize("theory", ["euler-bernoulli", "timoshenko"])
def test_rigid_body_motions_of_a_free_blade_are_exactly_free(theory):
    """1 m, 64 elements, masses at 0.5 and 1 m, soft root springs: every rigid motion (three
    translations, three rotations about the root) has exactly zero load beyond the root node and
    the springs' load on it; the assembled matrix leaves round-off everywhere."""
    springs = (1e-2, 1e2)  # rotational, translational
    blade = _blade(
        64,
        theory,
        [LumpedMass(0.05, 1e-6, 0.5), LumpedMass(0.1, 1e-5, 1.0)],
        RootParams("springs", *springs),
        length=1.0,
    )
    stiffness = blade_stiffness(blade)
    x_nodes = blade.node_x
    assert np.array_equal(np.diff(x_nodes), np.full(64, 1 / 64))  # exact in binary
    motions = []
    for axis in range(3):
        t = np.zeros((x_nodes.size, 6))
        t[:, axis] = 1.0
        motions.append(t)
        w = np.zeros(3)
        w[axis] = 1.0
        r = np.zeros((x_nodes.size, 6))
        r[:, 1] = x_nodes * w[2]  # omega x (x e_x) = x (0, wz, -wy)
        r[:, 2] = -x_nodes * w[1]
        r[:, 3:] = w
        motions.append(r)
    x = np.stack([m.ravel() for m in motions], axis=1)[blade.free_dofs]
    load = stiffness.product(x)
    spring = np.array([springs[1]] * 3 + [springs[0]] * 3)[:, None] * x[:6]
    np.testing.assert_array_equal(load[:6], spring)
    np.testing.assert_array_equal(load[6:], 0.0)
    np.testing.assert_array_equal(np.diag(stiffness.form(x)), np.sum(x[:6] * spring, axis=0))
    assert np.abs((blade.stiffness @ x)[6:]).max() > 0.0  # the assembled matrix is not exact


@pytest.mark.parametrize("n", [100, 400, 1600, 6400])
@pytest.mark.parametrize("theory", ["euler-bernoulli", "timoshenko"])
def test_static_tip_deflection_equals_the_closed_form_at_any_mesh(n, theory):
    blade = _blade(n, theory)
    b = BLADE
    kappa = 10 * (1 + b.poisson) / (12 + 11 * b.poisson)
    exact = b.length**3 / (3 * b.youngs_modulus * b.i_flexural)
    if theory == "timoshenko":
        exact += b.length / (kappa * b.shear_modulus * b.area)
    tip = blade.dof(blade.tip_node, UY)
    load = np.zeros(blade.n_dofs)
    load[tip] = 1.0
    assert blade_stiffness(blade).solve(load)[tip] / exact - 1 == pytest.approx(0.0, abs=1e-12)


def _beta(n_modes):
    """Roots of ``cos(b) + 1 / cosh(b)`` (the frequency equation over cosh: well scaled), bracketed,
    by Brent's method, then one Newton step (brentq stops at 4 eps relative)."""
    f = lambda b: np.cos(b) + 1.0 / np.cosh(b)
    df = lambda b: -np.sin(b) - np.tanh(b) / np.cosh(b)
    grid = np.arange(0.5, 12.0, 0.01)
    idx = np.nonzero(np.sign(f(grid[:-1])) != np.sign(f(grid[1:])))[0][:n_modes]
    roots = np.array([brentq(f, grid[i], grid[i + 1], xtol=1e-15) for i in idx])
    return roots - f(roots) / df(roots)


def test_frequencies_converge_as_h4_to_round_off():
    beta = _beta(3)
    np.testing.assert_allclose(beta, [1.8751040687, 4.6940911330, 7.8547574382], rtol=1e-10)
    b = BLADE
    scale = np.sqrt(b.youngs_modulus * b.i_flexural / (b.density * b.area * b.length**4)) / (2 * np.pi)
    exact = beta**2 * scale
    errors, predicted = [], []
    for n in (100, 400, 1600, 6400):
        blade = _blade(n)
        f = lowest_modes(blade, 3, dofs=[blade.dof(blade.tip_node, UY)]).frequencies_hz
        errors.append(f / exact - 1)
        predicted.append((beta / n) ** 4 / 1440)
    errors, predicted = np.array(errors), np.array(predicted)
    assert np.all(np.abs(errors - predicted) <= 0.05 * predicted + ROUND_OFF), errors
    for k in range(3):  # decreasing while the discretisation error is above the round-off
        resolved = predicted[:, k] > 10 * ROUND_OFF
        assert np.all(np.diff(errors[resolved, k]) < 0)


def test_nested_meshes_give_non_increasing_frequencies():
    """Consistent-mass Hermite elements are a Rayleigh-Ritz method: on nested meshes (25, 100, 400
    elements; masses at 0.0775 and 0.155 m, rotary inertia) each frequency is an upper bound of the
    next, which the solution shows beyond its round-off."""
    masses = [LumpedMass(0.066, 2e-6, BLADE.length / 2), LumpedMass(0.11, 1e-5, BLADE.length)]
    freqs = []
    for n in (25, 100, 400):
        blade = _blade(n, masses=masses, rotary_inertia=True)
        assert np.isclose(blade.node_x, BLADE.length / 2, rtol=0, atol=1e-15).any()
        freqs.append(lowest_modes(blade, 3, dofs=[blade.dof(blade.tip_node, UY)]).frequencies_hz)
    steps = np.diff(np.array(freqs), axis=0) / freqs[0]
    assert np.all(steps < -10 * ROUND_OFF), steps


def test_every_mode_of_a_blade_beyond_the_dense_limit_is_refused_in_one_line():
    blade = _blade(DENSE_MAX_ELEMENTS + 1)
    with pytest.raises(SimulationInputError) as err:
        blade_modes(blade)
    text = str(err.value)
    assert "\n" not in text and f"at most {DENSE_MAX_ELEMENTS} elements" in text
    assert f"got {DENSE_MAX_ELEMENTS + 1}" in text
    assert blade_modes(blade, 3).frequencies_hz.size == 3  # the sparse path has no such limit
