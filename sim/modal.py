"""Modal analysis of a blade: frequencies, mass-normalised shapes, and the kind of each mode.

The generalized symmetric eigenproblem ``K phi = w^2 M phi`` is solved one uncoupled DOF group at
a time (for a symmetric section: axial, the two bending planes, torsion):

* :func:`lowest_modes` -- only the modes asked for (the lowest ``n``, or those below a frequency),
  by the sparse shift-invert Lanczos solver (:func:`scipy.sparse.linalg.eigsh`, factorising the
  banded ``K - sigma M`` once): time and memory grow linearly with the element count, and the low
  modes are accurate to round-off relative to themselves at any mesh. Small groups are solved
  densely (LAPACK), which is faster there and gives the same modes. The model build and the
  reduction use this.
* :func:`blade_modes` without ``n_modes`` -- every mode (dense, O(n^3) in time and O(n^2) in
  memory): for the full-order reference integrator, the harmonic superposition over all modes,
  and the tests; meant for meshes of a few hundred elements.

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
from rigtools.sim.threads import single_blas_thread

KINDS = ("axial", "flexural", "edgewise", "torsional")
#: DOF groups up to this size are solved densely (all their modes): faster than Lanczos there.
DENSE_GROUP_MAX = 600
# shift of the shift-invert solver, (rad/s)^2: just below zero, so a (nearly) singular K is safe
_SIGMA = -1.0
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
    phi = phi[:, order]
    return Modes(np.sqrt(w2) / (2.0 * np.pi), phi, classify_modes(blade, phi))


def _all_modes(blade: BladeModel) -> Modes:
    """Every mode of the blade (dense, per DOF group), cached on it."""
    if "modes" not in blade._cache:
        K, M = blade.stiffness, blade.mass
        parts = []
        with single_blas_thread():
            for idx in _groups(blade):
                vals, vecs = scipy.linalg.eigh(K[idx][:, idx].toarray(), M[idx][:, idx].toarray())
                parts.append((idx, vals, vecs))
        blade._cache["modes"] = _assemble(blade, parts)
    return blade._cache["modes"]


def _group_lowest(kg, mg, n: int | None, below_w2: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The lowest modes of one group: ``n`` of them, or all below ``below_w2`` (at least one)."""
    size = kg.shape[0]
    if size <= DENSE_GROUP_MAX:
        vals, vecs = scipy.linalg.eigh(kg.toarray(), mg.toarray())
    else:
        k = min(size - 2, max(8, n or 8))
        kg, mg = kg.tocsc(), mg.tocsc()
        # one factorisation of K - sigma M serves every try
        op = spla.splu((kg - _SIGMA * mg).tocsc())
        opinv = spla.LinearOperator(kg.shape, matvec=op.solve, dtype=float)
        while True:
            vals, vecs = spla.eigsh(kg, k=k, M=mg, sigma=_SIGMA, which="LM", OPinv=opinv)
            order = np.argsort(vals)
            vals, vecs = vals[order], vecs[:, order]
            enough = (n is not None and vals.size >= n) or (below_w2 is not None and vals[-1] >= below_w2)
            if enough or k >= size - 2:
                break
            k = min(size - 2, 2 * k)
    if n is not None:
        vals, vecs = vals[:n], vecs[:, :n]
    if below_w2 is not None:
        keep = max(1, int(np.searchsorted(vals, below_w2)))
        vals, vecs = vals[:keep], vecs[:, :keep]
    return vals, vecs


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
        parts = []
        with single_blas_thread():
            for idx in groups:
                vals, vecs = _group_lowest(K[idx][:, idx], M[idx][:, idx], n_modes, below_w2)
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
    """
    modes = _all_modes(blade) if n_modes is None else lowest_modes(blade, min(int(n_modes), blade.n_dofs))
    return Modes(modes.frequencies_hz.copy(), modes.shapes.copy(), list(modes.kinds))


def flexural_frequencies(blade: BladeModel, n: int) -> np.ndarray:
    """The first ``n`` flexural (thin-direction bending) natural frequencies of a blade, Hz."""
    k = n
    while True:
        flex = lowest_modes(blade, min(k, blade.n_dofs)).of_kind("flexural")
        if len(flex.frequencies_hz) >= n or k >= blade.n_dofs:
            break
        k *= 2
    if len(flex.frequencies_hz) < n:
        raise ValueError(f"the blade has only {len(flex.frequencies_hz)} flexural modes")
    return flex.frequencies_hz[:n].copy()
