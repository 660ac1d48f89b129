"""Reduced (modal) model of the two-blade rig for fast vibro-impact time stepping.

Per blade, the Ritz basis is the low normal modes that move the load points (flexural modes
below ``cutoff_hz``) plus the residual static shapes of the load DOFs (shroud uy, and the
force-sensor uy on the active blade): ``r = K^-1 e - Phi Omega^-2 Phi^T e`` (the static
correction / residual flexibility of MacNeal-Rubin). The residual shapes are M- and
K-orthogonal to the kept modes; re-diagonalising them gives a few high "pseudo-modes", so the
reduced model is a set of decoupled oscillators whose static flexibility at the load DOFs equals
the full model's exactly. Blades are coupled only by the contact force at their tip DOFs.

Only three rows of the basis are needed to step it: the y displacement per unit modal coordinate
at the active tip, the passive tip and the force point (:data:`ROWS`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg

from rigtools.sim.analytical import AssumedModesBlade, assumed_modes_blade
from rigtools.sim.deformation import BladeStiffness, blade_stiffness
from rigtools.sim.modal import lowest_modes
from rigtools.sim.params import ContactParams, DampingParams, RigParams, SimulationInputError
from rigtools.sim.rig_model import RigModel, blade_masses, build_rig_model
from rigtools.sim.threads import single_blas_thread

ROWS = ("active_tip", "passive_tip", "force_point")
ACTIVE, PASSIVE = 0, 1
DEFAULT_CUTOFF_HZ = 6000.0
MAX_MODAL_DAMPING_RATIO = 1.0e3  # beyond: absurd, and exp(A dt) of such a mode over/underflows


@dataclass(frozen=True)
class ReducedSystem:
    """Decoupled modal oscillators of both blades, coupled only by the shroud contact.

    Attributes
    ----------
    omega
        (n,) circular natural frequencies, rad/s (kept modes and pseudo-modes).
    zeta
        (n,) modal damping ratios.
    shapes
        (3, n) y displacement per unit (mass-normalised) modal coordinate at
        ``ROWS = (active_tip, passive_tip, force_point)``.
    blade
        (n,) 0 for an active-blade mode, 1 for a passive-blade mode.
    contact
        Contact law, stiffness, damping and gap.
    damping
        The damping description the ratios came from (for re-derivation after a change).
    source
        ``"fem"`` or ``"am"``.
    pseudo
        (n,) True for the static-correction pseudo-modes.
    bases
        Optional full-DOF Ritz vectors per blade, ``{"active": (n_dofs_a, n_a), "passive": ...}``,
        in the column order of the modes of that blade (for mapping to the full model).
    """

    omega: np.ndarray
    zeta: np.ndarray
    shapes: np.ndarray
    blade: np.ndarray
    contact: ContactParams
    damping: DampingParams
    source: str = "fem"
    pseudo: np.ndarray | None = None
    bases: dict | None = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        om = np.asarray(self.omega, dtype=float)
        ze = np.asarray(self.zeta, dtype=float)
        which = lambda j: "active" if int(np.asarray(self.blade)[j]) == ACTIVE else "passive"
        bad = np.flatnonzero(~(np.isfinite(om) & (om > 0)))
        if bad.size:
            j = int(bad[0])
            raise SimulationInputError(
                f"natural frequency {om[j] / (2 * np.pi):g} Hz of {which(j)} mode {j + 1}: the eigen-solve "
                f"failed (check the root springs, blade dimensions and material)"
            )
        bad = np.flatnonzero(~(np.isfinite(ze) & (ze >= 0) & (ze <= MAX_MODAL_DAMPING_RATIO)))
        if bad.size:
            j = int(bad[0])
            raise SimulationInputError(
                f"modal damping ratio {ze[j]:g} of {which(j)} mode {j + 1} ({om[j] / (2 * np.pi):.4g} Hz) is "
                f"outside [0, {MAX_MODAL_DAMPING_RATIO:g}]: check [damping] (Rayleigh alpha = "
                f"{self.damping.alpha:g} 1/s, beta = {self.damping.beta:g} s)"
            )
        if not np.isfinite(np.asarray(self.shapes, dtype=float)).all():
            raise SimulationInputError(
                "the mode shapes hold non-finite values: the eigen-solve failed "
                "(check the root springs, blade dimensions and material)"
            )

    @property
    def n_modes(self) -> int:
        return int(self.omega.size)

    @property
    def frequencies_hz(self) -> np.ndarray:
        return self.omega / (2.0 * np.pi)

    def tip_masses(self) -> tuple[float, float]:
        """Apparent mass of each shroud to an impulse: ``1 / sum_j phi_tip,j**2`` per blade, kg
        (``inf`` for a blade without modes: a rigid stop)."""
        a = float(np.sum(self.shapes[0, self.blade == ACTIVE] ** 2))
        p = float(np.sum(self.shapes[1, self.blade == PASSIVE] ** 2))
        return (1.0 / a if a > 0 else np.inf), (1.0 / p if p > 0 else np.inf)

    def contact_effective_mass(self) -> float:
        """The two shroud apparent masses in series, kg (sets the contact period)."""
        ma, mp = self.tip_masses()
        if np.isinf(mp):
            return ma
        if np.isinf(ma):
            return mp
        return ma * mp / (ma + mp)

    def with_contact(self, **changes) -> ReducedSystem:
        """The same system with contact parameters changed (``gap=...``, ``stiffness=...``)."""
        return replace(self, contact=replace(self.contact, **changes))

    def with_attached(self, mass: float, stiffness: float) -> ReducedSystem:
        """Add a point mass and a grounded spring at the force point (e.g. a shaker armature).

        The active blade's modes are re-diagonalised in the current basis
        (``M = I + m phi_F phi_F^T``, ``K = Omega^2 + k phi_F phi_F^T``). The blade's modal
        damping matrix ``diag(2 zeta w)`` is projected on the new modes and its diagonal kept
        (exact for a single mode; the attachment adds no damping). ``bases`` is dropped.
        """
        act = np.flatnonzero(self.blade == ACTIVE)
        pf = self.shapes[2, act]
        m = np.eye(act.size) + mass * np.outer(pf, pf)
        k = np.diag(self.omega[act] ** 2) + stiffness * np.outer(pf, pf)
        w2, t = scipy.linalg.eigh(k, m)
        omega = self.omega.copy()
        shapes = self.shapes.copy()
        omega[act] = np.sqrt(np.clip(w2, 0.0, None))
        shapes[:, act] = self.shapes[:, act] @ t
        pseudo = None if self.pseudo is None else self.pseudo.copy()
        if pseudo is not None:  # the highest ones remain the pseudo-modes
            n_ps = int(pseudo[act].sum())
            pseudo[act] = False
            if n_ps:
                pseudo[act[-n_ps:]] = True
        # the blade's own damping is unchanged by the attachment: project it, keep the diagonal
        c = t.T @ ((2.0 * self.zeta[act] * self.omega[act])[:, None] * t)
        zeta = self.zeta.copy()
        zeta[act] = np.diag(c) / (2.0 * omega[act])
        return replace(self, omega=omega, zeta=zeta, shapes=shapes, pseudo=pseudo, bases=None)


def damping_ratios(omega: np.ndarray, damping: DampingParams) -> np.ndarray:
    """Modal damping ratios: the given ratio for every mode, or Rayleigh ``alpha/2w + beta w/2``
    (a rigid-body mode, ``w = 0``, gets no mass-proportional part)."""
    omega = np.asarray(omega, dtype=float)
    if damping.ratio is not None:
        return np.full(omega.shape, float(damping.ratio))
    safe = np.where(omega > 0, omega, np.inf)
    return damping.alpha / (2.0 * safe) + damping.beta * omega / 2.0


def _blade_ritz(
    mass,
    stiffness: BladeStiffness,
    damping: DampingParams,
    modes_omega,
    modes_shapes,
    load_dofs,
    cutoff_hz,
    static_correction: bool,
):
    """Ritz basis of one blade: kept modes + re-diagonalised residual static shapes.

    Damping in modal space: a normal mode gets :func:`damping_ratios` of its frequency (Rayleigh
    damping is exactly diagonal on the M- and K-orthonormal basis). A pseudo-mode ``p`` stands for
    the truncated modes: with a modal ratio it gets ``zeta * p^T M (M^-1 K)^(1/2) p / w_p`` (what
    the all-modes damping matrix ``M Phi diag(2 zeta w) Phi^T M`` gives it), from a few Lanczos
    steps instead of every mode (:func:`_sqrt_stiffness_form`). Returns (omega, zeta, basis
    (n_dofs, n), pseudo flags).
    """
    rows = modes_shapes[load_dofs, :]
    scale = np.abs(rows).max()
    moves = np.abs(rows).max(axis=0) > 1e-9 * scale  # modes the loads can excite / we can see
    keep = moves & (modes_omega < 2.0 * np.pi * cutoff_hz)
    phi = modes_shapes[:, keep]
    om = modes_omega[keep]
    parts, omegas, pseudo = [phi], [om], [np.zeros(om.size, bool)]
    if static_correction:
        e = np.zeros((mass.shape[0], len(load_dofs)))
        e[load_dofs, np.arange(len(load_dofs))] = 1.0
        # r = K^-1 e - Phi Omega^-2 Phi^T e is ~1e-6 of K^-1 e at the shroud: subtracting the two
        # leaves round-off that is not M-orthogonal to the kept modes (0.03-0.4 % of r, varying
        # with BLAS kernel and thread count; on a fine mesh more than r itself), and the
        # pseudo-modes then carry part of the kept modes' mass (shroud mass off by up to 0.9 %).
        # Solving for the load with the kept modes' share removed, K r = e - M Phi Phi^T e (the
        # same r, no cancellation), then removing what the kept modes' own round-off leaks back,
        # gives r M-orthogonal to round-off. The solve and the projected stiffness go through the
        # element deformations (rigtools.sim.deformation): a sparse LU of K, and r^T K r
        # formed with K, lose ~n^4 eps (7.5e-4 of the static deflection at 6400 elements).
        resid = stiffness.solve(e - mass @ (phi @ phi[load_dofs, :].T))
        resid -= phi @ (phi.T @ (mass @ resid))
        mr = resid.T @ (mass @ resid)
        kr = stiffness.form(resid)
        # drop directions with no residual flexibility left (all relevant modes already kept)
        flex = np.diag(resid[load_dofs, :])
        static = flex + np.sum(phi[load_dofs, :] ** 2 / om**2, axis=1)
        ok = flex > 1e-9 * np.abs(static)
        if ok.any():
            w2, t = scipy.linalg.eigh(kr[np.ix_(ok, ok)], mr[np.ix_(ok, ok)])
            parts.append(resid[:, ok] @ t)
            omegas.append(np.sqrt(w2))
            pseudo.append(np.ones(w2.size, bool))
    basis = np.hstack(parts)
    omega = np.concatenate(omegas)
    flags = np.concatenate(pseudo)
    zeta = damping_ratios(omega, damping)
    if damping.ratio is not None:
        for j in np.flatnonzero(flags):
            zeta[j] = damping.ratio * _sqrt_stiffness_form(stiffness, mass, basis[:, j]) / omega[j]
    return omega, zeta, basis, flags


def _sqrt_stiffness_form(stiffness: BladeStiffness, mass, x: np.ndarray, steps: int = 40) -> float:
    """``x^T M (M^-1 K)^(1/2) x`` = ``sum_j (phi_j^T M x)^2 w_j`` over all modes, without them.

    Gauss quadrature by Lanczos on ``B = K^-1 M`` (self-adjoint in the M inner product, spectrum
    ``1 / w_j^2``; ``stiffness.solve`` applies ``K^-1``): ``||x||_M^2 e1^T T^(-1/2) e1`` with T the tridiagonal
    Lanczos matrix. A residual static shape weighs mode j with ``(1 / w_j^2)^2``, so the first
    truncated modes dominate and a few dozen steps reach round-off (checked against all modes
    in tests/sim/test_reduction.py).
    """
    mx = mass @ x
    norm2 = float(x @ mx)
    q = x / np.sqrt(norm2)
    basis, mbasis = [q], [mx / np.sqrt(norm2)]
    alphas: list[float] = []
    betas: list[float] = []
    for _ in range(min(steps, x.size)):
        w = stiffness.solve(mbasis[-1])
        alphas.append(float(w @ mbasis[-1]))
        for v, mv in zip(basis, mbasis, strict=True):  # full reorthogonalisation (M inner product)
            w -= (w @ mv) * v
        mw = mass @ w
        beta = float(np.sqrt(max(w @ mw, 0.0)))
        if beta <= 1e-12 * abs(alphas[0]):
            break
        betas.append(beta)
        basis.append(w / beta)
        mbasis.append(mw / beta)
    k = len(alphas)
    theta, vecs = scipy.linalg.eigh_tridiagonal(np.array(alphas), np.array(betas[: k - 1]))
    theta = np.clip(theta, np.finfo(float).tiny, None)
    return norm2 * float(np.sum(vecs[0] ** 2 / np.sqrt(theta)))


def reduce_rig_model(
    model: RigModel,
    cutoff_hz: float = DEFAULT_CUTOFF_HZ,
    static_correction: bool = True,
    keep_bases: bool = False,
) -> ReducedSystem:
    """Reduce the FE rig model (:class:`rigtools.sim.rig_model.RigModel`) to decoupled modal oscillators.

    Parameters
    ----------
    model
        The FE model of both blades.
    cutoff_hz
        Keep the normal modes below this frequency that move a load DOF (about 3x the highest
        harmonic of interest; the default covers 30 x 60 Hz with margin).
    static_correction
        Add the residual static shapes of the load DOFs (recommended; without it the contact
        flexibility of the truncated modes is missing).
    keep_bases
        Keep the full-DOF Ritz vectors (for mapping states to the full model).

    Returns
    -------
    ReducedSystem
        Damping ratios are those of :func:`damping_ratios` (modal damping applied in modal
        space: the Ritz basis diagonalises modal-ratio and Rayleigh damping).

    Notes
    -----
    Only the modes below ``cutoff_hz`` of the DOF groups holding the load DOFs are computed
    (sparse shift-invert, :func:`rigtools.sim.modal.lowest_modes`): time and memory grow linearly
    with the element count, and the kept modes do not depend on the mesh once it resolves them.
    """
    parts = []
    # small dense solves and banded factorisations: BLAS threads only add overhead (and make
    # the time erratic on a busy machine), whatever the caller's process set
    with single_blas_thread():
        for name in ("active", "passive"):
            blade = model.blade(name)
            tip = blade.dof(blade.tip_node, 1)
            loads = [tip] if blade.sensor_node is None else [tip, blade.dof(blade.sensor_node, 1)]
            modes = lowest_modes(blade, below_hz=cutoff_hz, dofs=loads)
            om, z, basis, ps = _blade_ritz(
                blade.mass,
                blade_stiffness(blade),
                model.params.damping,
                modes.omegas,
                modes.shapes,
                loads,
                cutoff_hz,
                static_correction,
            )
            parts.append((om, z, basis, ps, tip, loads))
    (om_a, z_a, b_a, ps_a, tip_a, loads_a), (om_p, z_p, b_p, ps_p, tip_p, _) = parts
    n1, n2 = om_a.size, om_p.size
    shapes = np.zeros((3, n1 + n2))
    shapes[0, :n1] = b_a[tip_a]
    shapes[1, n1:] = b_p[tip_p]
    shapes[2, :n1] = b_a[loads_a[1]]
    return ReducedSystem(
        omega=np.concatenate([om_a, om_p]),
        zeta=np.concatenate([z_a, z_p]),
        shapes=shapes,
        blade=np.r_[np.zeros(n1, int), np.ones(n2, int)],
        contact=model.params.contact,
        damping=model.params.damping,
        source="fem",
        pseudo=np.concatenate([ps_a, ps_p]),
        bases={"active": b_a, "passive": b_p} if keep_bases else None,
    )


def reduce_assumed_modes(
    active: AssumedModesBlade,
    passive: AssumedModesBlade,
    params: RigParams,
    force_position: float | None = None,
    cutoff_hz: float | None = None,
) -> ReducedSystem:
    """Reduced system from two assumed-modes blades (:class:`rigtools.sim.analytical.AssumedModesBlade`).

    Each blade's generalised ``mass``/``stiffness`` is diagonalised; the rows are the mode
    shapes evaluated by ``shape(x)`` at the tips (blade length) and at the force sensor.

    Parameters
    ----------
    active, passive
        Assumed-modes models of the two blades (with their lumped masses).
    params
        :class:`rigtools.sim.params.RigParams` (lengths, sensor position, contact, damping).
    force_position
        Where the force acts on the active blade, m (default: the force sensor position).
    cutoff_hz
        Keep only modes below this frequency (default: all).
    """
    xf = params.force_sensor.position if force_position is None else force_position
    omegas, rows, blades = [], [], []
    for idx, (am, length) in enumerate(((active, params.active.length), (passive, params.passive.length))):
        w2, t = scipy.linalg.eigh(np.asarray(am.stiffness, float), np.asarray(am.mass, float))
        om = np.sqrt(np.clip(w2, 0.0, None))
        keep = np.ones(om.size, bool) if cutoff_hz is None else om < 2 * np.pi * cutoff_hz
        t, om = t[:, keep], om[keep]
        r = np.zeros((3, om.size))
        r[idx] = np.asarray(am.shape(length)) @ t
        if idx == ACTIVE:
            r[2] = np.asarray(am.shape(xf)) @ t
        omegas.append(om)
        rows.append(r)
        blades.append(np.full(om.size, idx))
    omega = np.concatenate(omegas)
    return ReducedSystem(
        omega=omega,
        zeta=damping_ratios(omega, params.damping),
        shapes=np.hstack(rows),
        blade=np.concatenate(blades),
        contact=params.contact,
        damping=params.damping,
        source="am",
        pseudo=np.zeros(omega.size, bool),
    )


def reduced_system(
    params: RigParams,
    model: str = "fem",
    cutoff_hz: float = DEFAULT_CUTOFF_HZ,
    n_terms: int = 12,
    rig_model: RigModel | None = None,
) -> ReducedSystem:
    """The reduced system of a rig, from the FE model (``"fem"``) or the assumed-modes model
    (``"am"``, all of its ``n_terms`` shapes per blade).

    Parameters
    ----------
    params
        :class:`rigtools.sim.params.RigParams`.
    model
        ``"fem"`` or ``"am"``.
    cutoff_hz
        Highest normal mode kept (FEM).
    n_terms
        Assumed modes per blade (AM only).
    rig_model
        An already built :class:`rigtools.sim.rig_model.RigModel` of ``params`` (FEM only).

    Examples
    --------
    The default rig's finite elements reduced to the modes below 6 kHz (and the static correction):

    >>> import numpy as np
    >>> import rigtools
    >>> from rigtools.sim.reduction import reduced_system
    >>> system = reduced_system(rigtools.load_rig().to_params(), "fem")
    >>> system.n_modes, np.round(system.omega[:2] / (2 * np.pi), 2)
    (14, array([ 53.21, 361.88]))
    """
    if model == "fem":
        return reduce_rig_model(rig_model if rig_model is not None else build_rig_model(params), cutoff_hz)
    if model == "am":
        passive_root = params.root_of("passive")
        act = assumed_modes_blade(params.active, blade_masses(params, "active"), params.root, n_terms)
        pas = assumed_modes_blade(params.passive, blade_masses(params, "passive"), passive_root, n_terms)
        # all shapes are kept: the AM has no static correction, its higher shapes supply it
        return reduce_assumed_modes(act, pas, params)
    raise ValueError(f"model must be 'fem' or 'am', got {model!r}")


# Rough cost of building and reducing the FE model (sparse, only the modes kept, polished through
# the element deformations), measured on the reference machine (2 shared cores under load, 2026,
# benchmarks/bench_model_build.py): 0.03-0.10 / 0.05-0.17 / 0.13-0.44 / 0.51-1.55 s at 100 / 400 /
# 1600 / 6400 elements per blade, 1.4-4.5 s at 20000 (the dense all-modes build it replaced took
# 0.5 / 13 s at 100 / 400, issue 8 saw 230 s at 2000). Only for telling a user up front.
_REDUCTION_SECONDS_AT_100 = 0.1
_REDUCTION_EXPONENT = 0.7


def estimate_reduction_seconds(params: RigParams) -> float:
    """Rough wall time, s, of :func:`reduced_system` with the FE model for ``params``
    (``0.1 s * (elements / 100) ** 0.7``, elements averaged over both blades)."""
    elements = 0.5 * (params.active.elements + params.passive.elements)
    return _REDUCTION_SECONDS_AT_100 * (elements / 100.0) ** _REDUCTION_EXPONENT
