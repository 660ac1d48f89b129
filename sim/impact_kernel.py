"""The compiled inner loop of the vibro-impact integrator (:func:`_kernel`) and its parts.

Each modal oscillator ``q'' + 2 zeta w q' + w^2 q = p(t)`` is propagated exactly over a step for
a load that varies linearly within the step (first-order hold): ``x1 = E x0 + G0 p0 + G1 p1``
with ``x = (q, q')`` (:func:`_props`, checked against the matrix exponential
:func:`foh_propagators`). The contact force (and, with a shaker, the armature force) at the end of
the step are unknown; the tip closure there is affine in them, so the force is solved consistently
in every step (:func:`rigtools.sim.contact.solve_contact`). A step costs O(n_modes).

The kernel writes one row of :data:`OUT_COLUMNS` per step. It is driven by
:class:`rigtools.sim.impact_stepper.VibroImpactStepper`; :mod:`rigtools.sim.vibro_impact` holds
the settled harmonic runs. :func:`add_mode` (a mode's share of the tips' and the force point's motion) is shared with the full-order reference (:mod:`rigtools.sim.full_order`).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
from numba import njit

from rigtools.sim.contact import solve_contact

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
    # equal to contact_force, in a step without an event); see :func:`rigtools.sim.contact_harmonics.contact_force_harmonics`
    "contact_split",
    "contact_force_before_split",
    "contact_force_after_split",
)
N_OUT = len(OUT_COLUMNS)
DIVERGED_DISPLACEMENT = 1.0e3  # m: no blade tip moves a kilometre
NO_SUMS = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # add_mode's sums before the first mode


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


@njit(cache=True, inline="always")
def add_mode(sums, phiA, phiP, phiF, c, q, v, a):
    """``sums`` plus one mode's share: ``sums = (xa, va, aa, xp, vp, ap, xF, vF, aF, pd)``, the
    displacement, velocity and acceleration of the active tip (shape value ``phiA``), the passive
    tip (``phiP``) and the force point (``phiF``), and the modal damping power ``c v^2``, for the
    mode's coordinate ``q``, rate ``v`` and acceleration ``a``. Inlined into the caller's loop over
    the modes, so each kernel compiles it with its own loop and flags (the sums bit-identical to
    the loops it replaced)."""
    xa, va, aa, xp, vp, ap, xF, vF, aF, pd = sums
    return (
        xa + phiA * q,
        va + phiA * v,
        aa + phiA * a,
        xp + phiP * q,
        vp + phiP * v,
        ap + phiP * a,
        xF + phiF * q,
        vF + phiF * v,
        aF + phiF * a,
        pd + c * v * v,
    )


@njit(cache=True, fastmath=_FAST)
def _kernel(P, omega, zeta, phiA, phiP, phiF, q, v, s, u, out, dt, gap, kc, cc, pexp, code, shaker, events):
    """Kept whole for speed (the per-step loop of every run; its phases share some 20 locals per
    step that helpers would pass and return): step ``len(u)`` times in place (state ``q, v, s``),
    writing ``out (len(u), N_OUT)``.

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
        if not split:
            _finish(P, qf, vf, phiF, d, F, fc, q, v)
            out[i, 14] = 1.0
            out[i, 15] = fc
            out[i, 16] = fc
        else:
            out[i, 14] = theta
            out[i, 15] = 0.0
            out[i, 16] = fc_start
        sums = NO_SUMS
        for j in range(n):
            qj = q[j]
            vj = v[j]
            acc = phiF[j] * F - d[j] * fc - c2[j] * vj - w2[j] * qj
            sums = add_mode(sums, phiA[j], phiP[j], phiF[j], c2[j], qj, vj, acc)
        xa, va, aa, xp, vp, ap, xF, vF, aF, pd = sums
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


@njit(cache=True)
def _kernel_columns(
    P, omega, zeta, phiA, phiP, phiF, Q, V, S, U, out, excitation, dt, gap, kc, cc, pexp, code, shaker, events
):
    """:func:`_kernel` once per row of ``Q, V, S`` (the carried states, each integrated in place
    from its own start), in one compiled call: the columns of a finite-difference Jacobian
    (:meth:`rigtools.sim.orbit_map.PeriodMap.jacobian`) without a Python round trip per column.

    Each row calls the same compiled :func:`_kernel` as a single run (the same arithmetic; its
    results equal that run's bit for bit, tests/sim/test_orbit_map_batched.py). ``U`` holds the input of each row, or one row
    shared by all. ``out`` is reused by every row; the excitation-force column of each row is
    kept in ``excitation`` (its rows, when it has as many as ``Q``).

    Returns ``(row, step)`` of the first row that diverged (the rows after it are not
    integrated; see :func:`_kernel`), or ``(-1, -1)``.
    """
    keep = excitation.shape[0] == Q.shape[0]
    for r in range(Q.shape[0]):
        u = U[r] if U.shape[0] > 1 else U[0]
        bad = _kernel(
            P,
            omega,
            zeta,
            phiA,
            phiP,
            phiF,
            Q[r],
            V[r],
            S[r],
            u,
            out,
            dt,
            gap,
            kc,
            cc,
            pexp,
            code,
            shaker,
            events,
        )
        if bad >= 0:
            return r, bad
        if keep:
            for i in range(u.size):
                excitation[r, i] = out[i, 10]
    return -1, -1
