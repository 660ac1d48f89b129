"""Analytical model (AM) of a blade bending in its thin (y) direction: the paper's verification partner.

It shares nothing with the FE matrices. Two parts:

* :func:`exact_flexural_frequencies` -- exact natural frequencies of the Euler-Bernoulli
  continuous beam carrying point masses with rotary inertia (shroud at the tip, force sensor at
  mid-span), clamped or on root springs, from the characteristic determinant. In each segment
  between masses ``w = a cos(bt) + b sin(bt) + c exp(-bt) + d exp(-b(l - t))`` (the exponential
  pair keeps the determinant well conditioned at high frequency); root, continuity and
  jump conditions at each mass (shear jump ``m w^2 w``, moment jump ``-J w^2 w'``) and the tip
  conditions give a square homogeneous system whose determinant vanishes at the natural
  frequencies. Roots are bracketed on a fine grid of ``lambda = beta L`` and refined by Brent's
  method.
* :func:`assumed_modes_blade` -- a Rayleigh-Ritz (assumed-modes) model for forced response:
  ``y(x, t) = sum_i psi_i(x) q_i(t)`` with the exact eigenfunctions of the blade with its masses
  as the assumed shapes; generalised mass and stiffness by quadrature over the segments, point
  masses added as ``m psi psi^T + J psi' psi'^T``. (The bare clamped-free eigenfunctions
  would converge only slowly here: they have zero tip moment and shear, while the shroud's
  inertia loads the tip.)
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from scipy.optimize import brentq

from rigtools.sim.params import BladeParams, LumpedMass, RootParams


def _flexural_scales(blade: BladeParams) -> tuple[float, float]:
    """(rho A, E I) of the blade for bending in y."""
    return blade.density * blade.area, blade.youngs_modulus * blade.i_flexural


def _mass_stations(
    blade: BladeParams, masses: list[LumpedMass]
) -> tuple[list[float], list[tuple[float, float]], tuple[float, float]]:
    """Interior stations (fractions of L), their (mu, j), and the tip (mu, j); masses at one point add."""
    rho_a, _ = _flexural_scales(blade)
    L = blade.length
    interior: dict[float, list[float]] = {}
    tip = [0.0, 0.0]
    for m in masses:
        s = m.position / L
        if not 0.0 < s <= 1.0 + 1e-12:
            raise ValueError(f"lumped mass at x = {m.position} m is not on the blade (0, {L}]")
        mu, j = m.mass / (rho_a * L), m.rotary_inertia / (rho_a * L**3)
        if s >= 1.0 - 1e-12:
            tip[0] += mu
            tip[1] += j
        else:
            key = round(s, 12)
            acc = interior.setdefault(key, [0.0, 0.0])
            acc[0] += mu
            acc[1] += j
    stations = sorted(interior)
    return stations, [(interior[s][0], interior[s][1]) for s in stations], (tip[0], tip[1])


def _basis(lam: np.ndarray, t: float, seg: float) -> np.ndarray:
    """Scaled derivatives D^k (k = 0..3, D = d/d(lambda t)) of the four basis functions at local t.

    Returns shape (n_lambda, 4 derivatives, 4 functions).
    """
    c, s = np.cos(lam * t), np.sin(lam * t)
    e = np.exp(-lam * t)
    g = np.exp(-lam * (seg - t))
    return np.stack(
        [
            np.stack([c, s, e, g], -1),
            np.stack([-s, c, -e, g], -1),
            np.stack([-c, -s, e, g], -1),
            np.stack([s, -c, -e, g], -1),
        ],
        axis=1,
    )


def characteristic_determinant(
    lam: np.ndarray,
    blade: BladeParams,
    masses: list[LumpedMass],
    root: RootParams,
    _matrix_out: dict | None = None,
) -> np.ndarray:
    """Determinant of the boundary/continuity system at ``lambda = beta L`` (vectorised).

    Zero exactly at the natural frequencies ``w = lambda^2 sqrt(E I / (rho A L^4))``.
    """
    lam = np.atleast_1d(np.asarray(lam, dtype=float))
    _, ei = _flexural_scales(blade)
    L = blade.length
    stations, interior, (mu_tip, j_tip) = _mass_stations(blade, masses)
    cuts = [0.0, *stations, 1.0]
    segs = np.diff(cuts)
    n_seg = len(segs)
    size = 4 * n_seg
    A = np.zeros((len(lam), size, size))
    row = 0
    # root
    d0 = _basis(lam, 0.0, segs[0])
    if root.kind == "clamped":
        A[:, row, 0:4] = d0[:, 0]
        A[:, row + 1, 0:4] = d0[:, 1]
    else:
        kr = root.rotational_stiffness * L / (ei * lam)
        kt = root.translational_stiffness * L**3 / (ei * lam**3)
        A[:, row, 0:4] = d0[:, 2] - kr[:, None] * d0[:, 1]
        A[:, row + 1, 0:4] = d0[:, 3] + kt[:, None] * d0[:, 0]
    row += 2
    # interfaces: continuity of w, w'; jumps of D2 and D3 from the mass
    for k, (mu, j) in enumerate(interior):
        left = _basis(lam, segs[k], segs[k])
        right = _basis(lam, 0.0, segs[k + 1])
        cl, cr = slice(4 * k, 4 * k + 4), slice(4 * k + 4, 4 * k + 8)
        for d in (0, 1):
            A[:, row, cl] = left[:, d]
            A[:, row, cr] = -right[:, d]
            row += 1
        # [D2] + j lam^3 D1 = 0   and   [D3] - mu lam D0 = 0   ([.] = right - left)
        A[:, row, cl] = -left[:, 2] + (j * lam**3)[:, None] * left[:, 1]
        A[:, row, cr] = right[:, 2]
        row += 1
        A[:, row, cl] = -left[:, 3] - (mu * lam)[:, None] * left[:, 0]
        A[:, row, cr] = right[:, 3]
        row += 1
    # tip: D2 - j lam^3 D1 = 0 ; D3 + mu lam D0 = 0
    dt = _basis(lam, segs[-1], segs[-1])
    A[:, row, -4:] = dt[:, 2] - (j_tip * lam**3)[:, None] * dt[:, 1]
    A[:, row + 1, -4:] = dt[:, 3] + (mu_tip * lam)[:, None] * dt[:, 0]
    if _matrix_out is not None:
        _matrix_out["A"] = A
    return np.linalg.det(A)


def _roots(fun, n: int, step: float = 0.004, start: float = 1e-3) -> np.ndarray:
    """First ``n`` sign changes of a vectorised function on a grid, refined by Brent's method."""
    found: list[float] = []
    lo = start
    while len(found) < n:
        grid = np.arange(lo, lo + 2000 * step, step)
        vals = fun(grid)
        idx = np.nonzero(np.sign(vals[:-1]) * np.sign(vals[1:]) < 0)[0]
        for i in idx:
            found.append(
                brentq(lambda z: float(fun(np.array([z]))[0]), grid[i], grid[i + 1], xtol=1e-14, rtol=1e-15)
            )
            if len(found) == n:
                break
        lo = grid[-1]
        if lo > 1e4:
            raise RuntimeError("characteristic determinant: roots not found")
    return np.array(found)


def exact_flexural_frequencies(
    blade: BladeParams, masses: list[LumpedMass], n: int, root: RootParams | None = None
) -> np.ndarray:
    """Exact Euler-Bernoulli flexural natural frequencies of a blade with point masses.

    Parameters
    ----------
    blade
        Geometry and material (bending in y: ``E I_flexural``, ``rho A``).
    masses
        Point masses with rotary inertia anywhere on ``(0, L]`` (the shroud at the tip, the force
        sensor in the span).
    n
        Number of frequencies.
    root
        Clamped (default) or springs (translational on y, rotational about z).

    Returns
    -------
    np.ndarray
        The first ``n`` natural frequencies, Hz.

    Examples
    --------
    The default rig's active blade with its force sensor and shroud (the finite elements give
    53.2, 361.9 and 1270.6 Hz, :func:`rigtools.sim.modal.flexural_frequencies`):

    >>> import numpy as np
    >>> import rigtools
    >>> from rigtools.sim.analytical import exact_flexural_frequencies
    >>> from rigtools.sim.rig_model import blade_masses
    >>> params = rigtools.load_rig().to_params()
    >>> f = exact_flexural_frequencies(params.active, blade_masses(params, "active"), 3, params.root)
    >>> np.round(f, 1)
    array([  53.2,  361.9, 1271.2])
    """
    root = root or RootParams()
    rho_a, ei = _flexural_scales(blade)
    lam = _roots(lambda z: characteristic_determinant(z, blade, masses, root), n)
    return lam**2 * np.sqrt(ei / (rho_a * blade.length**4)) / (2.0 * np.pi)


def tip_mass_frequency_equation(lam: np.ndarray, mu: float, j: float) -> np.ndarray:
    """Classical frequency equation of a clamped beam with tip mass ``mu = M/(rho A L)`` and tip
    rotary inertia ``j = J/(rho A L^3)`` (e.g. Laura et al., J. Sound Vib. 37, 1974; field notes):

    ``1 + cos l cosh l + mu l (cos l sinh l - sin l cosh l) - j l^3 (cosh l sin l + sinh l cos l)
    + mu j l^4 (1 - cos l cosh l) = 0``, divided by ``cosh l`` to stay finite.
    """
    lam = np.asarray(lam, dtype=float)
    c, s = np.cos(lam), np.sin(lam)
    th = np.tanh(lam)
    sech = 1.0 / np.cosh(lam)
    return sech + c + mu * lam * (c * th - s) - j * lam**3 * (s + th * c) + mu * j * lam**4 * (sech - c)


def tip_mass_lambdas(mu: float, j: float, n: int) -> np.ndarray:
    """First ``n`` roots ``lambda = beta L`` of :func:`tip_mass_frequency_equation`."""
    return _roots(lambda z: tip_mass_frequency_equation(z, mu, j), n, step=0.002)


# ---------------------------------------------------------------------------------------------
# assumed modes


def _system_matrix(lam: float, blade: BladeParams, masses: list[LumpedMass], root: RootParams) -> np.ndarray:
    """The square boundary/continuity matrix at one ``lambda`` (its null vector is the mode)."""
    holder: dict[str, np.ndarray] = {}
    characteristic_determinant(np.array([lam]), blade, masses, root, _matrix_out=holder)
    return holder["A"][0]


def _composite_gauss(a: float, b: float, panels: int, order: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of composite Gauss-Legendre quadrature on [a, b]."""
    g, w = np.polynomial.legendre.leggauss(order)
    edges = np.linspace(a, b, panels + 1)
    h = np.diff(edges)
    x = (edges[:-1, None] + 0.5 * h[:, None] * (g[None, :] + 1.0)).ravel()
    wt = (0.5 * h[:, None] * w[None, :]).ravel()
    return x, wt


@dataclass
class AssumedModesBlade:
    """Assumed-modes (Rayleigh-Ritz) model of a blade bending in y.

    ``y(x, t) = sum_i psi_i(x) q_i(t)``; the shapes ``psi_i`` are dimensionless (largest
    ``|psi_i| = 1`` on the blade, ``psi_i(L) > 0``), so ``q`` is in metres.

    Attributes
    ----------
    mass, stiffness
        (n, n) generalised mass (kg) and stiffness (N/m).
    length
        Blade length, m.
    lambdas
        ``beta L`` of each shape (the exact Euler-Bernoulli eigenvalues).
    cuts
        Segment ends as fractions of the length (masses sit at the inner cuts).
    coefficients
        (n, n_segments, 4) coefficients of the segment basis of each shape.
    """

    mass: np.ndarray
    stiffness: np.ndarray
    length: float
    lambdas: np.ndarray
    cuts: np.ndarray
    coefficients: np.ndarray
    _modes: tuple | None = field(default=None, repr=False, compare=False)

    @property
    def n(self) -> int:
        return self.mass.shape[0]

    def evaluate(self, x: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Shapes, slopes (1/m) and curvatures (1/m^2) at positions ``x`` (m): each (len(x), n)."""
        xi = np.atleast_1d(np.asarray(x, dtype=float)) / self.length
        if np.any(xi < -1e-12) or np.any(xi > 1 + 1e-12):
            raise ValueError("position outside the blade")
        seg = np.clip(np.searchsorted(self.cuts, xi, side="right") - 1, 0, len(self.cuts) - 2)
        out = np.zeros((3, len(xi), self.n))
        for k in np.unique(seg):
            sel = seg == k
            t = xi[sel] - self.cuts[k]
            length = self.cuts[k + 1] - self.cuts[k]
            for i, lam in enumerate(self.lambdas):
                b = _basis(np.full(len(t), lam), t, length)  # (nt, 4 derivs, 4 funcs)
                vals = b @ self.coefficients[i, k]  # (nt, 4 derivs)
                for d in range(3):
                    out[d, sel, i] = vals[:, d] * (lam / self.length) ** d
        return out[0], out[1], out[2]

    def shape(self, x: float) -> np.ndarray:
        """(n,) displacement shapes ``psi_i(x)``."""
        return self.evaluate(x)[0][0]

    def slope(self, x: float) -> np.ndarray:
        """(n,) slopes ``psi_i'(x)``, 1/m."""
        return self.evaluate(x)[1][0]

    def modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Natural frequencies (Hz, ascending) and mass-normalised eigenvectors (n, n) in q."""
        if self._modes is None:
            w2, vec = scipy.linalg.eigh(self.stiffness, self.mass)
            self._modes = (np.sqrt(np.clip(w2, 0.0, None)) / (2.0 * np.pi), vec)
        return self._modes

    def natural_frequencies(self, n: int | None = None) -> np.ndarray:
        """The first ``n`` natural frequencies of the generalised system, Hz."""
        f = self.modes()[0]
        return f[:n].copy() if n is not None else f.copy()


def assumed_modes_blade(
    blade: BladeParams,
    masses: list[LumpedMass],
    root: RootParams | None = None,
    n_terms: int = 12,
    rotary_inertia: bool = False,
) -> AssumedModesBlade:
    """Assumed-modes model of a blade with point masses (the paper's AM).

    The assumed shapes are the exact Euler-Bernoulli eigenfunctions of the blade with its masses
    and root (null vectors of the characteristic system of :func:`exact_flexural_frequencies`).
    Generalised mass and stiffness are then built independently, by quadrature of
    ``rho A psi psi^T`` and ``E I psi'' psi''^T`` over each segment plus ``m psi psi^T + J psi' psi'^T``
    at each mass and the root springs; orthogonality makes them diagonal up to round-off, and
    their eigenvalues reproduce the exact frequencies.

    Parameters
    ----------
    blade
        Geometry and material.
    masses
        Point masses with rotary inertia (shroud, force sensor).
    root
        Clamped (default) or springs.
    n_terms
        Number of generalised coordinates (shapes).
    rotary_inertia
        Add the distributed rotary inertia ``rho I int psi' psi'^T`` (Rayleigh beam); off by
        default, the AM being the Euler-Bernoulli verification partner.

    Returns
    -------
    AssumedModesBlade
    """
    root = root or RootParams()
    rho_a, ei = _flexural_scales(blade)
    L = blade.length
    lams = _roots(lambda z: characteristic_determinant(z, blade, masses, root), n_terms)
    stations, _, _ = _mass_stations(blade, masses)
    cuts = np.array([0.0, *stations, 1.0])
    coefs = np.empty((n_terms, len(cuts) - 1, 4))
    for i, lam in enumerate(lams):
        _, _, vt = np.linalg.svd(_system_matrix(lam, blade, masses, root))
        coefs[i] = vt[-1].reshape(len(cuts) - 1, 4)
    model = AssumedModesBlade(np.eye(n_terms), np.eye(n_terms), L, lams, cuts, coefs)
    # scale: largest |psi| = 1, positive at the tip
    grid = np.linspace(0.0, L, 801)
    psi = model.evaluate(grid)[0]
    scale = np.max(np.abs(psi), axis=0) * np.sign(psi[-1] + 1e-300 * (psi[-1] == 0))
    model.coefficients = coefs / scale[:, None, None]

    M = np.zeros((n_terms, n_terms))
    K = np.zeros((n_terms, n_terms))
    for a, b in itertools.pairwise(cuts):
        panels = max(4, int(np.ceil(lams[-1] * (b - a) / np.pi)) * 2)
        x, w = _composite_gauss(a * L, b * L, panels)
        # keep the quadrature nodes inside this segment's own basis
        x = np.clip(x, a * L * (1 + 1e-14), b * L * (1 - 1e-14))
        p, s, c = model.evaluate(x)
        M += rho_a * (p.T * w) @ p
        if rotary_inertia:
            M += blade.density * blade.i_flexural * (s.T * w) @ s
        K += ei * (c.T * w) @ c
    for m in masses:
        p, s, _ = model.evaluate(m.position)
        M += m.mass * np.outer(p[0], p[0]) + m.rotary_inertia * np.outer(s[0], s[0])
    if root.kind == "springs":
        p, s, _ = model.evaluate(0.0)
        K += root.translational_stiffness * np.outer(p[0], p[0]) + root.rotational_stiffness * np.outer(
            s[0], s[0]
        )
    model.mass = 0.5 * (M + M.T)
    model.stiffness = 0.5 * (K + K.T)
    return model
