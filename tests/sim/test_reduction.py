"""The reduced (modal + static correction) model against the full FE matrices it comes from.

* static flexibility at the load DOFs equals the full model's ``K^-1`` (the point of the
  static correction);
* attaching a mass and a grounded spring at the force point in modal coordinates
  (:meth:`ReducedSystem.with_attached`) gives the frequencies of the FE blade with the same
  attachment added to its matrices;
* the apparent shroud masses of point-mass oscillators are those masses, in series.
"""

import math

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse.linalg as spla

from rigtools.config import load_rig
from rigtools.sim.deformation import blade_stiffness
from rigtools.sim.params import ContactParams, DampingParams
from rigtools.sim.reduction import ReducedSystem, reduce_rig_model
from rigtools.sim.rig_model import build_rig_model

UY = 1


@pytest.fixture(scope="module")
def model():
    return build_rig_model(load_rig().to_params())


@pytest.fixture(scope="module")
def reduced(model):
    return reduce_rig_model(model)


def test_static_flexibility_at_the_load_dofs_equals_the_full_model(model, reduced):
    """``sum_j phi_a,j phi_b,j / w_j^2`` over the kept modes and pseudo-modes equals ``K^-1`` at
    (shroud, force point): to 1e-7 relative against a sparse LU of the assembled stiffness (measured
    9e-9: that LU's own round-off at 100 elements), and to 1e-12 against the solve through the
    element deformations (rigtools.sim.deformation; measured 9e-16)."""
    for name, blade_id, rows in (("active", 0, [0, 2]), ("passive", 1, [1])):
        blade = model.blade(name)
        loads = [blade.dof(blade.tip_node, UY)]
        if blade.sensor_node is not None:
            loads.append(blade.dof(blade.sensor_node, UY))
        unit = np.zeros((blade.n_dofs, len(loads)))
        unit[loads, np.arange(len(loads))] = 1.0
        full = spla.splu(blade.stiffness.tocsc()).solve(unit)[loads]
        sel = reduced.blade == blade_id
        phi = reduced.shapes[np.ix_(rows, np.flatnonzero(sel))]
        flex = (phi / reduced.omega[sel] ** 2) @ phi.T
        np.testing.assert_allclose(flex, full, rtol=1e-7, atol=0)
        np.testing.assert_allclose(flex, blade_stiffness(blade).solve(unit)[loads], rtol=1e-12, atol=0)


def test_shroud_apparent_masses_are_those_of_the_ritz_subspace(model):
    """The Ritz basis is M-orthonormal (1e-9; the pseudo-modes used to carry 0.03-0.4 % of the kept
    modes' mass, varying with the BLAS kernel and thread count), so ``1 / sum_j phi_tip,j^2`` is the
    shroud's apparent mass in span{kept modes, K^-1 e}. Reference, by another route: one dense
    eigensolve of the whole blade, the residual flexibility summed over the dropped modes
    (``sum phi_j phi_j^T e / w_j^2``, no cancellation) and the basis-free ``1 / e^T B (B^T M B)^-1 B^T e``.
    1e-7 relative (measured 1e-12; 40-digit mpmath: 117.175639 g and 119.608135 g)."""
    red = reduce_rig_model(model, keep_bases=True)
    for name, blade_id, row in (("active", 0, 0), ("passive", 1, 1)):
        blade = model.blade(name)
        tip = blade.dof(blade.tip_node, UY)
        loads = [tip] if blade.sensor_node is None else [tip, blade.dof(blade.sensor_node, UY)]
        m, k = blade.mass.toarray(), blade.stiffness.toarray()
        basis = red.bases[name]
        np.testing.assert_allclose(basis.T @ m @ basis, np.eye(basis.shape[1]), rtol=0, atol=1e-9)
        w2, phi = scipy.linalg.eigh(k, m)
        seen = np.abs(phi[loads]).max(axis=0) > 1e-6 * np.abs(phi[loads]).max()
        low = seen & (np.sqrt(w2) < 2 * np.pi * 6000.0)
        high = seen & ~low
        resid = phi[:, high] @ (phi[loads][:, high] / w2[high]).T
        b = np.hstack([phi[:, low], resid])
        expected = 1.0 / (b[tip] @ np.linalg.solve(b.T @ m @ b, b[tip]))
        shapes = red.shapes[row, red.blade == blade_id]
        assert 1.0 / np.sum(shapes**2) == pytest.approx(expected, rel=1e-7)


def test_attached_mass_and_spring_match_the_fe_blade_with_them(model, reduced):
    """Armature-like attachment (30 g, 5 kN/m) at the force point: the reduced active blade's
    flexural frequencies below 2.5 kHz equal those of the FE blade with the mass and spring added
    at the sensor uy DOF (1e-5 relative; measured 1e-7)."""
    ma, ks = 0.03, 5e3
    attached = reduced.with_attached(ma, ks)
    blade = model.active
    i = blade.dof(blade.sensor_node, UY)
    m = blade.mass.toarray()
    k = blade.stiffness.toarray()
    m[i, i] += ma
    k[i, i] += ks
    f_full = np.sqrt(scipy.linalg.eigh(k, m, eigvals_only=True, subset_by_index=[0, 40])) / (2 * np.pi)
    f_red = np.sort(attached.frequencies_hz[attached.blade == 0])
    f_red = f_red[f_red < 2500.0]
    assert f_red.size >= 3
    f_bare = np.sort(reduced.frequencies_hz[reduced.blade == 0])[0]
    assert abs(f_red[0] / f_bare - 1) > 1e-3  # the attachment does move the modes
    for f in f_red:
        assert f == pytest.approx(f_full[np.argmin(np.abs(f_full - f))], rel=1e-5)


def test_apparent_shroud_masses_of_point_masses_in_series():
    """One oscillator per blade with a unit-mass-normalised shape ``1/sqrt(m)``: apparent masses
    are ``m`` and the contact sees ``m1 m2 / (m1 + m2)`` (closed form, round-off)."""
    m1, m2 = 0.15, 0.12
    shapes = np.array([[1 / math.sqrt(m1), 0.0], [0.0, 1 / math.sqrt(m2)], [1 / math.sqrt(m1), 0.0]])
    system = ReducedSystem(
        omega=np.array([300.0, 400.0]),
        zeta=np.full(2, 0.01),
        shapes=shapes,
        blade=np.array([0, 1]),
        contact=ContactParams(gap=1e-4, stiffness=1e6),
        damping=DampingParams(ratio=0.01),
    )
    assert system.tip_masses() == pytest.approx((m1, m2), rel=1e-12)
    assert system.contact_effective_mass() == pytest.approx(m1 * m2 / (m1 + m2), rel=1e-12)


def test_kept_modes_and_static_flexibility_do_not_depend_on_the_mesh():
    """100 and 1600 elements per blade: the same 14 modes (11 normal, 3 pseudo), normal-mode
    frequencies lower on the finer mesh and within 5e-7 (measured 1.7e-7 for the highest kept
    mode, ~5 kHz: the discretisation error at 100 elements, (beta h)^4 / 1440), and the passive
    shroud's static flexibility of the reduced model equal to the closed form ``L^3 / 3EI`` of the
    clamped beam to 1e-12 (measured 1e-16 and 4e-15; it was 3e-5 at 1600 elements when the static
    shapes came from a sparse LU of the assembled stiffness)."""
    from dataclasses import replace

    p0 = load_rig().to_params()
    systems = []
    for n in (100, 1600):
        p = replace(p0, active=replace(p0.active, elements=n), passive=replace(p0.passive, elements=n))
        systems.append(reduce_rig_model(build_rig_model(p)))
    coarse, fine = systems
    assert coarse.n_modes == fine.n_modes == 14
    assert coarse.pseudo.sum() == fine.pseudo.sum() == 3
    real = ~coarse.pseudo
    np.testing.assert_allclose(fine.omega[real], coarse.omega[real], rtol=5e-7)
    # conforming elements: every FE frequency bounds the exact one from above, by an error ~h^4
    assert np.all(fine.omega[real] < coarse.omega[real])
    bp = p0.passive
    ei = bp.youngs_modulus * bp.width * bp.thickness**3 / 12.0
    for system in systems:
        sel = system.blade == 1
        flex = float(np.sum(system.shapes[1, sel] ** 2 / system.omega[sel] ** 2))
        assert flex == pytest.approx(bp.length**3 / (3.0 * ei), rel=1e-12)


def test_modal_damping_is_applied_in_modal_space():
    """Modal ratio: every normal mode has the ratio; each pseudo-mode the damping the all-modes
    matrix ``M Phi diag(2 zeta w) Phi^T M`` gives it (diagonal of ``B^T C B / 2w``, 1e-7; measured
    1e-9), computed without that matrix (it is not built). Rayleigh: ``alpha / 2w + beta w / 2``,
    equal to the projected physical matrix (the Ritz basis is M- and K-orthonormal)."""
    from dataclasses import replace

    p = load_rig().to_params()
    model = build_rig_model(replace(p, damping=DampingParams(ratio=0.013)))
    system = reduce_rig_model(model, keep_bases=True)
    assert model._damping is None  # the reduction never built the dense matrix
    np.testing.assert_array_equal(system.zeta[~system.pseudo], 0.013)
    for name, blade_id in (("active", 0), ("passive", 1)):
        off = model.offset(name)
        n = model.blade(name).n_dofs
        sel = system.blade == blade_id
        basis = system.bases[name]
        c = basis.T @ (model.damping[off : off + n, off : off + n] @ basis)  # dense reference
        np.testing.assert_allclose(system.zeta[sel], np.diag(c) / (2 * system.omega[sel]), rtol=1e-7)
    assert np.all(system.zeta[system.pseudo] < 0.013)  # the truncated modes' mean w is below w_p
    ray = build_rig_model(replace(p, damping=DampingParams(ratio=None, alpha=3.0, beta=2e-7)))
    system = reduce_rig_model(ray, keep_bases=True)
    np.testing.assert_allclose(system.zeta, 3.0 / (2 * system.omega) + 2e-7 * system.omega / 2, rtol=1e-12)
    basis = system.bases["active"]
    c = basis.T @ (ray.damping[: ray.active.n_dofs, : ray.active.n_dofs] @ basis)
    act = system.blade == 0
    np.testing.assert_allclose(np.diag(c) / (2 * system.omega[act]), system.zeta[act], rtol=1e-7)
