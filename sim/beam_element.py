"""Two-node 3D beam element (6 DOF per node): stiffness and consistent mass.

DOF order per node: (ux, uy, uz, rx, ry, rz); element DOFs are node a then node b (12 in all).
x runs along the beam, y is the thin ("flexural") direction, z the chord ("edgewise") direction.

Bending uses the interdependent interpolation of Friedman & Kosmatka (Computers & Structures 47,
1993, 473-481): the shape functions that solve the static Timoshenko equations exactly. With the
shear parameter ``phi = 12 E I / (kappa G A L^2)`` set to zero they are the cubic Hermite functions
of the Euler-Bernoulli element, so one code path serves both theories. The matrices are integrated
by Gauss-Legendre quadrature that is exact for these polynomials.

Sign conventions: in the x-y plane the section rotation is ``rz = dv/dx``; in the x-z plane it is
``ry = -dw/dx`` (right-hand rule), hence the sign flips when the planar matrix is scattered.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Exact for polynomials up to degree 11 (the products below are at most degree 6).
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(6)
_XI = 0.5 * (_GAUSS_X + 1.0)
_WXI = 0.5 * _GAUSS_W


@dataclass(frozen=True)
class Section:
    """Properties of a uniform beam section (SI).

    Attributes
    ----------
    youngs_modulus, shear_modulus, density
        Material.
    area
        Cross-section area, m^2.
    i_flexural
        Second moment of area for bending in y (moment about z), m^4.
    i_edgewise
        Second moment of area for bending in z (moment about y), m^4.
    torsion_constant
        Saint-Venant torsion constant, m^4.
    shear_coefficient
        Timoshenko shear coefficient kappa (same in both planes).
    """

    youngs_modulus: float
    shear_modulus: float
    density: float
    area: float
    i_flexural: float
    i_edgewise: float
    torsion_constant: float
    shear_coefficient: float

    @property
    def polar_inertia(self) -> float:
        """Polar second moment of area (for the torsional mass), m^4."""
        return self.i_flexural + self.i_edgewise


def rectangle_torsion_constant(width: float, thickness: float) -> float:
    """Saint-Venant torsion constant of a solid rectangle.

    Roark's formula ``J = a b^3 [1/3 - 0.21 (b/a) (1 - b^4 / (12 a^4))]`` with ``a >= b``
    (error below 0.5 % for every aspect ratio).
    """
    a, b = max(width, thickness), min(width, thickness)
    return a * b**3 * (1.0 / 3.0 - 0.21 * (b / a) * (1.0 - b**4 / (12.0 * a**4)))


def cowper_shear_coefficient(poisson: float) -> float:
    """Cowper's shear coefficient of a rectangle, ``10 (1 + nu) / (12 + 11 nu)``."""
    return 10.0 * (1.0 + poisson) / (12.0 + 11.0 * poisson)


def rectangular_section(
    width: float, thickness: float, youngs_modulus: float, density: float, poisson: float
) -> Section:
    """Section of a solid rectangular blade: ``width`` along z (chord), ``thickness`` along y."""
    return Section(
        youngs_modulus=youngs_modulus,
        shear_modulus=youngs_modulus / (2.0 * (1.0 + poisson)),
        density=density,
        area=width * thickness,
        i_flexural=width * thickness**3 / 12.0,
        i_edgewise=thickness * width**3 / 12.0,
        torsion_constant=rectangle_torsion_constant(width, thickness),
        shear_coefficient=cowper_shear_coefficient(poisson),
    )


def _shape_functions(xi: np.ndarray, length: float, phi: float):
    """Displacement N_v, rotation N_t and their x-derivatives at ``xi`` (rows), DOFs (v1, t1, v2, t2)."""
    L, c = length, 1.0 / (1.0 + phi)
    x1, x2, x3 = xi, xi**2, xi**3
    one = np.ones_like(xi)
    nv = c * np.stack(
        [
            2 * x3 - 3 * x2 - phi * x1 + (1 + phi) * one,
            L * (x3 - (2 + phi / 2) * x2 + (1 + phi / 2) * x1),
            -2 * x3 + 3 * x2 + phi * x1,
            L * (x3 - (1 - phi / 2) * x2 - (phi / 2) * x1),
        ],
        axis=1,
    )
    dnv = (
        c
        / L
        * np.stack(
            [
                6 * x2 - 6 * x1 - phi * one,
                L * (3 * x2 - (4 + phi) * x1 + (1 + phi / 2) * one),
                -6 * x2 + 6 * x1 + phi * one,
                L * (3 * x2 - (2 - phi) * x1 - (phi / 2) * one),
            ],
            axis=1,
        )
    )
    nt = c * np.stack(
        [
            6.0 / L * (x2 - x1),
            3 * x2 - (4 + phi) * x1 + (1 + phi) * one,
            6.0 / L * (x1 - x2),
            3 * x2 - (2 - phi) * x1,
        ],
        axis=1,
    )
    dnt = (
        c
        / L
        * np.stack(
            [
                6.0 / L * (2 * x1 - one),
                6 * x1 - (4 + phi) * one,
                6.0 / L * (one - 2 * x1),
                6 * x1 - (2 - phi) * one,
            ],
            axis=1,
        )
    )
    return nv, dnv, nt, dnt


def planar_bending(
    length: float,
    youngs_modulus: float,
    inertia: float,
    density: float,
    area: float,
    phi: float = 0.0,
    rotary_inertia: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and consistent mass (4x4) of a beam bending in one plane.

    Parameters
    ----------
    length
        Element length, m.
    youngs_modulus, inertia, density, area
        E (Pa), second moment of area (m^4), rho (kg/m^3), A (m^2).
    phi
        Shear parameter ``12 E I / (kappa G A L^2)``; 0 gives Euler-Bernoulli.
    rotary_inertia
        Include the distributed rotary inertia ``rho I`` of the section.

    Returns
    -------
    (K, M)
        4x4 arrays for DOFs (v1, theta1, v2, theta2), theta the section rotation.
    """
    nv, dnv, nt, dnt = _shape_functions(_XI, length, phi)
    w = _WXI * length
    ei = youngs_modulus * inertia
    k = ei * np.einsum("q,qi,qj->ij", w, dnt, dnt)
    if phi > 0.0:
        # kappa G A = 12 E I / (phi L^2)
        kga = 12.0 * ei / (phi * length**2)
        gamma = dnv - nt
        k = k + kga * np.einsum("q,qi,qj->ij", w, gamma, gamma)
    m = density * area * np.einsum("q,qi,qj->ij", w, nv, nv)
    if rotary_inertia:
        m = m + density * inertia * np.einsum("q,qi,qj->ij", w, nt, nt)
    return 0.5 * (k + k.T), 0.5 * (m + m.T)


_XY = np.array([1, 5, 7, 11])  # (uy, rz) at both nodes: theta = rz
_XZ = np.array([2, 4, 8, 10])  # (uz, ry) at both nodes: theta = -ry
_XZ_SIGN = np.array([1.0, -1.0, 1.0, -1.0])


def element_matrices(
    length: float,
    section: Section,
    theory: str = "euler-bernoulli",
    rotary_inertia: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """12x12 stiffness and consistent mass of a 3D beam element in its local axes.

    Parameters
    ----------
    length
        Element length, m.
    section
        Section and material (:class:`Section`).
    theory
        ``"euler-bernoulli"`` or ``"timoshenko"`` (shear deformation in both bending planes).
    rotary_inertia
        Include the distributed rotary inertia in bending (torsional inertia is always included).

    Returns
    -------
    (K, M)
        Symmetric 12x12 arrays, DOFs (ux, uy, uz, rx, ry, rz) of node a then node b.
    """
    if theory not in ("euler-bernoulli", "timoshenko"):
        raise ValueError(f"unknown beam theory {theory!r}")
    s = section
    K = np.zeros((12, 12))
    M = np.zeros((12, 12))
    bar = np.array([[1.0, -1.0], [-1.0, 1.0]])
    consistent = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0
    ax, tor = np.array([0, 6]), np.array([3, 9])
    K[np.ix_(ax, ax)] = s.youngs_modulus * s.area / length * bar
    M[np.ix_(ax, ax)] = s.density * s.area * length * consistent
    K[np.ix_(tor, tor)] = s.shear_modulus * s.torsion_constant / length * bar
    M[np.ix_(tor, tor)] = s.density * s.polar_inertia * length * consistent

    for idx, inertia, sign in ((_XY, s.i_flexural, None), (_XZ, s.i_edgewise, _XZ_SIGN)):
        phi = 0.0
        if theory == "timoshenko":
            phi = (
                12.0
                * s.youngs_modulus
                * inertia
                / (s.shear_coefficient * s.shear_modulus * s.area * length**2)
            )
        k4, m4 = planar_bending(length, s.youngs_modulus, inertia, s.density, s.area, phi, rotary_inertia)
        if sign is not None:
            k4 = k4 * np.outer(sign, sign)
            m4 = m4 * np.outer(sign, sign)
        K[np.ix_(idx, idx)] = k4
        M[np.ix_(idx, idx)] = m4
    return K, M
