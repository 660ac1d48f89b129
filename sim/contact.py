"""Penalty contact between the two shrouds along y.

Closure (see :mod:`rigtools.sim.rig_model`): ``g = u_active_tip_y - u_passive_tip_y - gap``. The contact is
closed when ``g > 0`` and then pushes the tips apart with

* linear law: ``f = k_c * g + c_c * dg/dt``
* Hertz law:  ``f = k_c * g**p + c_c * dg/dt``  (``p = hertz_exponent``, k_c in N/m**p)
* Hunt-Crossley law: ``f = k_c * g**p + c_c * g**p * dg/dt = k_c g**p (1 + alpha dg/dt)`` with
  ``alpha = c_c / k_c`` (s/m; c_c in N*s/m**(p+1)): the damping grows with the penetration, so
  the force starts from zero at first touch and ends at zero at release (no jump). Its
  coefficient of restitution for an impact at closing speed ``v_in`` follows from
  ``1 - e x = (1 + x) exp(-(1 + e) x)``, ``x = alpha v_in`` (exact for any ``p`` and mass,
  :func:`hunt_crossley_restitution`).

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

from rigtools.sim.params import ContactParams

LINEAR, HERTZ, HUNT_CROSSLEY = 0, 1, 2
LAWS = {"linear": LINEAR, "hertz": HERTZ, "hunt-crossley": HUNT_CROSSLEY}


def law_code(contact: ContactParams) -> int:
    """Integer code of the contact law for the compiled kernels."""
    try:
        return LAWS[contact.law]
    except KeyError:
        raise ValueError(f"unknown contact law {contact.law!r} (one of {', '.join(LAWS)})") from None


def kernel_contact(contact: ContactParams) -> tuple[float, float, float, float, int]:
    """The contact as the compiled kernels take it: ``(gap, stiffness, damping, hertz_exponent,
    law code)``, plain floats and an int."""
    c = contact
    return (float(c.gap), float(c.stiffness), float(c.damping), float(c.hertz_exponent), law_code(c))


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
    if contact.law == "linear":
        elastic = contact.stiffness * pen
        damper = contact.damping * v
    else:
        elastic = contact.stiffness * pen**contact.hertz_exponent
        damper = (
            contact.damping * v * (pen**contact.hertz_exponent if contact.law == "hunt-crossley" else 1.0)
        )
    return np.where(g > 0, np.maximum(elastic + damper, 0.0), 0.0)


@njit(cache=True)
def law(g: float, v: float, kc: float, cc: float, p: float, code: int) -> float:
    """Scalar contact force for closure ``g`` and rate ``v`` (compiled)."""
    if g <= 0.0:
        return 0.0
    if code == HERTZ:
        f = kc * g**p + cc * v
    elif code == HUNT_CROSSLEY:
        f = g**p * (kc + cc * v)
    else:
        f = kc * g + cc * v
    return max(0.0, f)


@njit(cache=True)
def _law_slope(g: float, v: float, g1: float, v1: float, kc: float, cc: float, p: float, code: int) -> float:
    """d law / d f along ``g = g0 + g1 f``, ``v = v0 + v1 f`` where the law is positive."""
    if code == HUNT_CROSSLEY:
        return p * g ** (p - 1.0) * g1 * (kc + cc * v) + g**p * cc * v1
    return kc * p * g ** (p - 1.0) * g1 + cc * v1


@njit(cache=True)
def solve_contact(
    g0: float, g1: float, v0: float, v1: float, kc: float, cc: float, p: float, code: int
) -> float:
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
    # Hertz, Hunt-Crossley: r(f) = f - law(g(f), v(f)) is increasing; bracket [0, hi] and
    # Newton with bisection
    hi = law(g0, v0, kc, cc, p, code)
    if hi <= 0.0:
        return 0.0
    f_close = -g0 / g1  # force at which g reaches zero
    hi = min(hi, f_close)
    lo = 0.0
    f = 0.5 * hi
    for _ in range(60):
        g = g0 + g1 * f
        r = f - law(g, v0 + v1 * f, kc, cc, p, code)
        if r > 0.0:
            hi = f
        else:
            lo = f
        if g > 0.0 and law(g, v0 + v1 * f, kc, cc, p, code) > 0.0:
            dr = 1.0 - _law_slope(g, v0 + v1 * f, g1, v1, kc, cc, p, code)
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

    For the Hertz and Hunt-Crossley laws the tangent stiffness at the penetration carrying
    ``force_scale`` newtons is used (``force_scale`` must then be > 0).
    """
    k = contact.stiffness
    if contact.law != "linear":
        if not force_scale > 0:
            raise ValueError(f"force_scale is needed for the {contact.law} law")
        p = contact.hertz_exponent
        pen = (force_scale / k) ** (1.0 / p)
        k = k * p * pen ** (p - 1.0)
    return 2.0 * math.pi * math.sqrt(effective_mass / k)


def hunt_crossley_restitution(alpha_v: float) -> float:
    """Coefficient of restitution of a Hunt-Crossley impact, ``x = alpha * v_in`` (>= 0).

    From ``m v dv/dg = -k g^p (1 + alpha v)`` integrated over the whole impact (g from 0 back to
    0): ``1 - e x = (1 + x) exp(-(1 + e) x)``, exact for any exponent ``p``, stiffness and mass
    (Hunt and Crossley 1975; Gonthier et al. 2004). Solved for ``e`` in (0, 1] by a bracketed
    root search; ``e -> 1 - 2x/3`` for small ``x`` (Hunt-Crossley's own linearisation).
    """
    from scipy.optimize import brentq

    x = float(alpha_v)
    if not (x >= 0 and math.isfinite(x)):
        raise ValueError(f"alpha * v_in must be finite and >= 0, got {alpha_v}")
    if x < 1e-8:
        return 1.0 - 2.0 * x / 3.0

    def residual(e: float) -> float:
        return math.log1p(-e * x) - math.log1p(x) + (1.0 + e) * x

    # residual(0) = x - log1p(x) > 0; residual < 0 just below e = min(1, 1/x) (the root is unique)
    hi = min(1.0, (1.0 - 1e-15) / x)
    return brentq(residual, 0.0, hi, xtol=1e-15, rtol=1e-15) if residual(hi) < 0 else hi


def hunt_crossley_damping(stiffness: float, restitution: float, impact_speed: float) -> float:
    """Hunt-Crossley damping ``c_c = alpha k_c`` (N*s/m**(p+1)) giving ``restitution`` at
    ``impact_speed`` (m/s): the inverse of :func:`hunt_crossley_restitution`,
    ``alpha v_in = x`` with ``x = -ln((1 - e x)/(1 + x)) / (1 + e)`` solved for ``x``."""
    from scipy.optimize import brentq

    e, v = float(restitution), float(impact_speed)
    if not 0 < e <= 1:
        raise ValueError(f"restitution must be in (0, 1], got {restitution}")
    if not (v > 0 and math.isfinite(v)):
        raise ValueError(f"impact speed must be > 0 m/s, got {impact_speed}")
    if e == 1.0:
        return 0.0
    # hunt_crossley_restitution falls from 1 (x = 0) towards 0 as x grows
    hi = 1.0
    while hunt_crossley_restitution(hi) > e:
        hi *= 2.0
    x = brentq(lambda y: hunt_crossley_restitution(y) - e, 0.0, hi, xtol=1e-14, rtol=1e-15)
    return x / v * stiffness


def contact_damping_ratio(contact: ContactParams, effective_mass: float) -> float:
    """Damping ratio ``c_c / (2 sqrt(k_c m))`` of a linear contact on ``effective_mass`` (kg)."""
    if contact.law != "linear":
        raise ValueError(f"the damping ratio is defined for the linear law, not {contact.law!r}")
    return contact.damping / (2.0 * math.sqrt(contact.stiffness * effective_mass))


def linear_restitution(damping_ratio: float, clipped: bool = True) -> float:
    """Coefficient of restitution of a linear spring-damper contact (Kelvin-Voigt), any speed.

    With the damper allowed to pull (``clipped=False``) the contact lasts half a damped period:
    ``e = exp(-pi zeta / sqrt(1 - zeta^2))``. A penalty contact never pulls (``clipped=True``,
    what :func:`law` does): it releases where ``k g + c dg/dt`` reaches zero, still compressed,
    at ``w_d t = pi - atan(2 zeta sqrt(1 - zeta^2) / (1 - 2 zeta^2))`` (atan2 form beyond
    ``zeta = 1/sqrt 2``), with the release speed ``e v0 = -v(t)``,
    ``v(t)/v0 = exp(-zeta w_n t) (cos w_d t - zeta/sqrt(1 - zeta^2) sin w_d t)`` (the free
    flight that follows keeps it). Valid for ``0 <= zeta < 1``; speed and stiffness drop out.
    """
    z = float(damping_ratio)
    if not 0 <= z < 1:
        raise ValueError(f"damping ratio must be in [0, 1), got {damping_ratio}")
    s = math.sqrt(1.0 - z * z)
    if not clipped:
        return math.exp(-math.pi * z / s)
    phase = math.pi - math.atan2(2.0 * z * s, 1.0 - 2.0 * z * z)  # w_d t at release
    # v(t)/v0 = e^{-z wn t} (cos(w_d t) - z/s sin(w_d t)); at release this equals -e^{-z wn t}
    return -math.exp(-z * phase / s) * (math.cos(phase) - z / s * math.sin(phase))
