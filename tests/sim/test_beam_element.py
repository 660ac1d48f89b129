"""The 3D beam element against the closed-form matrices of the textbooks, and rigid-body checks.

References: Przemieniecki, *Theory of Matrix Structural Analysis* (1968), sec. 5.6 (Timoshenko
stiffness with shear parameter phi) and 11.3 (consistent mass with rotary inertia); the
Euler-Bernoulli matrices are the phi = 0 case. Tolerances: 1e-12 relative (exact quadrature).
"""

import numpy as np
import pytest

from rigtools.sim.beam_element import (
    element_matrices,
    planar_bending,
    rectangle_torsion_constant,
    rectangular_section,
)

L, E, I, RHO, A = 0.0155, 2.0e11, 1.2e-10, 7850.0, 1.28e-4


def _timoshenko_stiffness(phi):
    return (
        E
        * I
        / ((1 + phi) * L**3)
        * np.array(
            [
                [12, 6 * L, -12, 6 * L],
                [6 * L, (4 + phi) * L**2, -6 * L, (2 - phi) * L**2],
                [-12, -6 * L, 12, -6 * L],
                [6 * L, (2 - phi) * L**2, -6 * L, (4 + phi) * L**2],
            ]
        )
    )


@pytest.mark.parametrize("phi", [0.0, 0.05, 0.7, 3.0])
def test_bending_stiffness_matches_closed_form(phi):
    k, _ = planar_bending(L, E, I, RHO, A, phi)
    ref = _timoshenko_stiffness(phi)
    assert np.allclose(k, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())


def test_euler_bernoulli_mass_matches_closed_form():
    _, m_trans = planar_bending(L, E, I, RHO, A, 0.0, rotary_inertia=False)
    ref_trans = (
        RHO
        * A
        * L
        / 420
        * np.array(
            [
                [156, 22 * L, 54, -13 * L],
                [22 * L, 4 * L**2, 13 * L, -3 * L**2],
                [54, 13 * L, 156, -22 * L],
                [-13 * L, -3 * L**2, -22 * L, 4 * L**2],
            ]
        )
    )
    assert np.allclose(m_trans, ref_trans, rtol=1e-12, atol=1e-14 * np.abs(ref_trans).max())
    _, m_all = planar_bending(L, E, I, RHO, A, 0.0, rotary_inertia=True)
    ref_rot = (
        RHO
        * I
        / (30 * L)
        * np.array(
            [
                [36, 3 * L, -36, 3 * L],
                [3 * L, 4 * L**2, -3 * L, -(L**2)],
                [-36, -3 * L, 36, -3 * L],
                [3 * L, -(L**2), -3 * L, 4 * L**2],
            ]
        )
    )
    assert np.allclose(m_all - m_trans, ref_rot, rtol=1e-10, atol=1e-12 * np.abs(ref_rot).max())


def test_timoshenko_mass_translational_part_closed_form():
    """Przemieniecki eq. (11.41), translational inertia, first row, for phi = 0.4."""
    phi = 0.4
    _, m = planar_bending(L, E, I, RHO, A, phi, rotary_inertia=False)
    c = RHO * A * L / (1 + phi) ** 2
    row = c * np.array(
        [
            13 / 35 + 7 * phi / 10 + phi**2 / 3,
            (11 / 210 + 11 * phi / 120 + phi**2 / 24) * L,
            9 / 70 + 3 * phi / 10 + phi**2 / 6,
            -(13 / 420 + 3 * phi / 40 + phi**2 / 24) * L,
        ]
    )
    assert np.allclose(m[0], row, rtol=1e-12)


def _rigid_modes(length):
    """Six rigid-body motions of a two-node element (columns): 3 translations, 3 rotations."""
    r = np.zeros((12, 6))
    for node, x in ((0, 0.0), (1, length)):
        o = 6 * node
        r[o : o + 3, 0:3] = np.eye(3)
        r[o + 3 : o + 6, 3:6] = np.eye(3)
        # u = theta x r with r = (x, 0, 0): rotation about y moves z by -x, about z moves y by +x
        r[o + 2, 4] = -x
        r[o + 1, 5] = x
    return r


@pytest.mark.parametrize("theory", ["euler-bernoulli", "timoshenko"])
def test_rigid_body_motions_are_strain_free_and_carry_the_mass(theory):
    section = rectangular_section(0.04, 0.0032, E, RHO, 0.3)
    k, m = element_matrices(L, section, theory)
    r = _rigid_modes(L)
    assert np.abs(k @ r).max() < 1e-9 * np.abs(k).max() * L
    mass = RHO * section.area * L
    assert np.allclose(np.diag(r.T @ m @ r)[:3], mass, rtol=1e-12)
    assert np.allclose(k, k.T) and np.allclose(m, m.T)


def test_torsion_constant_of_a_thin_strip():
    """J -> w t^3 / 3 for a thin strip; square: 0.1406 a^4 (Roark, table 10.7, within 0.5 %)."""
    assert rectangle_torsion_constant(1.0, 0.001) == pytest.approx(1e-9 / 3, rel=1e-3)
    assert rectangle_torsion_constant(1.0, 1.0) == pytest.approx(0.1406, rel=5e-3)
