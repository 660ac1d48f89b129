"""One blade as a finite-element model: mesh, assembly, lumped masses, root, free DOFs.

A blade is a uniform rectangular beam along x from the root (x = 0) to the shroud (x = length),
meshed with two-node 3D beam elements (:mod:`rigtools.sim.beam_element`). Lumped masses (the shroud at the
tip, the force sensor at mid-span) sit on nodes: the mesh puts a node exactly at each mass, keeping
the requested number of elements (elements are uniform between masses). The root is clamped
(its six DOFs are removed) or held by translational and rotational springs on all six DOFs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from rigtools.sim.beam_element import element_matrices, rectangular_section
from rigtools.sim.params import BladeParams, LumpedMass, RootParams

N_DOF_NODE = 6
# neighbouring elements whose lengths agree to this (relative) are one run of equal elements
_SAME_LENGTH = 1e-10
COMPONENTS = ("ux", "uy", "uz", "rx", "ry", "rz")


@dataclass
class BladeModel:
    """Finite-element model of one blade, reduced to its free DOFs.

    Attributes
    ----------
    name
        ``"active"`` or ``"passive"`` (any label).
    params
        Geometry and material.
    node_x
        Node positions from the root, m.
    mass, stiffness
        Free-DOF matrices (clamped DOFs removed), symmetric positive-definite.
    free_dofs
        Full DOF number ``node * 6 + component`` of each free DOF.
    tip_node
        Node carrying the shroud (last node).
    sensor_node
        Node carrying the force sensor, or ``None``.
    masses
        The lumped masses on this blade (positions as given).
    root
        The root support.
    rotary_inertia
        Whether the distributed rotary inertia of the section is in ``mass``.
    """

    name: str
    params: BladeParams
    node_x: np.ndarray
    mass: sp.csr_matrix
    stiffness: sp.csr_matrix
    free_dofs: np.ndarray
    tip_node: int
    sensor_node: int | None
    masses: tuple[LumpedMass, ...] = ()
    root: RootParams = field(default_factory=RootParams)
    rotary_inertia: bool = True
    # derived in __post_init__, never given; replace() builds a model with its own index and cache
    _free_index: np.ndarray = field(init=False, repr=False, compare=False)
    _cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        index = np.full(len(self.node_x) * N_DOF_NODE, -1, dtype=np.int64)
        index[self.free_dofs] = np.arange(len(self.free_dofs))
        self._free_index = index

    @property
    def n_dofs(self) -> int:
        return len(self.free_dofs)

    def dof(self, node: int, component: int) -> int:
        """Index in the free system of ``component`` (0..5 = ux, uy, uz, rx, ry, rz) at ``node``.

        Raises
        ------
        KeyError
            If that DOF is clamped or does not exist.
        """
        if not 0 <= component < N_DOF_NODE or not 0 <= node < len(self.node_x):
            raise KeyError((node, component))
        i = int(self._free_index[node * N_DOF_NODE + component])
        if i < 0:
            raise KeyError((node, component))
        return i

    def sensor_dof(self, component: int) -> int:
        """:meth:`dof` of ``component`` at the force sensor's node.

        Raises
        ------
        KeyError
            If this blade carries no force sensor.
        """
        if self.sensor_node is None:
            raise KeyError(f"the {self.name} blade carries no force sensor")
        return self.dof(self.sensor_node, component)

    def node_at(self, x: float) -> int:
        """The node nearest to position ``x`` (m from the root)."""
        return int(np.argmin(np.abs(self.node_x - x)))

    @property
    def components(self) -> np.ndarray:
        """Component (0..5) of each free DOF."""
        return self.free_dofs % N_DOF_NODE


def mesh_nodes(length: float, n_elements: int, breakpoints: list[float]) -> np.ndarray:
    """Node positions with ``n_elements`` elements and a node at every breakpoint.

    Elements are shared between the segments in proportion to their lengths (largest remainder,
    at least one per segment) and are uniform within a segment.
    """
    cuts = sorted({0.0, length, *[b for b in breakpoints if 0.0 < b < length]})
    seg = np.diff(cuts)
    if n_elements < len(seg):
        raise ValueError(f"{n_elements} elements cannot put a node at each of {len(seg) - 1} masses")
    share = seg / length * n_elements
    counts = np.maximum(np.floor(share).astype(int), 1)
    while counts.sum() < n_elements:
        counts[np.argmax(share - counts)] += 1
    while counts.sum() > n_elements:
        counts[np.argmax(counts - share)] -= 1
    parts = [np.linspace(a, b, n + 1)[:-1] for a, b, n in zip(cuts[:-1], cuts[1:], counts, strict=True)]
    return np.concatenate([*parts, [length]])


def element_types(
    params: BladeParams, node_x: np.ndarray, rotary_inertia: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The distinct elements of a mesh (elements are uniform between masses: a few lengths).

    Parameters
    ----------
    params
        Geometry, material and beam theory.
    node_x
        Node positions, m (:func:`mesh_nodes`).
    rotary_inertia
        Include the distributed rotary inertia of the section in the masses.

    Returns
    -------
    (lengths, stiffness, mass, kind)
        ``lengths`` (t,) the length each distinct element's matrices were computed for (the mean
        of a run of neighbouring elements of equal length),
        ``stiffness`` and ``mass`` (t, 12, 12) (:func:`rigtools.sim.beam_element.element_matrices`),
        ``kind`` (n_elements,) the index of each element's matrices.
    """
    section = rectangular_section(
        params.width, params.thickness, params.youngs_modulus, params.density, params.poisson
    )
    # The elements of a uniform segment differ in their last bits (linspace: ~n eps relative).
    # One matrix serves each run of equal elements, made for the run's mean length: the run then
    # spans exactly its segment (the first element's length, repeated, would stretch the blade
    # by up to ~n eps, which moves the frequencies by ~1e-12 at 6400 elements).
    le = np.diff(node_x)
    step = np.flatnonzero(np.abs(np.diff(le)) > _SAME_LENGTH * le[1:]) + 1
    starts, ends = np.r_[0, step], np.r_[step, le.size]
    lengths = [float(np.mean(le[a:b])) for a, b in zip(starts, ends, strict=True)]
    kind = np.repeat(np.arange(len(lengths)), ends - starts)
    mats = [element_matrices(h, section, params.theory, rotary_inertia) for h in lengths]
    k = np.array([km[0] for km in mats]).reshape(-1, 12, 12)
    m = np.array([km[1] for km in mats]).reshape(-1, 12, 12)
    return np.array(lengths), k, m, kind


def assemble_stiffness(
    node_x: np.ndarray, types: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], root: RootParams
) -> sp.csr_matrix:
    """Assembled stiffness over the free DOFs: the elements of ``types`` (:func:`element_types`)
    and the root springs (see :func:`build_blade`)."""
    _, k_types, _, kind = types
    free, _, springs = _nodal_terms(node_x, (), root)
    return _assemble(k_types, kind, springs, free)


def assemble_mass(
    node_x: np.ndarray,
    types: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    masses: list[LumpedMass] | tuple[LumpedMass, ...],
    root: RootParams,
) -> sp.csr_matrix:
    """Assembled mass over the free DOFs: the elements of ``types`` (:func:`element_types`) and
    the lumped masses (see :func:`build_blade`)."""
    _, _, m_types, kind = types
    free, lumped, _ = _nodal_terms(node_x, masses, root)
    return _assemble(m_types, kind, lumped, free)


def _nodal_terms(
    node_x: np.ndarray, masses: list[LumpedMass] | tuple[LumpedMass, ...], root: RootParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Free DOFs, lumped masses and root springs on the diagonal, over all DOFs."""
    n_full = len(node_x) * N_DOF_NODE
    if root.kind not in ("springs", "clamped"):
        raise ValueError(f"unknown root kind {root.kind!r}")
    free = np.arange(n_full) if root.kind == "springs" else np.arange(N_DOF_NODE, n_full)
    lumped = np.zeros(n_full)
    for m in masses:
        node = int(np.argmin(np.abs(node_x - m.position)))
        lumped[node * N_DOF_NODE + np.arange(6)] += [m.mass] * 3 + [m.rotary_inertia] * 3
    springs = np.zeros(n_full)
    if root.kind == "springs":
        springs[:6] = [root.translational_stiffness] * 3 + [root.rotational_stiffness] * 3
    return free, lumped, springs


def _assemble(
    matrices: np.ndarray, kind: np.ndarray, diagonal: np.ndarray, free: np.ndarray
) -> sp.csr_matrix:
    """Element ``e`` (``matrices[kind[e]]``, nodes e and e + 1) plus ``diagonal``, over the free DOFs."""
    n_full = diagonal.size
    index = np.full(n_full, -1)
    index[free] = np.arange(free.size)
    dofs = index[np.arange(kind.size)[:, None] * N_DOF_NODE + np.arange(12)]
    rows = np.r_[np.repeat(dofs, 12, axis=1).ravel(), index]
    cols = np.r_[np.tile(dofs, (1, 12)).ravel(), index]
    vals = np.r_[matrices[kind].ravel(), diagonal]
    keep = (rows >= 0) & (cols >= 0) & (vals != 0.0)
    return sp.coo_matrix((vals[keep], (rows[keep], cols[keep])), shape=(free.size, free.size)).tocsr()


def build_blade(
    name: str,
    params: BladeParams,
    masses: list[LumpedMass] | tuple[LumpedMass, ...],
    root: RootParams,
    sensor: LumpedMass | None = None,
    rotary_inertia: bool = True,
) -> BladeModel:
    """Assemble one blade.

    Parameters
    ----------
    name
        Label of the blade.
    params
        Geometry and material; ``params.elements`` elements, ``params.theory`` beam theory.
    masses
        Lumped masses (mass on ux, uy, uz; rotary inertia on rx, ry, rz) at their positions;
        each lands on a node of its own.
    root
        Clamped, or springs on every root DOF.
    sensor
        The lumped mass that is the force sensor (one of ``masses``), to set ``sensor_node``.
    rotary_inertia
        Include the distributed rotary inertia of the section (switch off to compare with
        Euler-Bernoulli closed forms).

    Returns
    -------
    BladeModel
    """
    for m in masses:
        if not 0.0 < m.position <= params.length * (1 + 1e-12):
            raise ValueError(f"lumped mass at x = {m.position} m is not on the blade (0, {params.length}]")
    x = mesh_nodes(params.length, params.elements, [m.position for m in masses])
    n_nodes = len(x)

    types = element_types(params, x, rotary_inertia)
    free, _, _ = _nodal_terms(x, (), root)
    sensor_node = None if sensor is None else int(np.argmin(np.abs(x - sensor.position)))
    blade = BladeModel(
        name=name,
        params=params,
        node_x=x,
        mass=assemble_mass(x, types, masses, root),
        stiffness=assemble_stiffness(x, types, root),
        free_dofs=free,
        tip_node=n_nodes - 1,
        sensor_node=sensor_node,
        masses=tuple(masses),
        root=root,
        rotary_inertia=rotary_inertia,
    )
    blade._cache[("element_types", rotary_inertia)] = types
    return blade
