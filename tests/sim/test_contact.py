"""Contact laws and the implicit end-of-step contact solve, against direct evaluation."""

import math

import numpy as np
import pytest

from rigtools.sim.contact import HERTZ, LINEAR, contact_force, contact_period, law, solve_contact
from rigtools.sim.params import ContactParams


def test_linear_and_hertz_force_with_damping_and_clip():
    c = ContactParams(gap=1e-4, stiffness=2e6, damping=50.0)
    g = np.array([-1e-5, 0.0, 2e-5, 2e-5, 2e-5])
    v = np.array([0.0, 1.0, 0.1, -0.5, -2.0])
    f = contact_force(g, v, c)
    # open, touching, closing, opening slowly, opening fast (damping would pull: clipped to 0)
    np.testing.assert_allclose(f, [0, 0, 2e6 * 2e-5 + 5.0, 40.0 - 25.0, 0.0], rtol=1e-14)
    h = ContactParams(gap=0.0, stiffness=1e9, law="hertz", hertz_exponent=1.5)
    assert contact_force(np.array([1e-6]), np.array([0.0]), h)[0] == pytest.approx(1e9 * 1e-9)
    assert law(1e-6, 0.0, 1e9, 0.0, 1.5, HERTZ) == pytest.approx(1.0)


@pytest.mark.parametrize("code, p", [(LINEAR, 1.0), (HERTZ, 1.5)])
def test_solve_contact_is_consistent(code, p):
    """The returned force satisfies f = law(g0 + g1 f, v0 + v1 f) to round-off (fixed point)."""
    rng = np.random.default_rng(3)
    kc = 1e6 if code == LINEAR else 5e8
    for _ in range(200):
        g0 = rng.uniform(-1e-5, 1e-4)
        g1 = -rng.uniform(1e-8, 1e-5)
        v0 = rng.uniform(-0.5, 0.5)
        v1 = -rng.uniform(0, 1e-3)
        cc = rng.uniform(0, 100)
        f = solve_contact(g0, g1, v0, v1, kc, cc, p, code)
        assert f >= 0
        target = law(g0 + g1 * f, v0 + v1 * f, kc, cc, p, code)
        if f == 0.0:  # open, or the damping would pull: the law gives zero too
            assert target == 0.0
        elif g0 + g1 * f > 1e-12 * abs(g0):
            assert f == pytest.approx(target, rel=1e-9)
        else:  # no fixed point at the jump of the law: the force that closes the gap
            assert abs(g0 + g1 * f) <= 1e-12 * abs(g0)


def test_contact_period():
    c = ContactParams(gap=0.0, stiffness=4e6)
    assert contact_period(0.01, c) == pytest.approx(2 * math.pi * math.sqrt(0.01 / 4e6))
    h = ContactParams(gap=0.0, stiffness=1e9, law="hertz", hertz_exponent=1.5)
    # at 1 N the penetration is 1e-6 m and the tangent stiffness 1.5e9 * 1e-3
    assert contact_period(0.01, h, force_scale=1.0) == pytest.approx(2 * math.pi * math.sqrt(0.01 / 1.5e6))
