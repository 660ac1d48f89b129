"""Coefficient of restitution of the contact laws: closed forms against an independent fine ODE
solve (scipy solve_ivp, DOP853, rtol 1e-12, release located by an event) and against a single
impact run through the fast kernel (a free mass on a rigid-stop contact spring).

* linear law, force clipped at zero (never pulls): :func:`rigtools.sim.contact.linear_restitution`;
* Hunt-Crossley ``f = k g^p (1 + alpha dg/dt)``: the exact relation
  ``1 - e x = (1 + x) exp(-(1 + e) x)``, ``x = alpha v_in`` (:func:`rigtools.sim.contact.hunt_crossley_restitution`),
  and the Lankarani-Nikravesh approximation ``alpha = 3 (1 - e^2) / (4 v_in)`` where it holds.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rigtools.sim.contact import (
    contact_damping_ratio,
    hunt_crossley_damping,
    hunt_crossley_restitution,
    linear_restitution,
)
from rigtools.sim.params import ContactParams, DampingParams
from rigtools.sim.reduction import ReducedSystem
from rigtools.sim.vibro_impact import VibroImpactStepper


def ode_restitution(m, v0, force):
    """Mass m hitting the contact at v0 (g = 0 at t = 0); outgoing speed / v0 (DOP853)."""

    def rhs(t, y):
        return [y[1], -force(y[0], y[1]) / m]

    def release(t, y):  # contact ends where the force reaches zero (g = 0 or damping)
        return force(y[0], y[1]) if y[0] > 0 else y[0]

    release.terminal, release.direction = True, -1
    t_c = 1.0
    sol = solve_ivp(
        rhs,
        (1e-12 * t_c, 10.0),
        [v0 * 1e-12 * t_c, v0],
        method="DOP853",
        rtol=1e-12,
        atol=1e-16,
        events=release,
        max_step=1e-4,
    )
    assert sol.status == 1
    return -sol.y_events[0][0][1] / v0


def kernel_restitution(m, v0, contact, steps_per_contact=400):
    """The same impact through VibroImpactStepper: one nearly free mode (1 Hz, undamped), the
    passive blade absent (rigid stop), the mass starting just short of the gap at -v0."""
    sysm = ReducedSystem(
        omega=np.array([2 * np.pi * 1.0]),
        zeta=np.array([0.0]),
        shapes=np.array([[1 / math.sqrt(m)], [0.0], [1 / math.sqrt(m)]]),
        blade=np.array([0]),
        contact=contact,
        damping=DampingParams(ratio=0.01),
        source="test",
        pseudo=np.zeros(1, bool),
    )
    k_tan = (
        contact.stiffness
        if contact.law == "linear"
        else contact.stiffness * 1e-3 ** (contact.hertz_exponent - 1)
    )
    tc = 2 * math.pi * math.sqrt(m / k_tan)
    dt = tc / steps_per_contact
    st = VibroImpactStepper(sysm, dt, force_scale=1.0)
    x0 = contact.gap - 0.37 * v0 * dt  # touch inside the first step
    st.state.q[0] = x0 * math.sqrt(m)
    st.state.v[0] = v0 * math.sqrt(m)
    out = st.step(np.zeros(int(20 * tc / dt)))
    closed = out.contact_force > 0
    assert closed.any() and not closed[-1]
    last = np.flatnonzero(closed)[-1]
    return -out.active_tip_velocity[last + 5] / v0


M, V0 = 0.059, 0.5


@pytest.mark.parametrize("zeta", [0.05, 0.2, 0.41, 0.6, 0.9])
def test_linear_clipped_restitution_closed_form(zeta):
    k = 1e6
    c = zeta * 2 * math.sqrt(k * M)
    e_ode = ode_restitution(M, V0, lambda g, v: max(k * g + c * v, 0.0))
    assert linear_restitution(zeta) == pytest.approx(e_ode, rel=1e-7)
    e_run = kernel_restitution(M, V0, ContactParams(gap=1e-4, stiffness=k, damping=c))
    assert e_run == pytest.approx(
        linear_restitution(zeta), rel=1e-3
    )  # measured < 3e-5 (400 steps per contact)


def test_default_contact_restitution_is_0_36_not_0_25():
    """The shipped contact (1e6 N/m, 200 N s/m on the shrouds' 59.19 g in series, 117.18 g and
    119.61 g, test_reduction's Ritz-subspace reference): zeta = 0.411; a damper allowed to pull would
    give 0.2426, the penalty contact (force >= 0) gives 0.3554."""
    from rigtools.config import load_rig
    from rigtools.sim.reduction import reduced_system

    params = load_rig().to_params()
    meff = reduced_system(params).contact_effective_mass()
    zeta = contact_damping_ratio(params.contact, meff)
    assert zeta == pytest.approx(0.411, abs=1e-3)
    assert linear_restitution(zeta, clipped=False) == pytest.approx(0.242, abs=1e-3)
    assert linear_restitution(zeta) == pytest.approx(0.355, abs=1e-3)
    k, c = params.contact.stiffness, params.contact.damping
    assert ode_restitution(meff, 0.3, lambda g, v: max(k * g + c * v, 0.0)) == pytest.approx(0.355, abs=1e-3)


@pytest.mark.parametrize("p", [1.0, 1.5])
@pytest.mark.parametrize("x", [0.02, 0.2, 0.6, 1.5])
def test_hunt_crossley_restitution_closed_form(p, x):
    k = 1e6 if p == 1.0 else 2e9
    alpha = x / V0
    e_ode = ode_restitution(M, V0, lambda g, v: max(k * g**p * (1 + alpha * v), 0.0) if g > 0 else 0.0)
    e = hunt_crossley_restitution(x)
    assert e == pytest.approx(e_ode, rel=1e-6)
    contact = ContactParams(gap=1e-4, stiffness=k, damping=alpha * k, law="hunt-crossley", hertz_exponent=p)
    # the bar: 1 %; measured < 0.005 % at 400 steps per contact
    assert kernel_restitution(M, V0, contact) == pytest.approx(e, rel=1e-2)


def test_hunt_crossley_relations():
    # Hunt-Crossley's own linearisation e ~ 1 - 2x/3 holds near e = 1 (0.03 % at e = 0.97);
    # Lankarani-Nikravesh x = 3 (1 - e^2) / 4 is 4.4 % low there
    e = 0.97
    x = hunt_crossley_damping(1.0, e, 1.0)
    assert hunt_crossley_restitution(x) == pytest.approx(e, rel=1e-12)
    assert x == pytest.approx(3 * (1 - e * e) / 4, rel=5e-2)
    assert 1 - 2 * x / 3 == pytest.approx(e, rel=1e-3)
    # c_c = alpha k: the damping a rig file gives for e = 0.5 at 0.3 m/s with k = 1e6
    cc = hunt_crossley_damping(1e6, 0.5, 0.3)
    assert hunt_crossley_restitution(cc / 1e6 * 0.3) == pytest.approx(0.5, rel=1e-12)
    with pytest.raises(ValueError, match="restitution"):
        hunt_crossley_damping(1e6, 1.5, 0.3)
