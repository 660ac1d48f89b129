"""FE blade frequencies against independent references.

* Euler-Bernoulli cantilever with tip mass and tip rotary inertia: the classical frequency equation
  (field notes; e.g. Laura, Pombo & Susemihl, J. Sound Vib. 37 (1974) 161-168), solved here by
  bracketing and Brent's method. Requirement: <= 0.05 % for the first three flexural modes at 100
  elements (we see ~1e-7).
* Timoshenko cantilever: the exact solution of the Timoshenko equations (Timoshenko 1921; the
  clamped-free frequency equation of Huang, J. Appl. Mech. 28 (1961) 579-584), obtained here from
  the matrix exponential of the first-order ODE system -- no discretisation.
* Torsion and axial modes of the bare cantilever: ``f = (2n - 1)/(4L) c`` with the wave speeds
  sqrt(G J / (rho Ip)) and sqrt(E / rho).
"""

import numpy as np
import pytest
import scipy.linalg
from scipy.optimize import brentq

from rigtools.sim.blade import build_blade
from rigtools.sim.modal import blade_modes, flexural_frequencies
from rigtools.sim.params import BladeParams, LumpedMass, RootParams

BLADE = BladeParams(length=0.155, width=0.04, thickness=0.0032, youngs_modulus=2e11, density=7850.0)


def _tip_mass_lambdas(mu, j, n):
    """Roots of the field-notes equation (divided by cosh l), independent of rigtools.sim.analytical."""

    def f(l):
        c, s, ch, sh = np.cos(l), np.sin(l), np.cosh(l), np.sinh(l)
        return (
            1
            + c * ch
            + mu * l * (c * sh - s * ch)
            - j * l**3 * (ch * s + sh * c)
            + mu * j * l**4 * (1 - c * ch)
        ) / ch

    grid = np.arange(1e-3, 40.0, 1e-3)
    vals = f(grid)
    idx = np.nonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))[0][:n]
    return np.array([brentq(f, grid[i], grid[i + 1], xtol=1e-14) for i in idx])


def _scale(b: BladeParams) -> float:
    return np.sqrt(b.youngs_modulus * b.i_flexural / (b.density * b.area * b.length**4)) / (2 * np.pi)


@pytest.mark.parametrize("mu, j", [(0.0, 0.0), (0.2, 0.002), (1.0, 0.02), (5.0, 0.1), (20.0, 0.5)])
def test_tip_mass_and_rotary_inertia_against_exact_euler_bernoulli(mu, j):
    rho_al = BLADE.density * BLADE.area * BLADE.length
    tip = LumpedMass(mu * rho_al, j * rho_al * BLADE.length**2, BLADE.length)
    blade = build_blade("t", BLADE, [tip], RootParams(), rotary_inertia=False)
    exact = _tip_mass_lambdas(mu, j, 3) ** 2 * _scale(BLADE)
    fe = flexural_frequencies(blade, 3)
    assert np.abs(fe / exact - 1).max() < 5e-4  # requirement 0.05 %


def test_mesh_convergence_is_fourth_order():
    """Relative error of mode 3 (tip mass mu = 1, j = 0.02) falls ~16x per halving of the element size."""
    mu, j = 1.0, 0.02
    rho_al = BLADE.density * BLADE.area * BLADE.length
    tip = LumpedMass(mu * rho_al, j * rho_al * BLADE.length**2, BLADE.length)
    exact = _tip_mass_lambdas(mu, j, 3) ** 2 * _scale(BLADE)
    errors = []
    for n in (4, 8, 16):
        b = build_blade(
            "t", BladeParams(**{**BLADE.__dict__, "elements": n}), [tip], RootParams(), rotary_inertia=False
        )
        errors.append(abs(flexural_frequencies(b, 3)[2] / exact[2] - 1))
    assert errors[0] > errors[1] > errors[2]
    assert errors[0] / errors[1] > 10 and errors[1] / errors[2] > 10


def _timoshenko_exact(b: BladeParams, n: int) -> np.ndarray:
    """Clamped-free Timoshenko frequencies from the exact transfer matrix expm(A L)."""
    E, G, rho = b.youngs_modulus, b.shear_modulus, b.density
    A, I = b.area, b.i_flexural
    kappa = 10 * (1 + b.poisson) / (12 + 11 * b.poisson)
    kga, ei = kappa * G * A, E * I

    def det(f):
        w2 = (2 * np.pi * f) ** 2
        # y = [w, psi, w', psi']
        a = np.array(
            [
                [0, 0, 1, 0],
                [0, 0, 0, 1],
                [-rho * A * w2 / kga, 0, 0, 1],
                [0, kga / ei - rho * I * w2 / ei, -kga / ei, 0],
            ]
        )
        t = scipy.linalg.expm(a * b.length)
        # w(0) = psi(0) = 0; at L: psi'(L) = 0 and w'(L) - psi(L) = 0
        return np.linalg.det(np.array([[t[3, 2], t[3, 3]], [t[2, 2] - t[1, 2], t[2, 3] - t[1, 3]]]))

    grid = np.linspace(1.0, 40000.0, 8000)
    vals = np.array([det(f) for f in grid])
    idx = np.nonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))[0][:n]
    return np.array([brentq(det, grid[i], grid[i + 1], xtol=1e-10) for i in idx])


def test_timoshenko_deep_cantilever_against_exact_theory():
    """Deep beam L/h = 5: shear and rotary inertia lower mode 3 by ~30 % vs Euler-Bernoulli;
    FE (100 elements, Timoshenko, rotary inertia) within 0.05 % of the exact Timoshenko values."""
    deep = BladeParams(
        length=0.1,
        width=0.06,
        thickness=0.02,
        youngs_modulus=2e11,
        density=7850.0,
        poisson=0.3,
        theory="timoshenko",
    )
    exact = _timoshenko_exact(deep, 3)
    fe = flexural_frequencies(build_blade("t", deep, [], RootParams(), rotary_inertia=True), 3)
    assert np.abs(fe / exact - 1).max() < 5e-4
    eb = np.array([1.8751040687, 4.6940911330, 7.8547574382]) ** 2 * _scale(deep)
    assert exact[2] / eb[2] < 0.8  # the reference really is a deep-beam case


def test_matrices_symmetric_positive_definite():
    masses = [LumpedMass(0.066, 2e-6, 0.085), LumpedMass(0.11, 1e-5, BLADE.length)]
    for root in (RootParams(), RootParams("springs", 3e3, 1e8)):
        for theory in ("euler-bernoulli", "timoshenko"):
            b = build_blade("t", BladeParams(**{**BLADE.__dict__, "theory": theory}), masses, root)
            for mat in (b.mass, b.stiffness):
                d = mat.toarray()
                assert np.abs(d - d.T).max() <= 1e-13 * np.abs(d).max()
                scipy.linalg.cholesky(d)  # raises if not positive-definite
            assert b.n_dofs == (606 if root.kind == "springs" else 600)


def test_mode_kinds_and_torsion_axial_edgewise_closed_forms():
    b = build_blade("t", BLADE, [], RootParams(), rotary_inertia=False)
    modes = blade_modes(b)
    tor = modes.of_kind("torsional").frequencies_hz[:2]
    ax = modes.of_kind("axial").frequencies_hz[:1]
    edge = modes.of_kind("edgewise").frequencies_hz[:2]
    L = BLADE.length
    ip = BLADE.i_flexural + BLADE.i_edgewise
    from rigtools.sim.beam_element import rectangle_torsion_constant

    c_t = np.sqrt(
        BLADE.shear_modulus * rectangle_torsion_constant(BLADE.width, BLADE.thickness) / (BLADE.density * ip)
    )
    assert tor == pytest.approx(np.array([1, 3]) * c_t / (4 * L), rel=2e-3)  # linear elements: O(h^2)
    assert ax == pytest.approx(np.sqrt(BLADE.youngs_modulus / BLADE.density) / (4 * L), rel=1e-4)
    edge_exact = (
        np.array([1.8751040687, 4.6940911330]) ** 2
        * np.sqrt(BLADE.youngs_modulus * BLADE.i_edgewise / (BLADE.density * BLADE.area * L**4))
        / (2 * np.pi)
    )
    assert edge == pytest.approx(edge_exact, rel=1e-4)
    assert modes.kinds[0] == "flexural" and len(modes.kinds) == b.n_dofs
    # mass-normalised shapes
    phi = modes.shapes[:, :10]
    assert np.allclose(phi.T @ (b.mass @ phi), np.eye(10), atol=1e-9)


def test_sparse_lowest_modes_equal_the_dense_solution(monkeypatch):
    """The shift-invert Lanczos path (eigsh, used for DOF groups above DENSE_GROUP_MAX asked for
    less than a third of their modes, then polished by subspace iteration) against every mode by
    dense LAPACK (on the flexibility), forced here for every group at 100 elements: the lowest 12
    frequencies to 1e-11 relative (measured 1.4e-13; before both were polished through the element
    deformations, each carried the assembled stiffness's round-off, 7e-9 apart here and ~2e-6 at
    400 elements), the shapes to 1e-9 (measured 2.5e-11) with the same sign (both paths sign a
    shape by its first clearly nonzero entry), the kinds; ``below_hz`` gives exactly the dense
    modes below it."""
    from rigtools.sim import modal

    def blade():
        tip = LumpedMass(0.05, 1e-6, BLADE.length)
        return build_blade("t", BladeParams(**{**BLADE.__dict__, "elements": 100}), [tip], RootParams())

    dense = modal._all_modes(blade())
    monkeypatch.setattr(modal, "DENSE_GROUP_MAX", 0)
    b = blade()
    sparse = modal.lowest_modes(b, 12)
    np.testing.assert_allclose(sparse.frequencies_hz, dense.frequencies_hz[:12], rtol=1e-11)
    assert sparse.kinds == dense.kinds[:12]
    for j in range(12):
        x, y = sparse.shapes[:, j], dense.shapes[:, j]
        assert np.abs(x - y).max() < 1e-9 * np.abs(y).max()
    below = modal.lowest_modes(b, below_hz=5000.0)
    n_below = int(np.sum(dense.frequencies_hz < 5000.0))
    assert n_below >= 5
    np.testing.assert_allclose(below.frequencies_hz[:n_below], dense.frequencies_hz[:n_below], rtol=1e-11)
    # per group: everything below the limit, then at most the group's next mode (or its lowest)
    assert np.sum(below.frequencies_hz < 5000.0) == n_below


def test_eigen_solves_run_on_one_blas_thread_whatever_the_caller_set(monkeypatch):
    """A library user who never called configure_process: the solvers still run on one BLAS
    thread (the model's problems are banded or small), and the caller's setting is back after."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from rigtools.sim import modal

    seen = []
    solve = modal._group_lowest

    def spy(*args, **kwargs):
        seen.append({lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"})
        return solve(*args, **kwargs)

    monkeypatch.setattr(modal, "_group_lowest", spy)
    blade = build_blade("t", BLADE, [], RootParams())
    with threadpool_limits(limits=2, user_api="blas"):
        before = {lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"}
        flexural_frequencies(blade, 3)
        after = {lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"}
    assert seen and all(s == {1} for s in seen)
    assert after == before
