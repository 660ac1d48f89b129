"""Linear harmonic response: static limit against beam formulas, FEM against AM, and a
direct frequency-domain solve of the full damped FE system."""

import dataclasses

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from rigtools.config import load_rig
from rigtools.sim.harmonic import LOCATIONS, am_harmonic_response, fem_harmonic_response, harmonic_curves
from rigtools.sim.rig_model import build_rig_model


@pytest.fixture(scope="module")
def params():
    return load_rig().to_params()


@pytest.fixture(scope="module")
def rig_eb(params):
    """FE without distributed rotary inertia: the same physics as the Euler-Bernoulli AM."""
    return build_rig_model(params, rotary_inertia=False)


def test_static_limit_matches_cantilever_formulas(params, rig_eb):
    """At f -> 0 a load P at a gives tip deflection P a^2 (3L - a) / (6 E I) and P a^3 / (3 E I)
    under it (Roark). FEM within 1e-6, AM (40 modes, truncated) within 1e-5."""
    bp, a = params.active, params.force_sensor.position
    ei, L = bp.youngs_modulus * bp.i_flexural, bp.length
    f = np.array([1e-3])
    fem = fem_harmonic_response(rig_eb, f, 1.0)
    am = am_harmonic_response(params, f, 1.0)
    for res, tol in ((fem, 1e-6), (am, 1e-5)):
        for blade in ("active", "passive"):
            assert res.displacement[f"{blade}_shroud"].real[0] == pytest.approx(
                a**2 * (3 * L - a) / (6 * ei), rel=tol
            )
            assert res.displacement[f"{blade}_force_point"].real[0] == pytest.approx(a**3 / (3 * ei), rel=tol)


def test_fem_and_am_curves_agree(params, rig_eb):
    """Same physics (EB, no distributed rotary inertia): every curve within 0.1 % everywhere."""
    f = np.linspace(10.0, 1500.0, 600)
    fem, am = harmonic_curves(rig_eb, f, 15.0)
    for loc in LOCATIONS:
        assert fem.displacement_amplitude(loc) == pytest.approx(am.displacement_amplitude(loc), rel=1e-3)
        assert fem.acceleration_amplitude(loc) == pytest.approx(am.acceleration_amplitude(loc), rel=1e-3)


def test_default_fem_peaks_match_am_peaks(params):
    """With the rotary inertia of the default FEM, resonance peak heights still within 1 %."""
    rig = build_rig_model(params)
    f = np.linspace(300.0, 420.0, 4001)
    fem, am = harmonic_curves(rig, f, 15.0)
    for loc in ("active_shroud", "active_force_point"):
        assert fem.acceleration_amplitude(loc).max() == pytest.approx(
            am.acceleration_amplitude(loc).max(), rel=1e-2
        )


def test_modal_superposition_equals_direct_solve(params):
    """Direct sparse solve of (K + i w C - w^2 M) x = F on the active blade, modal damping; 1e-6
    (the dense modal C makes the direct system ill-conditioned at the 1e-8 level)."""
    small = dataclasses.replace(
        params,
        active=dataclasses.replace(params.active, elements=30),
        passive=dataclasses.replace(params.passive, elements=30),
    )
    rig = build_rig_model(small)
    f = np.array([40.0, 200.0, 361.0, 900.0])
    fem = fem_harmonic_response(rig, f, 15.0)
    for k, fk in enumerate(f):
        w = 2 * np.pi * fk
        a = (rig.stiffness + 1j * w * rig.damping - w**2 * rig.mass).tocsc()
        rhs = np.zeros(rig.n_dofs, complex)
        rhs[rig.force_dof] = 15.0
        x = spla.spsolve(a, rhs)
        assert fem.displacement["active_shroud"][k] == pytest.approx(x[rig.active_tip_dof], rel=1e-6)
        assert fem.displacement["active_force_point"][k] == pytest.approx(x[rig.force_dof], rel=1e-6)
