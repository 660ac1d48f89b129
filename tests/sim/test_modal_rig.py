"""The two-blade RigModel: indexing, block structure, and the modal damping matrix."""

import dataclasses

import numpy as np
import pytest

from rigtools.sim.modal import blade_modes
from rigtools.sim.params import BladeParams, ContactParams, DampingParams, LumpedMass, RigParams, RootParams
from rigtools.sim.rig_model import build_rig_model

BLADE = BladeParams(
    length=0.155, width=0.04, thickness=0.0032, youngs_modulus=2e11, density=7850.0, elements=20
)


def _params(**kw):
    base = dict(
        active=BLADE,
        passive=dataclasses.replace(BLADE, length=0.15, elements=16),
        root=RootParams(),
        shroud=LumpedMass(0.11, 1e-5, BLADE.length),
        force_sensor=LumpedMass(0.066, 2e-6, 0.085),
        contact=ContactParams(gap=5e-4, stiffness=1e6),
    )
    base.update(kw)
    return RigParams(**base)


def test_dofs_point_at_the_right_nodes():
    rig = build_rig_model(_params())
    a, p = rig.active, rig.passive
    assert rig.n_dofs == a.n_dofs + p.n_dofs == 6 * 20 + 6 * 16
    assert a.node_x[a.sensor_node] == pytest.approx(0.085)
    assert a.node_x[a.tip_node] == pytest.approx(0.155) and p.node_x[p.tip_node] == pytest.approx(0.15)
    assert rig.force_dof == a.dof(a.sensor_node, 1)
    assert rig.active_tip_dof == a.dof(a.tip_node, 1)
    assert rig.passive_tip_dof == a.n_dofs + p.dof(p.tip_node, 1) == rig.dof("passive", p.tip_node, 1)
    assert p.sensor_node is None
    with pytest.raises(KeyError):
        a.dof(0, 1)  # clamped
    # the shroud mass sits on the tip uy of both blades, the sensor on the force DOF only
    m = rig.mass.toarray()
    assert m[rig.passive_tip_dof, rig.passive_tip_dof] > 0.11
    assert np.abs(m[: a.n_dofs, a.n_dofs :]).max() == 0.0  # blades are not coupled


def test_modal_damping_gives_each_mode_its_ratio():
    zeta = 0.02
    rig = build_rig_model(_params(damping=DampingParams(ratio=zeta)))
    for name in ("active", "passive"):
        blade = rig.blade(name)
        modes = blade_modes(blade)
        sl = slice(rig.offset(name), rig.offset(name) + blade.n_dofs)
        c = rig.damping.toarray()[sl, sl]
        modal = modes.shapes.T @ c @ modes.shapes
        assert np.allclose(modal, np.diag(2 * zeta * modes.omegas), atol=1e-8 * modal.max())


def test_rayleigh_damping_and_spring_root():
    rig = build_rig_model(
        _params(damping=DampingParams(ratio=None, alpha=3.0, beta=1e-6), root=RootParams("springs", 2e3, 1e8))
    )
    ref = 3.0 * rig.mass + 1e-6 * rig.stiffness
    assert abs(rig.damping - ref).max() < 1e-12 * abs(ref).max()
    assert rig.active.n_dofs == 6 * 21  # spring root keeps the root node
