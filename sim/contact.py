"""Penalty contact between the two shrouds along y.

Closure (see :mod:`sim.rig_model`): ``g = u_active_tip_y - u_passive_tip_y - gap``. The contact is
closed when ``g > 0`` and then pushes the tips apart with

* linear law: ``f = k_c * g + c_c * dg/dt``
* Hertz law:  ``f = k_c * g**p + c_c * dg/dt``  (``p = hertz_exponent``, k_c in N/m**p)

clipped at zero (a penalty contact never pulls). ``+f`` acts on the passive tip, ``-f`` on the
active tip.

Time integrators evaluate the force implicitly at the end of a step, where the closure and its
rate are affine in the unknown force: ``g = g0 + g1*f``, ``dg/dt = v0 + v1*f`` with ``g1, v1 <= 0``.
:func:`solve_contact` finds the consistent force (closed form for the linear law, safeguarded
Newton for Hertz); it is compiled with numba and shared by the reduced and full-order integrators.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sim.params import ContactParams

LINEAR, HERTZ = 0, 1


def law_code(contact: ContactParams) -> int:
    """Integer code of the contact law for the compiled kernels."""
    if contact.law == "linear":
        return LINEAR
    if contact.law == "hertz":
        return HERTZ
    raise ValueError(f"unknown contact law {contact.law!r}")


def contact_force(closure: np.ndarray, closure_rate: np.ndarray, contact: ContactParams) -> np.ndarray:
    """Contact force for given closure ``g`` (m) and closure rate (m/s); zero where open.

    Parameters
    ----------
    closure, closure_rate
        Arrays of the same shape (``g`` already includes the gap: contact where ``g > 0``).
    contact
        Stiffness, damping and law.

    Returns
    -------
    np.ndarray
        Force pushing the shrouds apart, N (>= 0).
    """
    g = np.asarray(closure, dtype=float)
    v = np.asarray(closure_rate, dtype=float)
    pen = np.maximum(g, 0.0)
    if contact.law == "hertz":
        elastic = contact.stiffness * pen**contact.hertz_exponent
    else:
        elastic = contact.stiffness * pen
    return np.where(g > 0, np.maximum(elastic + contact.damping * v, 0.0), 0.0)


@njit(cache=True)
def law(g: float, v: float, kc: float, cc: float, p: float, code: int) -> float:
    """Scalar contact force for closure ``g`` and rate ``v`` (compiled)."""
    if g <= 0.0:
        return 0.0
    if code == HERTZ:
        f = kc * g**p + cc * v
    else:
        f = kc * g + cc * v
    return f if f > 0.0 else 0.0


@njit(cache=True)
def solve_contact(g0: float, g1: float, v0: float, v1: float,
                  kc: float, cc: float, p: float, code: int) -> float:
    """Force ``f >= 0`` consistent with ``f = law(g0 + g1 f, v0 + v1 f)``.

    ``g1 < 0`` (the force opens the contact) and ``v1 <= 0`` make the right side non-increasing in
    ``f``, so the root is unique. If the law jumps at ``g = 0`` (damping force at first touch) and
    no root exists, the force that just closes the gap (``g = 0``) is returned.
    """
    if g0 <= 0.0:
        return 0.0
    if code == LINEAR:
        f = (kc * g0 + cc * v0) / (1.0 - kc * g1 - cc * v1)
        if f <= 0.0:
            return 0.0
        if g0 + g1 * f < 0.0:
            return -g0 / g1
        return f
    # Hertz: r(f) = f - law(g(f), v(f)) is increasing; bracket [0, hi] and Newton with bisection
    hi = law(g0, v0, kc, cc, p, code)
    if hi <= 0.0:
        return 0.0
    f_close = -g0 / g1          # force at which g reaches zero
    if hi > f_close:
        hi = f_close
    lo = 0.0
    f = 0.5 * hi
    for _ in range(60):
        g = g0 + g1 * f
        r = f - law(g, v0 + v1 * f, kc, cc, p, code)
        if r > 0.0:
            hi = f
        else:
            lo = f
        if g > 0.0 and kc * g**p + cc * (v0 + v1 * f) > 0.0:
            dr = 1.0 - (kc * p * g ** (p - 1.0) * g1 + cc * v1)
        else:
            dr = 1.0
        fn = f - r / dr
        if not (lo < fn < hi):
            fn = 0.5 * (lo + hi)
        if abs(fn - f) <= 1e-13 * (abs(f) + 1e-300) or hi - lo <= 1e-14 * hi:
            return fn
        f = fn
    return f


def contact_period(effective_mass: float, contact: ContactParams, force_scale: float = 0.0) -> float:
    """Period ``2 pi sqrt(m_eff / k)`` of the shroud pair bouncing on the contact spring, s.

    For the Hertz law the tangent stiffness at the penetration carrying ``force_scale`` newtons is
    used (``force_scale`` must then be > 0).
    """
    k = contact.stiffness
    if contact.law == "hertz":
        if not force_scale > 0:
            raise ValueError("force_scale is needed for the Hertz law")
        p = contact.hertz_exponent
        pen = (force_scale / k) ** (1.0 / p)
        k = k * p * pen ** (p - 1.0)
    return 2.0 * math.pi * math.sqrt(effective_mass / k)
