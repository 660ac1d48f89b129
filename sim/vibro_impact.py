"""Fast vibro-impact time stepping of a :class:`rigtools.sim.reduction.ReducedSystem`.

Each modal oscillator ``q'' + 2 zeta w q' + w^2 q = p(t)`` is propagated exactly over a step for
a load that varies linearly within the step (first-order hold): ``x1 = E x0 + G0 p0 + G1 p1``
with ``x = (q, q')``. The contact force (and, with a shaker, the armature force) at the end of the
step are unknown; the tip closure there is affine in them, so the force is solved consistently
in every step (closed form for the linear law, Newton for Hertz, :func:`rigtools.sim.contact.solve_contact`).
A step costs O(n_modes); the inner loop is compiled with numba.

Time convention: ``step(u)`` takes the input at the END of each step (``u[i]`` at
``t0 + (i+1)*dt``, the input at ``t0`` being carried from the previous call) and returns the
outputs at the same instants.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from typing import Protocol

import numpy as np
import scipy.linalg
from numba import njit

from rigtools.sim.contact import contact_period, law_code, solve_contact
from rigtools.sim.params import ContactParams, SimulationInputError
from rigtools.sim.reduction import ReducedSystem

# output columns of the compiled kernel
OUT_COLUMNS = (
    "active_tip_displacement",
    "active_tip_velocity",
    "active_tip_acceleration",
    "passive_tip_displacement",
    "passive_tip_velocity",
    "passive_tip_acceleration",
    "force_point_displacement",
    "force_point_velocity",
    "force_point_acceleration",
    "contact_force",
    "excitation_force",
    "coil_current",
    "damping_power",
    "contact_damping_power",
    # the contact force within each step (exact load of the scheme): linear from the previous
    # step's force to ``contact_force_before_split`` over the fraction ``contact_split`` of the
    # step, then linear from ``contact_force_after_split`` to ``contact_force`` (split = 1, both
    # equal to contact_force, in a step without an event); see :func:`contact_force_harmonics`
    "contact_split",
    "contact_force_before_split",
    "contact_force_after_split",
)
N_OUT = len(OUT_COLUMNS)
MIN_STEPS_PER_CONTACT = 20
# contact damping c over the step: c dt / m_eff above 2 makes the end-of-step damping force
# overshoot and the run diverge (1e4 N*s/m at the default 50 us step: 8.5, no steady state;
# 1e5: 1e227 N); at <= 2 the contact-force harmonics agree with a 4x finer step to 0.01 %
MAX_CONTACT_DAMPING_STEP = 2.0
DIVERGED_DISPLACEMENT = 1.0e3  # m: no blade tip moves a kilometre
# scalar state slots: last load at the force point, last contact force, coil current,
# last coil voltage, last force-point velocity
_S_F, _S_FC, _S_I, _S_V, _S_VF = range(5)


class SimulationDivergedError(SimulationInputError):
    """The integration produced a non-finite or absurd value; the message names the likely
    parameters."""


@dataclass(frozen=True)
class ShakerCoupling:
    """Electrodynamic shaker rigidly attached at the force point, force sensor in between.

    ``L di/dt + R i + Bl v = V``; the armature mass and suspension act at the force point; the
    sensor reads ``Bl i - m_a a - k_s x - c_s v`` (the force passed into the blade).
    """

    armature_mass: float  # kg
    suspension_stiffness: float  # N/m
    suspension_damping: float  # N s/m
    force_factor: float  # Bl, N/A
    coil_resistance: float  # ohm
    coil_inductance: float  # H

    def __post_init__(self) -> None:
        from rigtools.sim.shaker_params import SHAKER_BOUNDS

        for f in fields(self):
            SHAKER_BOUNDS[f.name].check(f.name, getattr(self, f.name), SimulationInputError)


@dataclass
class StepOutput:
    """Outputs of :meth:`VibroImpactStepper.step`, one value per step (y direction, SI)."""

    time: np.ndarray
    data: np.ndarray = field(repr=False)  # (n_steps, N_OUT) in OUT_COLUMNS order

    def __getattr__(self, name: str) -> np.ndarray:
        # only called for names that are not attributes; during copy/unpickling ``data`` is not
        # set yet and lookups such as ``__setstate__`` must end in AttributeError
        if name in OUT_COLUMNS:
            return self.data[:, OUT_COLUMNS.index(name)]
        raise AttributeError(name)

    def as_dict(self) -> dict[str, np.ndarray]:
        return {name: self.data[:, i] for i, name in enumerate(OUT_COLUMNS)}


@dataclass
class StepperState:
    """Carried state: modal coordinates, their rates, the last loads, coil current, time."""

    q: np.ndarray
    v: np.ndarray
    scalars: np.ndarray  # see the _S_* slots
    time: float = 0.0

    def copy(self) -> StepperState:
        return StepperState(self.q.copy(), self.v.copy(), self.scalars.copy(), self.time)


def foh_propagators(
    omega: np.ndarray, zeta: np.ndarray, dt: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact one-step propagators of ``q'' + 2 zeta w q' + w^2 q = p`` for piecewise-linear ``p``.

    Returns ``E (n,2,2), G0 (n,2), G1 (n,2)`` with ``x1 = E x0 + G0 p0 + G1 p1``, ``x = (q, q')``
    (from the matrix exponential of the augmented system, exact to round-off).
    """
    n = omega.size
    E = np.empty((n, 2, 2))
    G0 = np.empty((n, 2))
    G1 = np.empty((n, 2))
    for j in range(n):
        a = np.array([[0.0, 1.0], [-(omega[j] ** 2), -2.0 * zeta[j] * omega[j]]])
        aug = np.zeros((4, 4))
        aug[:2, :2] = a * dt
        aug[1, 2] = dt  # constant input, b = (0, 1)
        aug[2, 3] = 1.0  # ramp input s/dt
        x = scipy.linalg.expm(aug)
        E[j] = x[:2, :2]
        gamma1, gamma2 = x[:2, 2], x[:2, 3]
        G0[j] = gamma1 - gamma2
        G1[j] = gamma2
    return E, G0, G1


_FAST = {"reassoc", "contract", "arcp", "nsz"}  # no nnan/ninf: keep comparisons exact


@njit(cache=True)
def _props_series(w, z, tau, P, j):
    """Column ``j`` of :func:`_props` from the power series of ``M = A tau``:
    ``exp(M) = sum M^k/k!``, ``Gamma1 = tau sum M^k/(k+1)! b``, ``Gamma2 = tau sum M^k/(k+2)! b``
    with ``b = (0, 1)`` (constant and ramp input)."""
    m10 = -w * w * tau
    m11 = -2.0 * z * w * tau
    # M^k = [[a, b], [c, d]], starting at the identity
    a = 1.0
    b = 0.0
    c = 0.0
    d = 1.0
    e00 = 0.0
    e01 = 0.0
    e10 = 0.0
    e11 = 0.0
    g1q = 0.0
    g1v = 0.0
    g2q = 0.0
    g2v = 0.0
    fk = 1.0  # 1 / k!
    for k in range(25):  # the scaled norm w tau (1 + 2 zeta) < 0.5: 0.5^25 / 25! ~ 2e-33
        f1 = fk / (k + 1)  # 1 / (k+1)!
        f2 = f1 / (k + 2)  # 1 / (k+2)!
        e00 += a * fk
        e01 += b * fk
        e10 += c * fk
        e11 += d * fk
        g1q += b * f1
        g1v += d * f1
        g2q += b * f2
        g2v += d * f2
        # M^(k+1) = M^k M with M = [[0, tau], [m10, m11]]
        a, b, c, d = b * m10, a * tau + b * m11, d * m10, c * tau + d * m11
        fk = f1
    P[0, j] = e00
    P[1, j] = e01
    P[2, j] = e10
    P[3, j] = e11
    P[4, j] = tau * (g1q - g2q)
    P[5, j] = tau * (g1v - g2v)
    P[6, j] = tau * g2q
    P[7, j] = tau * g2v


@njit(cache=True)
def _props(omega, zeta, tau, P):
    """Exact FOH propagators for a step ``tau`` into ``P (8, n)``: rows e00 e01 e10 e11 g0q g0v
    g1q g1v (closed form of ``exp(A tau)`` from the eigenvalues of each oscillator; for a step
    short against the oscillator, ``w tau (1 + 2 zeta) < 0.5``, the power series of ``exp``,
    ``phi1`` and ``phi2`` instead, where the closed form cancels: at 50 ns, the step of a
    1e12 N/m contact, it lost 0.3 % on the load terms of a 53 Hz mode)."""
    for j in range(omega.size):
        w = omega[j]
        z = zeta[j]
        if w * tau * (1.0 + 2.0 * z) < 0.5:
            _props_series(w, z, tau, P, j)
            continue
        if abs(z - 1.0) < 1e-7:
            z = 1.0 + 1e-7  # the critically damped limit, nudged off the double root
        root = np.sqrt(complex(z * z - 1.0))
        l1 = w * (-z + root)
        l2 = w * (-z - root)
        x1 = np.exp(l1 * tau)
        x2 = np.exp(l2 * tau)
        c1 = ((x1 - x2) / (l1 - l2)).real
        c0 = ((l1 * x2 - l2 * x1) / (l1 - l2)).real
        w2 = w * w
        P[0, j] = c0
        P[1, j] = c1
        P[2, j] = -w2 * c1
        P[3, j] = c0 - 2.0 * z * w * c1
        gam1q = (1.0 - c0) / w2
        gam1v = c1
        gam2q = (1.0 - c1 / tau - 2.0 * z * (1.0 - c0) / (w * tau)) / w2
        gam2v = (1.0 - c0) / (w2 * tau)
        P[4, j] = gam1q - gam2q
        P[5, j] = gam1v - gam2v
        P[6, j] = gam2q
        P[7, j] = gam2v


@njit(cache=True, fastmath=_FAST)
def _free(P, q, v, phiF, d, F_start, fc_start, qf, vf):
    """End state of a step with the start loads only (ramping to zero); returns
    (sum d qf, sum d vf, sum phiF vf)."""
    g = 0.0
    gd = 0.0
    vF = 0.0
    for j in range(q.size):
        p0 = phiF[j] * F_start - d[j] * fc_start
        qj = P[0, j] * q[j] + P[1, j] * v[j] + P[4, j] * p0
        vj = P[2, j] * q[j] + P[3, j] * v[j] + P[5, j] * p0
        qf[j] = qj
        vf[j] = vj
        g += d[j] * qj
        gd += d[j] * vj
        vF += phiF[j] * vj
    return g, gd, vF


@njit(cache=True, fastmath=_FAST)
def _influence(P, phiF, d):
    """End-of-step closure, closure rate and force-point velocity per unit end load
    (force-point load F, contact force f)."""
    hgF = 0.0
    hgc = 0.0
    hvF = 0.0
    hvc = 0.0
    hfF = 0.0
    hfc = 0.0
    for j in range(d.size):
        hgF += d[j] * P[6, j] * phiF[j]
        hgc += d[j] * P[6, j] * d[j]
        hvF += d[j] * P[7, j] * phiF[j]
        hvc += d[j] * P[7, j] * d[j]
        hfF += phiF[j] * P[7, j] * phiF[j]
        hfc += phiF[j] * P[7, j] * d[j]
    return hgF, hgc, hvF, hvc, hfF, hfc


@njit(cache=True)
def _end_loads(infl, g0, gd0, vF0, F_end, i_free, use_shaker, bl, kap, gap, kc, cc, pexp, code):
    """Solve the end-of-step loads (force-point load, contact force) of a (sub)step with the
    influence coefficients ``infl`` of :func:`_influence`."""
    hgF, hgc, hvF, hvc, hfF, hfc = infl
    if use_shaker:
        den = 1.0 + kap * hfF
        F0 = (bl * i_free - kap * vF0) / den
        F1 = kap * hfc / den
    else:
        F0 = F_end
        F1 = 0.0
    fc = solve_contact(
        g0 - gap + hgF * F0, hgF * F1 - hgc, gd0 + hvF * F0, hvF * F1 - hvc, kc, cc, pexp, code
    )
    return F0 + F1 * fc, fc, F0


@njit(cache=True, fastmath=_FAST)
def _finish(P, qf, vf, phiF, d, F, fc, q, v):
    for j in range(q.size):
        p1 = phiF[j] * F - d[j] * fc
        q[j] = qf[j] + P[6, j] * p1
        v[j] = vf[j] + P[7, j] * p1


@njit(cache=True)
def _hermite_root(y0, s0, y1, s1):
    """Root in (0, 1) of the cubic Hermite interpolant with values y0, y1 (opposite signs) and
    slopes s0, s1 (per unit of the interval); bisection on the sign change."""
    lo = 0.0
    hi = 1.0
    neg_at_lo = y0 < 0.0
    for _ in range(52):
        t = 0.5 * (lo + hi)
        t2 = t * t
        t3 = t2 * t
        y = (2 * t3 - 3 * t2 + 1) * y0 + (t3 - 2 * t2 + t) * s0 + (-2 * t3 + 3 * t2) * y1 + (t3 - t2) * s1
        if (y < 0.0) == neg_at_lo:
            lo = t
        else:
            hi = t
    return 0.5 * (lo + hi)


@njit(cache=True, fastmath=_FAST)
def _kernel(P, omega, zeta, phiA, phiP, phiF, q, v, s, u, out, dt, gap, kc, cc, pexp, code, shaker, events):
    """Step ``len(u)`` times in place (state ``q, v, s``), writing ``out (len(u), N_OUT)``.

    Returns -1, or the first step whose outputs are not finite or move a tip or the force point
    by :data:`DIVERGED_DISPLACEMENT` or more (stepping stops there; the state is then useless).

    ``P`` holds the whole-step propagators. ``shaker = (enabled, Bl, e, c0, c1, c_s, m_a, k_s)``:
    with ``enabled`` the input is the coil voltage, otherwise the force at the force point.
    With ``events`` a step in which the contact closes or opens is split at the instant
    located on the cubic Hermite interpolant of the closure (the contact force then starts or
    ends exactly there, which keeps the scheme second order through impacts).
    """
    n = omega.size
    d = phiA - phiP
    c2 = 2.0 * zeta * omega
    w2 = omega * omega
    use_shaker = shaker[0] > 0.5
    bl = shaker[1]
    ei = shaker[2]
    c0 = shaker[3]
    c1 = shaker[4]
    cs = shaker[5]
    ma = shaker[6]
    ks = shaker[7]
    kap = c1 * bl * bl + cs
    qf = np.empty(n)
    vf = np.empty(n)
    q1 = np.empty(n)
    v1 = np.empty(n)
    P1 = np.empty((8, n))
    P2 = np.empty((8, n))
    infl = _influence(P, phiF, d)
    g_old = -gap
    gd_old = 0.0
    for j in range(n):
        g_old += d[j] * q[j]
        gd_old += d[j] * v[j]
    for i in range(u.size):
        F_old = s[0]
        fc_old = s[1]
        g0, gd0, vF0 = _free(P, q, v, phiF, d, F_old, fc_old, qf, vf)
        if use_shaker:
            w_old = s[3] - bl * s[4]
            i_free = ei * s[2] + c0 * w_old + c1 * u[i]
        else:
            i_free = 0.0
        F, fc, Fn = _end_loads(infl, g0, gd0, vF0, u[i], i_free, use_shaker, bl, kap, gap, kc, cc, pexp, code)
        onset = fc_old == 0.0 and fc > 0.0 and g_old < 0.0
        release = fc_old > 0.0 and fc == 0.0
        split = False
        tau1 = 0.0
        theta = 1.0
        gdm = 0.0
        gm = 0.0
        if events and (onset or release):
            if onset:
                # closure without contact over the step (load at the end: no-contact value)
                gA = g0 - gap + infl[0] * Fn
                gdA = gd0 + infl[2] * Fn
                theta = _hermite_root(g_old, gd_old * dt, gA, gdA * dt)
            else:
                # where the force law reaches zero on the trajectory with the force ramped out
                _finish(P, qf, vf, phiF, d, F, 0.0, q1, v1)
                gB = -gap
                gdB = 0.0
                for j in range(n):
                    gB += d[j] * q1[j]
                    gdB += d[j] * v1[j]
                # zero of kc*g + cc*gd on the Hermite interpolant (g alone without damping)
                if code == 2:
                    # Hunt-Crossley: the force vanishes with the closure (or where the damping
                    # cancels the spring, 1 + alpha gd = 0, which needs a far faster release)
                    theta = _hermite_root(g_old, gd_old * dt, gB, gdB * dt) if gB < 0.0 else 1.0
                elif cc > 0.0:
                    if code == 0:
                        y0 = kc * g_old + cc * gd_old
                        y1 = kc * gB + cc * gdB
                    else:
                        y0 = kc * max(g_old, 0.0) ** pexp + cc * gd_old
                        y1 = kc * max(gB, 0.0) ** pexp + cc * gdB
                    theta = y0 / (y0 - y1) if y0 > 0.0 and y1 < 0.0 else 1.0
                else:
                    theta = _hermite_root(g_old, gd_old * dt, gB, gdB * dt) if gB < 0.0 else 1.0
            if 1e-9 < theta < 1.0 - 1e-9:
                split = True
                tau1 = theta * dt
                _props(omega, zeta, tau1, P1)
                _props(omega, zeta, dt - tau1, P2)
                F_mid = F_old + theta * (Fn - F_old)
                fc_mid_end = 0.0
                # sub-step 1: open (onset) or force ramping to zero (release)
                _free(P1, q, v, phiF, d, F_old, fc_old if release else 0.0, q1, v1)
                _finish(P1, q1, v1, phiF, d, F_mid, fc_mid_end, q1, v1)
                fc_start = 0.0
                gdm = 0.0
                gm = -gap
                for j in range(n):
                    gdm += d[j] * v1[j]
                    gm += d[j] * q1[j]
                if onset and cc > 0.0 and code != 2:
                    fc_start = cc * gdm if gdm > 0.0 else 0.0  # damping force at first touch
                g0b, gd0b, vF0b = _free(P2, q1, v1, phiF, d, F_mid, fc_start, qf, vf)
                F, fc, Fn = _end_loads(
                    _influence(P2, phiF, d),
                    g0b,
                    gd0b,
                    vF0b,
                    u[i],
                    i_free,
                    use_shaker,
                    bl,
                    kap,
                    gap,
                    kc,
                    cc,
                    pexp,
                    code,
                )
                _finish(P2, qf, vf, phiF, d, F, fc, q, v)
        xa = 0.0
        va = 0.0
        aa = 0.0
        xp = 0.0
        vp = 0.0
        ap = 0.0
        xF = 0.0
        vF = 0.0
        aF = 0.0
        pd = 0.0
        if not split:
            _finish(P, qf, vf, phiF, d, F, fc, q, v)
            out[i, 14] = 1.0
            out[i, 15] = fc
            out[i, 16] = fc
        else:
            out[i, 14] = theta
            out[i, 15] = 0.0
            out[i, 16] = fc_start
        for j in range(n):
            qj = q[j]
            vj = v[j]
            acc = phiF[j] * F - d[j] * fc - c2[j] * vj - w2[j] * qj
            xa += phiA[j] * qj
            va += phiA[j] * vj
            aa += phiA[j] * acc
            xp += phiP[j] * qj
            vp += phiP[j] * vj
            ap += phiP[j] * acc
            xF += phiF[j] * qj
            vF += phiF[j] * vj
            aF += phiF[j] * acc
            pd += c2[j] * vj * vj
        s[0] = F
        s[1] = fc
        if use_shaker:
            s[2] = i_free - c1 * bl * vF
            s[3] = u[i]
            s[4] = vF
            sensor = F - ma * aF - ks * xF
        else:
            sensor = F
        out[i, 0] = xa
        out[i, 1] = va
        out[i, 2] = aa
        out[i, 3] = xp
        out[i, 4] = vp
        out[i, 5] = ap
        out[i, 6] = xF
        out[i, 7] = vF
        out[i, 8] = aF
        out[i, 9] = fc
        out[i, 10] = sensor
        out[i, 11] = s[2]
        out[i, 12] = pd
        # energy dissipated by the contact damping in this step, as a step-average power:
        # integral of cc*gd^2 over the part of the step in contact, gd linear over that part
        # (a damped contact releases where the force reaches zero while still compressed: the
        # spring energy left then is lost too, and counted)
        gd = va - vp
        ce = 0.0
        if cc > 0.0 and code == 2:
            # Hunt-Crossley: cc g^p gd^2 by the trapezoid rule on each part in contact (zero at
            # the touch / release instant, where g = 0)
            g_new = xa - xp - gap
            if split and onset:
                ce = 0.5 * cc * (dt - tau1) * max(g_new, 0.0) ** pexp * gd * gd
            elif split:
                ce = 0.5 * cc * tau1 * max(g_old, 0.0) ** pexp * gd_old * gd_old
            elif fc > 0.0 or fc_old > 0.0:
                ce = (
                    0.5
                    * cc
                    * dt
                    * (max(g_old, 0.0) ** pexp * gd_old * gd_old + max(g_new, 0.0) ** pexp * gd * gd)
                )
        elif cc > 0.0:
            if split and onset:
                ce = cc * (dt - tau1) * (gdm * gdm + gdm * gd + gd * gd) / 3.0
            elif split:
                ce = cc * tau1 * (gd_old * gd_old + gd_old * gdm + gdm * gdm) / 3.0
                if gm > 0.0:
                    ce += kc * gm ** (pexp + 1.0) / (pexp + 1.0) if code == 1 else 0.5 * kc * gm * gm
            elif fc > 0.0 or fc_old > 0.0:
                ce = cc * dt * (gd_old * gd_old + gd_old * gd + gd * gd) / 3.0
        out[i, 13] = ce / dt
        g_old = xa - xp - gap
        gd_old = gd
        # a NaN fails every comparison; a sum of finite values is finite unless absurd anyway
        total = 0.0
        for k in range(out.shape[1]):
            total += out[i, k]
        if not (
            abs(xa) < DIVERGED_DISPLACEMENT
            and abs(xp) < DIVERGED_DISPLACEMENT
            and abs(xF) < DIVERGED_DISPLACEMENT
            and abs(total) < math.inf
        ):
            return i
    return -1


def _coil_coefficients(shaker: ShakerCoupling, dt: float) -> tuple[float, float, float]:
    """Exact FOH step of ``L di/dt + R i = w(t)``: ``i1 = e i0 + c0 w0 + c1 w1``."""
    r, ind = shaker.coil_resistance, shaker.coil_inductance
    if ind <= 0.0:
        return 0.0, 0.0, 1.0 / r
    x = r * dt / ind
    e = math.exp(-x)
    # integral of exp(-R(h-s)/L)/L * (w0 (1 - s/h) + w1 s/h) ds
    if x < 1e-6:
        c1 = dt / (2 * ind)
        c0 = dt / (2 * ind)
    else:
        one_minus = -math.expm1(-x)
        c1 = (1.0 / r) * (1.0 - one_minus / x)
        c0 = (1.0 / r) * (one_minus / x - e)
    return e, c0, c1


def effective_contact_damping(contact, force_scale: float = 100.0) -> float:
    """Damping coefficient of the contact, N*s/m: ``c_c`` for the linear and Hertz laws; for
    Hunt-Crossley ``c_c g^p`` at the penetration carrying ``force_scale`` newtons."""
    if contact.law == "hunt-crossley":
        return contact.damping * force_scale / contact.stiffness
    return contact.damping


class HasContact(Protocol):
    """What :func:`check_time_step` reads of a system: the contact and the mass it moves."""

    @property
    def contact(self) -> ContactParams: ...

    def contact_effective_mass(self) -> float: ...


def check_time_step(
    system: HasContact, dt: float, force_scale: float = 100.0, min_steps: int = MIN_STEPS_PER_CONTACT
) -> float:
    """Refuse a step that does not resolve the contact period with ``min_steps`` steps, or
    whose contact damping force would overshoot (``c dt / m_eff > 2``).

    Returns the contact period (s). ``force_scale`` (N) sets the tangent stiffness of a Hertz
    contact. Raises :class:`SimulationInputError` with one line otherwise, or for an invalid
    contact (:func:`validate_contact`).
    """
    if not (dt > 0 and math.isfinite(dt)):
        raise SimulationInputError(f"time step must be > 0, got {dt}")
    validate_contact(system)  # before the contact period, which needs a positive stiffness
    meff = system.contact_effective_mass()
    tc = contact_period(meff, system.contact, force_scale)
    if dt > tc / min_steps:
        raise SimulationInputError(
            f"time step {dt * 1e6:.3g} us is too coarse for the contact stiffness "
            f"{system.contact.stiffness:.3g}: the contact period {tc * 1e3:.3g} ms needs "
            f"dt <= {tc / min_steps * 1e6:.3g} us ({min_steps} steps per contact period)"
        )
    c = effective_contact_damping(system.contact, force_scale)
    if c * dt > MAX_CONTACT_DAMPING_STEP * meff:
        raise SimulationInputError(
            f"time step {dt * 1e6:.3g} us is too coarse for the contact damping {c:.3g} N*s/m "
            f"({c / (2 * math.sqrt(system.contact.stiffness * meff)):.3g} of critical on "
            f"{meff * 1e3:.3g} g): it needs dt <= {MAX_CONTACT_DAMPING_STEP * meff / c * 1e6:.3g} us "
            f"(c dt / m <= {MAX_CONTACT_DAMPING_STEP:g}); lower the contact damping or the step"
        )
    return tc


class VibroImpactStepper:
    """Block-wise stepping of the reduced two-blade system with carried state.

    Parameters
    ----------
    system
        The reduced system (from :func:`rigtools.sim.reduction.reduce_rig_model` or
        :func:`rigtools.sim.reduction.reduce_assumed_modes`).
    dt
        Time step, s. Must resolve the contact period with at least 20 steps.
    shaker
        If given, the input of :meth:`step` is the coil voltage (V) and the armature mass and
        suspension are added at the force point; otherwise the input is the force (N).
    force_scale
        Force (N) at which a Hertz contact's tangent stiffness is taken for the step check.
    """

    def __init__(
        self,
        system: ReducedSystem,
        dt: float,
        shaker: ShakerCoupling | None = None,
        force_scale: float = 100.0,
    ):
        self.contact_period = check_time_step(system, dt, force_scale)
        if shaker is not None:
            system = system.with_attached(shaker.armature_mass, shaker.suspension_stiffness)
        self.system = system
        self.dt = float(dt)
        self.shaker = shaker
        self._P = np.empty((8, system.n_modes))
        _props(system.omega, system.zeta, self.dt, self._P)
        self.events = True
        self._phi = [np.ascontiguousarray(system.shapes[i]) for i in range(3)]
        c = system.contact
        self._contact = (
            float(c.gap),
            float(c.stiffness),
            float(c.damping),
            float(c.hertz_exponent),
            law_code(c),
        )
        if shaker is None:
            self._shaker = np.zeros(8)
        else:
            e, c0, c1 = _coil_coefficients(shaker, self.dt)
            self._shaker = np.array(
                [
                    1.0,
                    shaker.force_factor,
                    e,
                    c0,
                    c1,
                    shaker.suspension_damping,
                    shaker.armature_mass,
                    shaker.suspension_stiffness,
                ]
            )
        self.state = StepperState(np.zeros(system.n_modes), np.zeros(system.n_modes), np.zeros(5))

    def reset(self) -> None:
        """Back to rest at t = 0."""
        self.state = StepperState(np.zeros(self.system.n_modes), np.zeros(self.system.n_modes), np.zeros(5))

    @property
    def time(self) -> float:
        return self.state.time

    def step(self, u: np.ndarray, out: np.ndarray | None = None) -> StepOutput:
        """Advance ``len(u)`` steps.

        Parameters
        ----------
        u
            Input at the end of each step: force at the force point (N), or coil voltage (V)
            with a shaker.
        out
            Optional preallocated ``(len(u), N_OUT)`` array to write into.

        Returns
        -------
        StepOutput
            Time and outputs at the end of each step.
        """
        u = np.ascontiguousarray(u, dtype=float).ravel()
        if out is None:
            out = np.empty((u.size, N_OUT))
        t0 = self.state.time
        self.advance(u, out)
        return StepOutput(t0 + self.dt * np.arange(1, u.size + 1), out)

    def advance(self, u: np.ndarray, out: np.ndarray) -> None:
        """:meth:`step` without the time array: ``u`` a contiguous float array, ``out`` a
        ``(len(u), N_OUT)`` array written in place. Allocates nothing per step.

        Raises
        ------
        SimulationInputError
            A non-finite input.
        SimulationDivergedError
            A non-finite or absurd output (the message names the likely parameters).
        """
        st = self.state
        gap, kc, cc, p, code = self._contact
        if not np.isfinite(u).all():
            raise SimulationInputError(
                f"the input ({'coil voltage' if self.shaker else 'force'}) holds a non-finite value"
            )
        bad = _kernel(
            self._P,
            self.system.omega,
            self.system.zeta,
            self._phi[0],
            self._phi[1],
            self._phi[2],
            st.q,
            st.v,
            st.scalars,
            u,
            out,
            self.dt,
            gap,
            kc,
            cc,
            p,
            code,
            self._shaker,
            self.events,
        )
        if bad >= 0:
            # the values the kernel ran with (the same as system.contact unless overridden)
            ran = _ContactSystem(self.system, replace(self.system.contact, gap=gap, stiffness=kc, damping=cc))
            raise SimulationDivergedError(diverged_message(ran, self.dt, st.time + self.dt * (bad + 1)))
        st.time = st.time + self.dt * u.size


class _ContactSystem:
    """A system seen with other contact values (for :func:`diverged_message`)."""

    def __init__(self, system, contact):
        self._system = system
        self.contact = contact
        self.zeta = getattr(system, "zeta", np.zeros(1))

    def contact_effective_mass(self) -> float:
        return self._system.contact_effective_mass()


def diverged_message(system, dt: float, time: float) -> str:
    """One line naming the parameters that most likely made a run diverge at ``time``."""
    c = system.contact
    meff = system.contact_effective_mass()
    zeta_c = effective_contact_damping(c) / (2 * math.sqrt(c.stiffness * meff))
    suspects = []
    if zeta_c > 1:
        suspects.append(f"contact damping {c.damping:.3g} ({zeta_c:.3g} of critical)")
    zeta = getattr(system, "zeta", np.zeros(1))
    if np.max(zeta) > 10:
        suspects.append(f"modal damping (ratio up to {np.max(zeta):.3g}: Rayleigh alpha/beta?)")
    suspects.append(f"contact stiffness {c.stiffness:.3g} N/m and time step {dt * 1e6:.3g} us")
    return (
        f"the simulation diverged (non-finite or > {DIVERGED_DISPLACEMENT:g} m displacement) at "
        f"t = {time:.6g} s; likely cause: {'; '.join(suspects)}"
    )


def validate_contact(system: HasContact) -> None:
    """Refuse a negative gap or a non-positive stiffness / negative damping with one line."""
    c = system.contact
    if not c.gap >= 0:
        raise SimulationInputError(f"gap must be >= 0, got {c.gap * 1e3:g} mm")
    if not c.stiffness > 0:
        raise SimulationInputError(f"contact stiffness must be > 0, got {c.stiffness:g} N/m")
    if not c.damping >= 0:
        raise SimulationInputError(f"contact damping must be >= 0, got {c.damping:g} N s/m")


# --------------------------------------------------------------------------- harmonic runs

DEFAULT_STEPS_PER_CONTACT = 30  # halving the step then moves harmonics k <= 10 by < 0.2 %


@dataclass
class RunState:
    """What a sweep carries from one point to the next: the stepper state and the force phase."""

    stepper: StepperState
    phase: float = 0.0  # phase of the force sin(phase) at the state's time, rad


@dataclass
class VibroImpactRun:
    """A harmonically forced run, settled to steady state, then recorded.

    ``outputs`` holds the recorded time histories (keys of :data:`OUT_COLUMNS`, SI, y direction),
    sampled at ``sample_rate = fe * steps_per_period``; the record holds ``record_periods``
    whole excitation periods, starting at an instant where the force phase is zero.
    """

    fe: float
    force_amplitude: float
    gap: float
    dt: float
    steps_per_period: int
    record_periods: int
    time: np.ndarray
    outputs: dict[str, np.ndarray]
    steady_state: bool
    period_multiple: int
    mismatch: float
    settle_time: float
    contact_period: float
    final_state: RunState = field(repr=False)

    @property
    def sample_rate(self) -> float:
        return self.fe * self.steps_per_period

    @property
    def peak_contact_force(self) -> float:
        return float(self.outputs["contact_force"].max())

    @property
    def impacts_per_period(self) -> float:
        """Contact onsets per excitation period over the record.

        The record holds whole periods of a periodic response, so it wraps around: a contact
        that starts on the first sample is counted (its previous sample is the last one).
        """
        closed = self.outputs["contact_force"] > 0
        onsets = int(np.count_nonzero(closed & ~np.roll(closed, 1)))
        return onsets / self.record_periods

    @property
    def min_steps_per_contact(self) -> float:
        """Shortest contact in the record, in steps (inf without contact)."""
        closed = np.r_[False, self.outputs["contact_force"] > 0, False].astype(np.int8)
        edges = np.diff(closed)
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        # a contact that straddles the record ends is not a whole contact
        lengths = [e - s for s, e in zip(starts, ends, strict=True) if s > 0 and e < closed.size - 2]
        return float(min(lengths)) if lengths else float("inf")

    def energy_balance(self) -> dict[str, float]:
        """Work per excitation period over the record, J (contact damping from the exact
        per-step energies of the kernel, the rest by the periodic trapezoidal rule).

        Returns ``input`` (``excitation_force * force_point_velocity``), ``modal_damping``,
        ``contact_damping``, and ``imbalance = (input - dissipated) / input`` (stored energy
        returns to its value after whole periods of a periodic response).
        """
        o = self.outputs

        def work(p):  # whole periods of a periodic signal: the rectangle sum is the trapezoid rule
            return float(np.sum(p)) * self.dt / self.record_periods

        w_in = work(o["excitation_force"] * o["force_point_velocity"])
        w_md = work(o["damping_power"])
        w_cd = work(o["contact_damping_power"])
        imbalance = (w_in - w_md - w_cd) / w_in if w_in != 0 else float("nan")
        return {"input": w_in, "modal_damping": w_md, "contact_damping": w_cd, "imbalance": imbalance}


def steps_per_period_for(
    system: ReducedSystem,
    fe: float,
    steps_per_contact: int = DEFAULT_STEPS_PER_CONTACT,
    force_scale: float = 100.0,
    k_max: int = 30,
) -> int:
    """Integer steps per excitation period giving at least ``steps_per_contact`` steps per
    contact period, ``c dt / m_eff <= 1`` for the contact damping ``c`` and a sample rate of at
    least ``4 * k_max * fe``."""
    tc = contact_period(system.contact_effective_mass(), system.contact, force_scale)
    n = math.ceil(steps_per_contact / (fe * tc) - 1e-9)
    # and c dt / m_eff <= 1 for the contact damping (half the limit of check_time_step)
    c = effective_contact_damping(system.contact, force_scale)
    n_c = math.ceil(c / (fe * system.contact_effective_mass()) - 1e-9) if c > 0 else 0
    return max(n, n_c, 4 * k_max)


def validate_harmonic_input(fe: float, force_amplitude: float, gap: float | None = None) -> None:
    """One-line refusal of a non-positive frequency, a negative force or gap."""
    if not (fe > 0 and math.isfinite(fe)):
        raise SimulationInputError(f"excitation frequency must be > 0 Hz, got {fe:g} Hz")
    if not (force_amplitude >= 0 and math.isfinite(force_amplitude)):
        raise SimulationInputError(f"force amplitude must be >= 0 N, got {force_amplitude:g} N")
    if gap is not None and not gap >= 0:
        raise SimulationInputError(f"gap must be >= 0, got {gap * 1e3:g} mm")


class _TipHistory:
    """The last ``keep`` samples of both tips' displacement and velocity (rows), appended from
    the kernel's output in place: no allocation per chunk."""

    COLUMNS = (0, 1, 3, 4)  # active x, v; passive x, v (OUT_COLUMNS)

    def __init__(self, keep: int, chunk: int) -> None:
        self.keep = int(keep)
        self.buf = np.empty((len(self.COLUMNS), self.keep + max(int(chunk), self.keep)))
        self.end = 0

    def append(self, out: np.ndarray) -> None:
        m, cap = out.shape[0], self.buf.shape[1]
        if m >= self.keep:
            for r, c in enumerate(self.COLUMNS):
                self.buf[r, : self.keep] = out[m - self.keep :, c]
            self.end = self.keep
            return
        if self.end + m > cap:
            # move the samples still needed to the front (row by row: 1-D copies, no temporary)
            n_old = min(self.end, self.keep - m)
            for r in range(len(self.COLUMNS)):
                self.buf[r, :n_old] = self.buf[r, self.end - n_old : self.end]
            self.end = n_old
        for r, c in enumerate(self.COLUMNS):
            self.buf[r, self.end : self.end + m] = out[:, c]
        self.end += m

    def view(self) -> np.ndarray:
        """(4, min(samples so far, keep)) view of the latest samples, oldest first."""
        return self.buf[:, max(0, self.end - self.keep) : self.end]


def _pair_scale(hist: np.ndarray, n: int) -> np.ndarray:
    """Common scale of the tip displacements (rows 0, 2) and of the tip velocities (rows 1, 3)
    over the last three periods."""
    span = np.ptp(hist[:, -3 * n :], axis=1)
    x, v = max(span[0], span[2]), max(span[1], span[3])
    return np.array([x, v, x, v])


def run_harmonic(
    system: ReducedSystem,
    fe: float,
    force_amplitude: float,
    *,
    record_periods: int = 20,
    steps_per_period: int | None = None,
    max_settle_time: float = 30.0,
    tol: float = 1e-5,
    check_every: int = 5,
    initial: RunState | None = None,
    min_settle_periods: int = 0,
    progress: Callable[[float, float], None] | None = None,
    force_harmonics=None,
) -> VibroImpactRun:
    """Force ``F0 sin(2 pi fe t)`` at the force point, run to a periodic steady state, record.

    With ``force_harmonics`` the periodic force ``sum_k A_k cos(k 2 pi fe t + phi_k)`` replaces
    ``F0 sin`` (e.g. the harmonics of a force measured on the rig).

    Parameters
    ----------
    system
        Reduced system (its ``contact`` sets the gap and stiffness).
    fe, force_amplitude
        Excitation frequency (Hz, > 0) and force amplitude (N, >= 0).
    record_periods
        Whole excitation periods recorded after settling (>= 1).
    steps_per_period
        Integer steps per period (default: :func:`steps_per_period_for`). Refused with
        :class:`SimulationInputError` if the step does not resolve the contact (for a Hertz
        contact, its tangent stiffness at ``max(100 N, 10 F0)``).
    max_settle_time
        Give up settling after this much simulated time, s (``steady_state`` is then False and
        the record follows anyway).
    tol
        Relative period-to-period mismatch of the tip displacements and velocities accepted
        as steady (:func:`rigtools.sim.steady_state.check_periodic`).
    check_every
        Periods simulated between checks.
    initial
        State to start from (a previous point of a sweep); default: at rest.
    min_settle_periods
        Periods to run before the first check.
    progress
        ``progress(simulated_s, at_most_s)`` after every ``check_every`` periods of settling.
    force_harmonics
        The periodic force instead of ``F0 sin``: a sequence of ``(k, A_k, phi_k)`` (k >= 1
        integer, peak amplitude A_k >= 0 in N, phase phi_k in rad, the convention of
        :mod:`rigtools.analysis.harmonics`) or a 1-D complex array ``c`` with ``c[k-1] = A_k exp(i phi_k)``;
        ``F0 sin`` is ``[(1, F0, -pi/2)]``. Each ``k`` must lie below half the steps per period.
        ``force_amplitude`` is then only recorded as the run's nominal amplitude (and sizes the
        step with the harmonics' sum). Default ``None``: ``F0 sin``, bit-identical to before.

    Returns
    -------
    VibroImpactRun
    """
    from rigtools.sim.steady_state import check_periodic

    validate_harmonic_input(fe, force_amplitude, system.contact.gap)
    validate_contact(system)
    record_periods = int(record_periods)
    if record_periods < 1:
        raise SimulationInputError("the record must hold at least one excitation period")
    harmonics = None if force_harmonics is None else periodic_force_terms(force_harmonics)
    # a Hertz contact stiffens with the force: size the step for a generous peak force
    peak = force_amplitude if harmonics is None else max(force_amplitude, float(np.sum(harmonics[:, 1])))
    force_scale = max(100.0, 10.0 * peak)
    n = (
        steps_per_period_for(system, fe, force_scale=force_scale)
        if steps_per_period is None
        else int(steps_per_period)
    )
    dt = 1.0 / (fe * n)
    stepper = VibroImpactStepper(system, dt, force_scale=force_scale)
    if initial is not None:
        stepper.state = initial.stepper.copy()
        phase0 = initial.phase
    else:
        phase0 = 0.0
    w = 2.0 * np.pi * fe
    t_start = stepper.time
    if harmonics is None:
        stepper.state.scalars[_S_F] = force_amplitude * math.sin(phase0)
        # one period of force samples at the step ends; the phase restarts each period
        ramp = force_amplitude * np.sin(phase0 + w * dt * np.arange(1, n + 1))
    else:
        if np.any(harmonics[:, 0] >= n / 2):
            raise SimulationInputError(
                f"force harmonic k = {int(harmonics[:, 0].max())} needs more than {n} steps per period "
                f"(k < steps / 2)"
            )
        stepper.state.scalars[_S_F] = float(periodic_force(harmonics, np.array([phase0]))[0])
        ramp = periodic_force(harmonics, phase0 + w * dt * np.arange(1, n + 1))
    chunk = np.tile(ramp, check_every)
    keep = max(check_every, 3 + 4) * n  # enough periods for m <= 4 with 3 compared
    hist = _TipHistory(keep, chunk.size)
    out = np.empty((chunk.size, N_OUT))
    periods_run = 0
    steady = False
    per = None
    max_periods = max(math.ceil(max_settle_time * fe), check_every)
    while periods_run < max_periods:
        stepper.advance(chunk, out)
        periods_run += check_every
        if progress is not None:
            progress(periods_run / fe, (max_periods + record_periods) / fe)
        hist.append(out)
        if periods_run < min_settle_periods:
            continue
        tips = hist.view()
        per = check_periodic(tips, n, tol, scale=_pair_scale(tips, n))
        if per.steady:
            steady = True
            break
    settle_time = stepper.time - t_start
    rec_u = np.tile(ramp, record_periods)
    # samples at t = 0, dt, ..., (P n - 1) dt of the record, the force phase being phase0 at t = 0:
    # the last settling output, then the kernel's outputs written straight behind it
    buf = np.empty((rec_u.size + 1, N_OUT))
    buf[0] = out[-1] if periods_run else 0.0
    stepper.advance(rec_u, buf[1:])
    hist.append(buf[1:])
    tips = hist.view()
    final = check_periodic(tips, n, tol, scale=_pair_scale(tips, n))
    steady = final.steady  # the record itself must repeat (checked on its last periods)
    data = buf[:-1]
    t_rec = dt * np.arange(data.shape[0])
    outputs = {name: data[:, i] for i, name in enumerate(OUT_COLUMNS) if name != "coil_current"}
    return VibroImpactRun(
        fe=float(fe),
        force_amplitude=float(force_amplitude),
        gap=float(system.contact.gap),
        dt=dt,
        steps_per_period=n,
        record_periods=record_periods,
        time=t_rec,
        outputs=outputs,
        steady_state=bool(steady),
        period_multiple=final.period_multiple if steady else 0,
        mismatch=float(final.mismatch),
        settle_time=float(settle_time),
        contact_period=stepper.contact_period,
        final_state=RunState(stepper.state.copy(), phase0),
    )


def periodic_force_terms(force_harmonics) -> np.ndarray:
    """``(n, 3)`` array of ``(k, A_k, phi_k)`` from :func:`run_harmonic`'s ``force_harmonics``
    (tuples or complex coefficients); refuses a non-integer or non-positive ``k``, a negative
    or non-finite amplitude."""
    arr = np.asarray(force_harmonics)
    if np.iscomplexobj(arr):
        c = arr.ravel()
        terms = np.column_stack([np.arange(1, c.size + 1), np.abs(c), np.angle(c)])
    else:
        terms = np.asarray(arr, dtype=float).reshape(-1, 3) if arr.size else np.empty((0, 3))
    if terms.shape[0] == 0:
        raise SimulationInputError("force_harmonics holds no harmonic")
    k, a, _ph = terms.T
    if not (np.all(np.isfinite(terms)) and np.all(k >= 1) and np.all(k == np.round(k))):
        raise SimulationInputError("force harmonics need integer orders k >= 1 and finite values")
    if np.any(a < 0):
        raise SimulationInputError("force harmonic amplitudes must be >= 0 N")
    return terms


def periodic_force(terms: np.ndarray, phase: np.ndarray) -> np.ndarray:
    """``sum_k A_k cos(k phase + phi_k)`` of :func:`periodic_force_terms` at phases ``phase`` (rad)."""
    phase = np.asarray(phase, dtype=float)
    out = np.zeros_like(phase)
    for k, a, ph in terms:
        out += a * np.cos(k * phase + ph)
    return out


# --------------------------------------------------------------------------- exact harmonics


def _segment_integrals(phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``A = int_0^1 exp(-i phi u) du`` and ``B = int_0^1 u exp(-i phi u) du`` (series for small
    ``|phi|``, where the closed forms cancel)."""
    phi = np.asarray(phi, dtype=float)
    z = -1j * phi
    small = np.abs(phi) < 0.05
    with np.errstate(divide="ignore", invalid="ignore"):
        A = np.where(small, 0.0, np.expm1(z) / np.where(small, 1.0, z))
        B = np.where(small, 0.0, (np.exp(z) - A) / np.where(small, 1.0, z))
    if np.any(small):
        zs = z[small]
        a = np.zeros_like(zs)
        b = np.zeros_like(zs)
        term = np.ones_like(zs)  # z^n / n!
        for n in range(9):
            a += term / (n + 1)
            b += term / (n + 2)
            term = term * zs / (n + 1)
        A = A.astype(complex)
        B = B.astype(complex)
        A[small] = a
        B[small] = b
    return A, B


def contact_force_harmonics(run: VibroImpactRun, k_max: int = 30) -> np.ndarray:
    """Exact Fourier coefficients of the contact force of a settled run, k = 1 .. ``k_max``.

    The integrator's contact load is piecewise linear in time, with a break (and at first touch
    of the linear and Hertz laws a jump) at the contact event located inside a step; the kernel
    records it per step (``contact_split``, ``contact_force_before_split``,
    ``contact_force_after_split``). The Fourier integrals of these segments are evaluated in
    closed form, so no sampling error is made (a least-squares fit of the step-end samples is off
    by up to a few % at the jump). Periodic record assumed (``run.steady_state``).

    Parameters
    ----------
    run
        A :class:`VibroImpactRun` (from :func:`run_harmonic`).
    k_max
        Highest harmonic order.

    Returns
    -------
    np.ndarray
        Complex ``(k_max,)``: ``c_k`` with ``f(t) = f_mean + sum_k Re(c_k exp(i 2 pi k fe t))``,
        t from the first sample of the record (force phase zero); peak amplitude ``|c_k|`` (N),
        phase ``angle(c_k)`` of ``cos(2 pi k fe t + phase)``.
    """
    o = run.outputs
    k_max = int(k_max)
    if k_max < 1:
        raise ValueError(f"k_max must be >= 1, got {k_max}")
    f_end = np.asarray(o["contact_force"], dtype=float)
    theta = np.asarray(o["contact_split"], dtype=float)
    f_before = np.asarray(o["contact_force_before_split"], dtype=float)
    f_after = np.asarray(o["contact_force_after_split"], dtype=float)
    # row m describes the step ending at t = m dt (row 0: the step ending at the record start,
    # which the periodic record repeats at its end); its start force is row m - 1's end force
    f_start = np.roll(f_end, 1)
    dt = run.dt
    t_start = (np.arange(f_end.size) - 1) * dt
    period_total = f_end.size * dt
    k = np.arange(1, k_max + 1)[:, None]
    w = 2.0 * np.pi * run.fe * k
    total = np.zeros(k_max, dtype=complex)
    # segment 1: [0, theta dt] from f_start to f_before; segment 2: [theta dt, dt] from f_after
    # to f_end; int_a^{a+h} (f0 + (f1 - f0) u) e^{-i w t} dt = h e^{-i w a} (f0 A + (f1 - f0) B)
    for a, h, f0, f1 in (
        (t_start, theta * dt, f_start, f_before),
        (t_start + theta * dt, (1.0 - theta) * dt, f_after, f_end),
    ):
        live = (h > 0) & ((f0 != 0) | (f1 != 0))
        if not np.any(live):
            continue
        a_, h_, f0_, f1_ = a[live], h[live], f0[live], f1[live]
        A, B = _segment_integrals(w * h_)
        total += np.sum(h_ * np.exp(-1j * w * a_) * (f0_ * A + (f1_ - f0_) * B), axis=1)
    return 2.0 * total / period_total


# --------------------------------------------------------------------------- cost estimate

# Rough speed of the compiled kernel on the reference machine (2 shared cores, 2026): about
# 25-55 ns per step and mode, settling checks included (kc = 1e6, 1e8, 1e10 N/m on the default
# rig). Only for telling a user "this will take minutes"; never used for decisions.
SECONDS_PER_MODE_STEP = 30e-9


@dataclass(frozen=True)
class CostEstimate:
    """What a harmonic run will cost (:func:`estimate_steps`)."""

    steps_per_period: int
    limited_by: str  # "contact stiffness", "contact damping" or "harmonics"
    time_step: float  # s
    settle_periods: int  # estimated periods to settle (modal-damping decay to ``tol``)
    record_periods: int
    total_steps: int  # (settle + record) * steps_per_period
    mode_steps: int  # total_steps * n_modes: the kernel's work
    seconds: float  # rough wall time at SECONDS_PER_MODE_STEP
    worst_case_steps: int  # if the run never settles: max_settle_time, then the record
    worst_case_seconds: float

    def describe(self) -> str:
        """One line for a user, e.g. ``'~7.5e+07 steps (3.27e+05 per period, set by the contact
        stiffness), about 32 s (up to 4.6e+02 s if it does not settle)'``."""
        return (
            f"~{self.total_steps:.2g} steps ({self.steps_per_period:.3g} per period, set by the "
            f"{self.limited_by}), about {self.seconds:.2g} s (up to {self.worst_case_seconds:.2g} s "
            f"if it does not settle)"
        )


def estimate_steps(
    system: ReducedSystem,
    fe: float,
    force_amplitude: float = 0.0,
    *,
    record_periods: int = 20,
    steps_per_period: int | None = None,
    tol: float = 1e-5,
    max_settle_time: float = 30.0,
    check_every: int = 5,
) -> CostEstimate:
    """Cheap up-front estimate of a :func:`run_harmonic` call (no integration).

    Steps per period as :func:`run_harmonic` chooses them; settling time from the slowest
    decaying flexural mode, ``ln(1 / tol) / min(zeta_j w_j)`` (an upper bound in practice: the
    contact damping only speeds settling; measured on the default rig at 60 Hz: 3.1-4.3 s against
    3.4 s estimated), capped at ``max_settle_time``, rounded up to ``check_every`` periods. A
    run that never settles (a nearly elastic contact, e.g. 1e12 N/m with 200 N*s/m: 4e-4 of
    critical) runs for ``max_settle_time``: ``worst_case_steps``.
    Arguments as :func:`run_harmonic`. Raises :class:`SimulationInputError` for invalid input.
    """
    validate_harmonic_input(fe, force_amplitude, system.contact.gap)
    validate_contact(system)
    force_scale = max(100.0, 10.0 * force_amplitude)
    auto = steps_per_period_for(system, fe, force_scale=force_scale)
    n = auto if steps_per_period is None else int(steps_per_period)
    if steps_per_period is None:
        tc = contact_period(system.contact_effective_mass(), system.contact, force_scale)
        n_k = math.ceil(DEFAULT_STEPS_PER_CONTACT / (fe * tc) - 1e-9)
        c = effective_contact_damping(system.contact, force_scale)
        n_c = math.ceil(c / (fe * system.contact_effective_mass()) - 1e-9) if c > 0 else 0
        limited = (
            "harmonics"
            if n == 4 * 30 and n > max(n_k, n_c)
            else "contact damping"
            if n_c > n_k
            else "contact stiffness"
        )
    else:
        limited = "given steps per period"
    real = np.ones(system.n_modes, bool) if system.pseudo is None else ~np.asarray(system.pseudo, bool)
    decay = float(np.min((system.zeta * system.omega)[real])) if real.any() else math.inf
    t_settle = math.log(1.0 / tol) / decay if decay > 0 else math.inf
    t_settle = min(t_settle, max_settle_time)
    periods = max(check_every, math.ceil(t_settle * fe / check_every) * check_every)
    total = (periods + int(record_periods)) * n
    mode_steps = total * system.n_modes
    max_periods = max(math.ceil(max_settle_time * fe), check_every)
    worst = (math.ceil(max_periods / check_every) * check_every + int(record_periods)) * n
    return CostEstimate(
        steps_per_period=n,
        limited_by=limited,
        time_step=1.0 / (fe * n),
        settle_periods=periods,
        record_periods=int(record_periods),
        total_steps=total,
        mode_steps=mode_steps,
        seconds=mode_steps * SECONDS_PER_MODE_STEP,
        worst_case_steps=worst,
        worst_case_seconds=worst * system.n_modes * SECONDS_PER_MODE_STEP,
    )
