"""The two-blade rig: both blade models side by side, with damping and the DOFs that matter.

The blades are coupled only by the shroud contact, so the rig matrices are block-diagonal
``[active, passive]``: global index = blade-local free index, plus the active blade's DOF count
for the passive blade.

Contact convention (used by the vibro-impact code): relative closure
``g = u_active_tip_y - u_passive_tip_y - gap``; the contact force acts when ``g > 0``: ``+f`` on
the passive tip (pushes it +y), ``-f`` on the active tip.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import scipy.sparse as sp

from rigtools.sim.blade import BladeModel, build_blade
from rigtools.sim.modal import _all_modes
from rigtools.sim.params import DampingParams, LumpedMass, RigParams

__all__ = ["BladeModel", "RigModel", "blade_damping", "blade_masses", "build_rig_model"]

UY = 1


@dataclass
class RigModel:
    """FE model of the rig (both blades), free DOFs only.

    Attributes
    ----------
    params
        The rig parameters it was built from.
    active, passive
        The blade models.
    mass, stiffness
        Block-diagonal ``[active, passive]`` sparse matrices.
    force_dof
        Global index of uy at the active blade's force-sensor node (the shaker force acts here).
    active_tip_dof, passive_tip_dof
        Global index of uy at each shroud node.
    """

    params: RigParams
    active: BladeModel
    passive: BladeModel
    mass: sp.csr_matrix
    stiffness: sp.csr_matrix
    force_dof: int
    active_tip_dof: int
    passive_tip_dof: int
    _damping: sp.csr_matrix | None = field(default=None, repr=False, compare=False)

    @property
    def damping(self) -> sp.csr_matrix:
        """Block-diagonal physical damping matrix, built on first use.

        Rayleigh damping is sparse and cheap. Modal damping (a ratio on every mode) is
        ``M Phi diag(2 zeta w) Phi^T M`` over *all* modes: dense, O(n^3) to build -- a reference
        for the full-order integrator and the tests on meshes of a few hundred elements. The
        model build, the reduction and the simulated rig apply modal damping in modal space
        (:func:`rigtools.sim.reduction.damping_ratios`) and never build it.
        """
        if self._damping is None:
            self._damping = sp.block_diag(
                [
                    blade_damping(self.active, self.params.damping),
                    blade_damping(self.passive, self.params.damping),
                ],
                format="csr",
            )
        return self._damping

    @property
    def n_dofs(self) -> int:
        return self.active.n_dofs + self.passive.n_dofs

    def blade(self, name: str) -> BladeModel:
        """The blade called ``"active"`` or ``"passive"``."""
        if name == "active":
            return self.active
        if name == "passive":
            return self.passive
        raise KeyError(name)

    def offset(self, blade: str) -> int:
        """Global index of the first DOF of a blade."""
        if blade == "active":
            return 0
        if blade == "passive":
            return self.active.n_dofs
        raise KeyError(blade)

    def dof(self, blade: str, node: int, component: int) -> int:
        """Global index of ``component`` (0..5 = ux, uy, uz, rx, ry, rz) at ``node`` of a blade.

        Raises
        ------
        KeyError
            Unknown blade, or a clamped/nonexistent DOF.
        """
        return self.offset(blade) + self.blade(blade).dof(node, component)


def blade_masses(params: RigParams, blade: str) -> list[LumpedMass]:
    """Lumped masses on a blade: the shroud at its tip, plus the force sensor on the active blade."""
    bp = params.active if blade == "active" else params.passive
    shroud = replace(params.shroud, position=bp.length)
    if blade == "active":
        # a massless sensor still gets its node: the shaker force acts there
        return [params.force_sensor, shroud]
    return [shroud]


def blade_damping(blade: BladeModel, damping: DampingParams) -> sp.csr_matrix:
    """Damping matrix of one blade (see :attr:`RigModel.damping` for its cost).

    Modal ratio ``zeta`` on every mode: ``C = M Phi diag(2 zeta w) Phi^T M`` (Phi mass-normalised,
    all modes), so each mode has exactly ``zeta``. Otherwise Rayleigh ``C = alpha M + beta K``.
    """
    if damping.ratio is not None:
        modes = _all_modes(blade)
        mphi = blade.mass @ modes.shapes
        c = (mphi * (2.0 * damping.ratio * modes.omegas)) @ mphi.T
        c = 0.5 * (c + c.T)
        return sp.csr_matrix(c)
    return (damping.alpha * blade.mass + damping.beta * blade.stiffness).tocsr()


def build_rig_model(params: RigParams, rotary_inertia: bool = True) -> RigModel:
    """Build the FE model of both blades from the rig parameters.

    Parameters
    ----------
    params
        Rig parameters (SI).
    rotary_inertia
        Include the distributed rotary inertia of the blade sections.

    Returns
    -------
    RigModel

    Examples
    --------
    The finite-element model of the default rig (both blades, their shrouds, the force sensor):

    >>> import rigtools
    >>> from rigtools.sim.rig_model import build_rig_model
    >>> rig = build_rig_model(rigtools.load_rig().to_params())
    >>> rig.n_dofs
    1200
    """
    active = build_blade(
        "active",
        params.active,
        blade_masses(params, "active"),
        params.root,
        params.force_sensor,
        rotary_inertia,
    )
    passive_root = params.root_of("passive")
    passive = build_blade(
        "passive", params.passive, blade_masses(params, "passive"), passive_root, None, rotary_inertia
    )
    mass = sp.block_diag([active.mass, passive.mass], format="csr")
    stiffness = sp.block_diag([active.stiffness, passive.stiffness], format="csr")
    n_a = active.n_dofs
    return RigModel(
        params=params,
        active=active,
        passive=passive,
        mass=mass,
        stiffness=stiffness,
        force_dof=active.sensor_dof(UY),
        active_tip_dof=active.dof(active.tip_node, UY),
        passive_tip_dof=n_a + passive.dof(passive.tip_node, UY),
    )
