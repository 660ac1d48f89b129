"""Modal analysis of a blade: frequencies, mass-normalised shapes, and the kind of each mode.

The generalized symmetric eigenproblem ``K phi = w^2 M phi`` is solved one uncoupled DOF group at
a time (for a symmetric section: axial, the two bending planes, torsion):

* :func:`lowest_modes` -- only the modes asked for (the lowest ``n``, or those below a frequency),
  first by the shift-invert Lanczos solver (:func:`scipy.sparse.linalg.eigsh` at 0, ``K^-1``
  applied through the element deformations of :mod:`rigtools.sim.deformation`, no factorisation;
  small groups densely by LAPACK), then polished by subspace iteration through the same
  deformations (Rayleigh-Ritz with energies summed per element): time and memory
  grow linearly with the element count, and the modes are accurate to ~1e-15 relative at any
  mesh (the assembled stiffness alone leaves ~n^4 eps: 3e-8 at 100 elements, 4e-5 at 6400). The
  model build and the reduction use this.
* :func:`blade_modes` without ``n_modes`` -- every mode (dense, O(n^3) in time and O(n^2) in
  memory, on the flexibility so that the low modes are at round-off): for the full-order
  reference integrator, the harmonic superposition over all modes, and the tests; at most
  :data:`DENSE_MAX_ELEMENTS` elements per blade.

Each mode is classified by where its kinetic energy ``phi_i (M phi)_i`` sits: uy and rz ->
``flexural`` (bending in the thin, impact direction), uz and ry -> ``edgewise``, rx ->
``torsional``, ux -> ``axial``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

from rigtools.sim.blade import BladeModel
from rigtools.sim.deformation import (
    BladeInertia,
    BladeStiffness,
    blade_inertia,
    blade_stiffness,
    deformation_form,
)
from rigtools.sim.params import SimulationInputError
from rigtools.sim.threads import single_blas_thread

KINDS = ("axial", "flexural", "edgewise", "torsional")
#: DOF groups up to this size (or asked for a third of their modes) get their first approximations
#: densely (all their modes): faster than Lanczos there.
DENSE_GROUP_MAX = 120
#: Every mode of a blade (dense LAPACK: O(n^3) time, O(n^2) memory) only up to this many elements
#: per blade (one blade of the default rig, measured: 1.5 s and 0.3 GB at 500 elements, 7.4 s and
#: 1.1 GB at 1000, so about a minute and 4 GB at 2000); the sparse paths reach MAX_ELEMENTS.
DENSE_MAX_ELEMENTS = 2000
# subspace iteration that polishes the modes (_refine): at least this many guard vectors, stop
# when the wanted shapes move less than this (M-norm; the frequencies then move ~its square), or
# after this many steps (a step costs a few passes over the mesh)
_GUARD_MIN = 4
# columns of the flexibility built per pass in _all_modes (bounds the temporary arrays)
_FLEX_COLUMNS = 256
_REFINE_TOL = 1e-9
_REFINE_MAX_STEPS = 30
# component (ux, uy, uz, rx, ry, rz) -> index into KINDS
_KIND_OF_COMPONENT = np.array([0, 1, 2, 3, 2, 1])


@dataclass
class Modes:
    """Modes of a blade.

    Attributes
    ----------
    frequencies_hz
        (n,) natural frequencies, ascending, Hz.
    shapes
        (n_dofs, n) mass-normalised shapes (``Phi^T M Phi = I``).
    kinds
        ``"flexural"``, ``"edgewise"``, ``"torsional"`` or ``"axial"`` per mode.
    """

    frequencies_hz: np.ndarray
    shapes: np.ndarray
    kinds: list[str]

    @property
    def omegas(self) -> np.ndarray:
        """Circular natural frequencies, rad/s."""
        return 2.0 * np.pi * self.frequencies_hz

    def of_kind(self, kind: str) -> Modes:
        """The modes of one kind only, in ascending order."""
        sel = [i for i, k in enumerate(self.kinds) if k == kind]
        return Modes(self.frequencies_hz[sel], self.shapes[:, sel], [self.kinds[i] for i in sel])


def _groups(blade: BladeModel) -> list[np.ndarray]:
    """Free-DOF indices of each DOF group that no matrix entry couples, cached on the blade."""
    if "groups" not in blade._cache:
        pattern = (abs(blade.stiffness) + abs(blade.mass)).tocsr()
        n_groups, labels = connected_components(pattern, directed=False)
        order = np.argsort(labels, kind="stable")
        bounds = np.searchsorted(labels[order], np.arange(n_groups + 1))
        blade._cache["groups"] = [order[bounds[g] : bounds[g + 1]] for g in range(n_groups)]
    return blade._cache["groups"]


def _assemble(blade: BladeModel, parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> Modes:
    """Modes from per-group ``(dof indices, w^2, vectors)``, ascending in frequency."""
    n = blade.n_dofs
    w2 = np.concatenate([p[1] for p in parts]) if parts else np.empty(0)
    phi = np.zeros((n, w2.size))
    col = 0
    for idx, _, vecs in parts:
        phi[idx, col : col + vecs.shape[1]] = vecs
        col += vecs.shape[1]
    order = np.argsort(w2, kind="stable")
    w2 = np.clip(w2[order], 0.0, None)
    phi = _signed(phi[:, order])
    return Modes(np.sqrt(w2) / (2.0 * np.pi), phi, classify_modes(blade, phi))


def check_dense(blade: BladeModel, what: str) -> None:
    """Refuse every mode of a blade finer than :data:`DENSE_MAX_ELEMENTS` (one line naming ``what``).

    Raises
    ------
    SimulationInputError
        The dense eigen-solve would take minutes to hours and gigabytes.
    """
    elements = len(blade.node_x) - 1
    if elements > DENSE_MAX_ELEMENTS:
        raise SimulationInputError(
            f"{what} needs every mode of the {blade.name} blade, a dense eigen-solve that grows as "
            f"elements^3: at most {DENSE_MAX_ELEMENTS} elements per blade, got {elements}"
        )


def _signed(phi: np.ndarray) -> np.ndarray:
    """Each shape with the sign that makes its first clearly nonzero entry (above 1e-6 of its
    largest) positive: near a clamped root the displacement, or on fine meshes the rotation --
    both the sign of the root curvature. A shape's sign is arbitrary, but whatever is built on
    the modes (a continuation's branch switching, for one) should not depend on the solver."""
    big = np.abs(phi) > 1e-6 * np.abs(phi).max(axis=0)
    first = phi[np.argmax(big, axis=0), np.arange(phi.shape[1])]
    return phi * np.where(first < 0, -1.0, 1.0)


def _all_modes(blade: BladeModel) -> Modes:
    """Every mode of the blade (dense, per DOF group), cached on it.

    Solved for ``mu = 1 / w^2`` of the flexibility, ``M F M y = mu M y`` with ``F = K^-1`` built
    column by column through the element deformations (:meth:`BladeStiffness.solve`): LAPACK's
    error is ~eps times the largest ``mu``, so the low modes, which carry the response, are
    accurate to round-off relative to themselves (``eigh(K, M)`` puts that error on the highest
    ``w^2`` instead, ~n^4 eps relative on the lowest: 1e-8 at 100 elements, 1e-3 at 2000).
    """
    if "modes" not in blade._cache:
        check_dense(blade, "this computation (full-order model, harmonic response over all modes)")
        stiffness, M = blade_stiffness(blade), blade.mass
        parts = []
        with single_blas_thread():
            for idx in _groups(blade):
                flex = np.empty((idx.size, idx.size))
                for start in range(0, idx.size, _FLEX_COLUMNS):
                    cols = idx[start : start + _FLEX_COLUMNS]
                    unit = np.zeros((blade.n_dofs, cols.size))
                    unit[cols, np.arange(cols.size)] = 1.0
                    flex[:, start : start + cols.size] = stiffness.solve(unit)[idx]
                mg = M[idx][:, idx].toarray()
                mu, vecs = scipy.linalg.eigh(mg @ (0.5 * (flex + flex.T)) @ mg, mg)
                mu, vecs = mu[::-1], vecs[:, ::-1]
                # the highest modes of a fine mesh without rotary inertia can reach mu ~ eps mu_1
                vals = 1.0 / np.maximum(mu, np.finfo(float).eps * mu[0])
                parts.append((idx, vals, vecs))
        blade._cache["modes"] = _assemble(blade, parts)
    return blade._cache["modes"]


def _group_lowest(kg, mg, n: int | None, below_w2: float | None, guard: int, solve):
    """First approximations of the lowest modes of one group: ``n`` of them, or all below
    ``below_w2`` (at least one), plus up to ``guard`` more when the solver found them.

    ``solve`` applies the group's ``K^-1`` (through the element deformations: no factorisation).
    Returns ``(w^2, vectors, wanted)``: ascending, the first ``wanted`` are the modes asked for.
    """
    size = kg.shape[0]
    k = min(size - 2, max(8, (n or 8) + guard))
    if size <= DENSE_GROUP_MAX or 3 * k >= size:
        vals, vecs = scipy.linalg.eigh(kg.toarray(), mg.toarray())
    else:
        mg = mg.tocsc()
        opinv = spla.LinearOperator(kg.shape, matvec=solve, dtype=float)
        # a fixed start: ARPACK's own random one differs from run to run, and so would the modes'
        # last bits (and whatever a vibro-impact run or a fit makes of them)
        start = np.random.default_rng(0).standard_normal(size)
        while True:
            vals, vecs = spla.eigsh(kg, k=k, M=mg, sigma=0.0, which="LM", OPinv=opinv, v0=start)
            order = np.argsort(vals)
            vals, vecs = vals[order], vecs[:, order]
            enough = (n is not None and vals.size >= n) or (below_w2 is not None and vals[-1] >= below_w2)
            if enough or k >= size - 2:
                break
            k = min(size - 2, 2 * k)
    wanted = vals.size if n is None else min(n, vals.size)
    if below_w2 is not None:
        wanted = max(1, int(np.searchsorted(vals, below_w2)))
    keep = min(vals.size, wanted + guard)
    return vals[:keep], vecs[:, :keep], wanted


def _group_solve(stiffness: BladeStiffness, idx: np.ndarray):
    """``x -> (K^-1 x)[idx]`` for ``x`` over the DOF group ``idx`` (the groups are uncoupled)."""

    def solve(x: np.ndarray) -> np.ndarray:
        full = np.zeros(stiffness.free_dofs.size)
        full[idx] = x
        return stiffness.solve(full)[idx]

    return solve


def _guard(wanted: int) -> int:
    """Extra vectors carried by the subspace iteration beside the ``wanted`` modes."""
    return max(_GUARD_MIN, wanted // 2)


def _refine(
    stiffness: BladeStiffness, inertia: BladeInertia, idx: np.ndarray, mg, vecs: np.ndarray, wanted: int
) -> tuple[np.ndarray, np.ndarray]:
    """Polish the lowest ``wanted`` modes of one DOF group by subspace (block inverse) iteration.

    The first approximations (LAPACK or Lanczos on the assembled matrices) carry the round-off of
    the assembled stiffness (relative ~n^4 eps: 1e-8 in frequency at 100 elements, 4e-5 at 6400).
    Each step applies ``K^-1 M`` through the element deformations
    (:meth:`rigtools.sim.deformation.BladeStiffness.solve_deformations`: no factorisation, no
    cancellation) and takes the Rayleigh-Ritz pairs with the projected stiffness summed per
    element (``y_i^T K y_j = z_i^T g_j``, every term an element's own energy). The error of mode
    ``i`` shrinks by ``w_i^2 / w_(p+1)^2`` per step (``p`` vectors in all); the steps stop when
    the wanted shapes move less than :data:`_REFINE_TOL` (M-norm), or stall.

    Returns ``(w^2, mass-normalised vectors)`` of the ``wanted`` modes.
    """
    size = len(idx)
    p = wanted + _guard(wanted)
    if p >= size:  # a group this small is solved densely at round-off already (a few elements)
        return _rayleigh_ritz(stiffness, inertia, idx, mg, vecs[:, :wanted])
    v = vecs[:, :p]
    if v.shape[1] < p:  # random guard vectors: the iteration turns them into the next modes
        rng = np.random.default_rng(0)
        v = np.hstack([v, rng.standard_normal((size, p - v.shape[1]))])
    previous = np.inf
    w2 = np.empty(0)
    for _ in range(_REFINE_MAX_STEPS):
        w2, new = _rayleigh_ritz(stiffness, inertia, idx, mg, v, inverse_step=True)
        d = (new - v)[:, :wanted]
        s = (new + v)[:, :wanted]
        moved = np.sqrt(np.minimum(np.sum(d * (mg @ d), axis=0), np.sum(s * (mg @ s), axis=0))).max()
        v = new
        if moved < _REFINE_TOL or moved > 0.5 * previous:
            break
        previous = moved
    return w2[:wanted], v[:, :wanted]


def _rayleigh_ritz(
    stiffness: BladeStiffness,
    inertia: BladeInertia,
    idx: np.ndarray,
    mg,
    v: np.ndarray,
    inverse_step: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Ritz pairs of (K, M) in span(v), or in span(K^-1 M v) with ``inverse_step``, with the
    projected stiffness from the element deformations and the projected mass with the rotary
    inertia summed per element (:class:`rigtools.sim.deformation.BladeInertia`); ascending,
    mass-normalised."""
    full = np.zeros((stiffness.free_dofs.size, v.shape[1]))
    if inverse_step:
        full[idx] = mg @ v
        z, g = stiffness.solve_deformations(full)
        y = stiffness.displacements(z)[idx]
        kp = deformation_form(z, g)
    else:
        y = v
        full[idx] = y
        kp = stiffness.form(full)
    full[idx] = y
    mp = inertia.form(full)
    # unit M-norm columns: the projected matrices stay well scaled whatever the spread of w
    scale = 1.0 / np.sqrt(np.diag(mp))
    y = y * scale
    kp = kp * np.outer(scale, scale)
    mp = mp * np.outer(scale, scale)
    kp, mp = 0.5 * (kp + kp.T), 0.5 * (mp + mp.T)
    _, q = scipy.linalg.eigh(kp, mp)
    # eigh's eigenvalues carry eps * w_p^2 in absolute terms (1e-12 of w_1^2 when w_p is 10 w_1);
    # the Rayleigh quotients of its vectors are accurate to eps relative to each w^2 (second
    # order in the vectors' error)
    w2 = np.einsum("ji,jk,ki->i", q, kp, q) / np.einsum("ji,jk,ki->i", q, mp, q)
    order = np.argsort(w2)
    return w2[order], y @ q[:, order]


def lowest_modes(
    blade: BladeModel,
    n_modes: int | None = None,
    below_hz: float | None = None,
    dofs: list[int] | np.ndarray | None = None,
) -> Modes:
    """The lowest modes of a blade, computed sparsely (time and memory linear in the mesh).

    Parameters
    ----------
    blade
        The blade model.
    n_modes
        How many modes, lowest first.
    below_hz
        Or every mode below this frequency, Hz (plus the lowest of each group if none is).
    dofs
        Only the DOF groups holding these free DOFs (modes of the other groups do not move
        them at all, e.g. a load and its response in y only need the flexural group).

    Returns
    -------
    Modes
        Frequencies (Hz, ascending), mass-normalised shapes over the blade's free DOFs, kinds.
    """
    if (n_modes is None) == (below_hz is None):
        raise ValueError("give n_modes or below_hz")
    key = ("lowest", n_modes, below_hz, None if dofs is None else tuple(int(d) for d in dofs))
    if key not in blade._cache:
        groups = _groups(blade)
        if dofs is not None:
            wanted = {int(d) for d in dofs}
            groups = [g for g in groups if wanted.intersection(g.tolist())]
        below_w2 = None if below_hz is None else (2.0 * np.pi * float(below_hz)) ** 2
        K, M = blade.stiffness, blade.mass
        accurate, inertia = blade_stiffness(blade), blade_inertia(blade)
        parts = []
        with single_blas_thread():
            for idx in groups:
                mg = M[idx][:, idx]
                guard = _guard(n_modes or 8)
                solve = _group_solve(accurate, idx)
                _, vecs, wanted = _group_lowest(K[idx][:, idx], mg, n_modes, below_w2, guard, solve)
                vals, vecs = _refine(accurate, inertia, idx, mg, vecs, wanted)
                parts.append((idx, vals, vecs))
        modes = _assemble(blade, parts)
        if n_modes is not None:
            modes = Modes(modes.frequencies_hz[:n_modes], modes.shapes[:, :n_modes], modes.kinds[:n_modes])
        blade._cache[key] = modes
    return blade._cache[key]


def classify_modes(blade: BladeModel, shapes: np.ndarray) -> list[str]:
    """Kind of each column of ``shapes`` by its kinetic-energy share per DOF component."""
    energy = shapes * (blade.mass @ shapes)
    groups = np.zeros((len(KINDS), shapes.shape[1]))
    np.add.at(groups, _KIND_OF_COMPONENT[blade.components], energy)
    return [KINDS[i] for i in np.argmax(groups, axis=0)]


def blade_modes(blade: BladeModel, n_modes: int | None = None) -> Modes:
    """The lowest ``n_modes`` modes of a blade (sparse solver), or all of them if ``None`` (dense).

    Parameters
    ----------
    blade
        The blade model.
    n_modes
        How many modes, lowest first.

    Returns
    -------
    Modes
        Frequencies (Hz, ascending), mass-normalised shapes over the blade's free DOFs, kinds.

    Examples
    --------
    The four lowest modes of the default rig's active blade:

    >>> import numpy as np
    >>> import rigtools
    >>> from rigtools.sim.modal import blade_modes
    >>> from rigtools.sim.rig_model import build_rig_model
    >>> rig = build_rig_model(rigtools.load_rig().to_params())
    >>> modes = blade_modes(rig.blade("active"), 4)
    >>> np.round(modes.frequencies_hz, 1)
    array([ 53.2, 361.9, 532.7, 663. ])
    >>> modes.kinds
    ['flexural', 'flexural', 'torsional', 'edgewise']
    """
    modes = _all_modes(blade) if n_modes is None else lowest_modes(blade, min(int(n_modes), blade.n_dofs))
    return Modes(modes.frequencies_hz.copy(), modes.shapes.copy(), list(modes.kinds))


def flexural_frequencies(blade: BladeModel, n: int) -> np.ndarray:
    """The first ``n`` flexural (thin-direction bending) natural frequencies of a blade, Hz.

    Examples
    --------
    The first three flexural (impact-direction) frequencies of the default rig's active blade, Hz:

    >>> import numpy as np
    >>> import rigtools
    >>> from rigtools.sim.modal import flexural_frequencies
    >>> from rigtools.sim.rig_model import build_rig_model
    >>> rig = build_rig_model(rigtools.load_rig().to_params())
    >>> np.round(flexural_frequencies(rig.blade("active"), 3), 1)
    array([  53.2,  361.9, 1270.6])
    """
    k = n
    while True:
        flex = lowest_modes(blade, min(k, blade.n_dofs)).of_kind("flexural")
        if len(flex.frequencies_hz) >= n or k >= blade.n_dofs:
            break
        k *= 2
    if len(flex.frequencies_hz) < n:
        raise ValueError(f"the blade has only {len(flex.frequencies_hz)} flexural modes")
    return flex.frequencies_hz[:n].copy()
