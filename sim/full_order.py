"""Full-order reference: HHT-alpha (Newmark average acceleration for alpha = 0) time integration
of the full FE matrices of both blades with the same shroud contact.

HHT-alpha (Hilber-Hughes-Taylor), ``0 <= alpha <= 1/3``, ``beta = (1 + alpha)^2 / 4``,
``gamma = 1/2 + alpha``::

    M a1 + (1 - alpha) (C v1 + K u1) + alpha (C v0 + K u0) = (1 - alpha) f1 + alpha f0
    u1 = u0 + dt v0 + dt^2 ((1/2 - beta) a0 + beta a1),   v1 = v0 + dt ((1 - gamma) a0 + gamma a1)

Every step solves ``S a1 = r - (1 - alpha) lambda S^-1 d`` with ``S = M + (1 - alpha)(gamma dt C
+ beta dt^2 K)`` factorised once; the contact force ``lambda`` enters through the single vector
``d`` (active tip minus passive tip), so the closure at the end of the step is affine in
``lambda`` and the same scalar contact solve as the fast model applies (Newton for Hertz).

Two equivalent solvers:

* ``"physical"``: factorise ``S`` (dense Cholesky per blade; the modal-ratio damping matrix is
  dense) and step in physical coordinates. Generic, slow (milliseconds per step).
* ``"modal"``: ``M``, ``K`` and ``C`` (modal ratio or Rayleigh) are all diagonalised by the full
  set of mass-normalised modes, so the same HHT recurrences decouple exactly mode by mode.
  Modes that do not move the load DOFs (edgewise, torsion, axial) are never excited and are
  left out, which is exact. A compiled loop, microseconds per step. The test suite checks the two
  against each other step by step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from numba import njit

from rigtools.sim.contact import kernel_contact, solve_contact
from rigtools.sim.impact_kernel import DIVERGED_DISPLACEMENT, N_OUT, NO_SUMS, OUT_COLUMNS, add_mode
from rigtools.sim.impact_stepper import (
    SimulationDivergedError,
    SimulationInputError,
    check_time_step,
    diverged_message,
)
from rigtools.sim.modal import blade_modes
from rigtools.sim.params import ContactParams
from rigtools.sim.rig_model import RigModel

# outputs: the same columns as the fast stepper (coil current always zero)


@dataclass
class FullOrderSystem:
    """Full modal decomposition of the rig for the modal HHT solver.

    ``omega``, ``cdiag`` per mode (modal damping coefficient ``phi^T C phi``), ``rows`` (3, n) at
    ``(active_tip, passive_tip, force_point)`` like :class:`rigtools.sim.reduction.ReducedSystem`.
    """

    omega: np.ndarray
    cdiag: np.ndarray
    rows: np.ndarray
    n_dofs: int
    damping_offdiag: float

    def contact_effective_mass(self) -> float:
        a = float(np.sum(self.rows[0] ** 2))
        p = float(np.sum(self.rows[1] ** 2))
        ma, mp = 1.0 / a, 1.0 / p
        return ma * mp / (ma + mp)


def full_modal_system(model: RigModel) -> FullOrderSystem:
    """All modes of both blades that move a load DOF (exact modal form of the full model)."""
    omegas, cds, rows = [], [], []
    worst = 0.0
    n_a = model.active.n_dofs
    for idx, (name, off) in enumerate((("active", 0), ("passive", n_a))):
        blade = model.blade(name)
        modes = blade_modes(blade)
        tip = blade.dof(blade.tip_node, 1)
        loads = [tip] if blade.sensor_node is None else [tip, blade.dof(blade.sensor_node, 1)]
        r = modes.shapes[loads, :]
        keep = np.abs(r).max(axis=0) > 1e-12 * np.abs(r).max()
        phi = modes.shapes[:, keep]
        c = model.damping[off : off + blade.n_dofs, off : off + blade.n_dofs]
        cproj = phi.T @ (c @ phi)
        cd = np.diag(cproj).copy()
        off_diag = cproj - np.diag(cd)
        worst = max(worst, float(np.abs(off_diag).max() / np.abs(cd).max()))
        row = np.zeros((3, phi.shape[1]))
        row[idx] = phi[tip]
        if blade.sensor_node is not None:
            row[2] = phi[loads[1]]
        omegas.append(modes.omegas[keep])
        cds.append(cd)
        rows.append(row)
    return FullOrderSystem(np.concatenate(omegas), np.concatenate(cds), np.hstack(rows), model.n_dofs, worst)


@njit(cache=True)
def _hht_modal(omega, cdiag, rA, rP, rF, u, v, a, s, force, out, dt, alpha, gap, kc, cc, pexp, code):
    """HHT-alpha on decoupled modes with the contact through the rows; state in place."""
    n = omega.size
    beta = 0.25 * (1.0 + alpha) ** 2
    gamma = 0.5 + alpha
    d = rA - rP
    k = omega * omega
    sdiag = 1.0 + (1.0 - alpha) * (gamma * dt * cdiag + beta * dt * dt * k)
    # closure per unit contact force (through a1 = a0 - (1 - alpha) lambda z, z = d / s)
    dz = 0.0
    for j in range(n):
        dz += d[j] * d[j] / sdiag[j]
    a0 = np.empty(n)
    up = np.empty(n)
    vp = np.empty(n)
    for i in range(force.size):
        F_old = s[0]
        lam_old = s[1]
        F_new = force[i]
        g0 = -gap
        gd0 = 0.0
        for j in range(n):
            upj = u[j] + dt * v[j] + dt * dt * (0.5 - beta) * a[j]
            vpj = v[j] + dt * (1.0 - gamma) * a[j]
            up[j] = upj
            vp[j] = vpj
            f0 = rF[j] * F_old - d[j] * lam_old
            f1 = rF[j] * F_new
            r = (
                (1.0 - alpha) * f1
                + alpha * f0
                - (1.0 - alpha) * (cdiag[j] * vpj + k[j] * upj)
                - alpha * (cdiag[j] * v[j] + k[j] * u[j])
            )
            a0[j] = r / sdiag[j]
            g0 += d[j] * (upj + beta * dt * dt * a0[j])
            gd0 += d[j] * (vpj + gamma * dt * a0[j])
        g1 = -beta * dt * dt * (1.0 - alpha) * dz
        v1 = -gamma * dt * (1.0 - alpha) * dz
        lam = solve_contact(g0, g1, gd0, v1, kc, cc, pexp, code)
        sums = NO_SUMS
        for j in range(n):
            aj = a0[j] - (1.0 - alpha) * lam * d[j] / sdiag[j]
            uj = up[j] + beta * dt * dt * aj
            vj = vp[j] + gamma * dt * aj
            u[j] = uj
            v[j] = vj
            a[j] = aj
            sums = add_mode(sums, rA[j], rP[j], rF[j], cdiag[j], uj, vj, aj)
        xa, va, aa, xp, vpp, ap, xF, vF, aF, pd = sums
        s[0] = F_new
        s[1] = lam
        out[i, 0] = xa
        out[i, 1] = va
        out[i, 2] = aa
        out[i, 3] = xp
        out[i, 4] = vpp
        out[i, 5] = ap
        out[i, 6] = xF
        out[i, 7] = vF
        out[i, 8] = aF
        out[i, 9] = lam
        out[i, 10] = F_new
        out[i, 11] = 0.0
        out[i, 12] = pd
        gd = va - vpp
        out[i, 13] = cc * gd * gd if (lam > 0.0 and cc > 0.0 and lam - cc * gd > 0.0) else 0.0
        if code == 2:
            g_end = xa - xp - gap
            out[i, 13] = cc * g_end**pexp * gd * gd if (lam > 0.0 and g_end > 0.0) else 0.0
        out[i, 14] = 1.0  # no events: the force is taken linear over every step
        out[i, 15] = lam
        out[i, 16] = lam


class FullOrderIntegrator:
    """HHT-alpha integration of the full FE rig model with shroud contact.

    Parameters
    ----------
    model
        :class:`rigtools.sim.rig_model.RigModel` (its ``params.contact`` is used unless ``contact`` given).
    dt
        Time step, s (must resolve the contact period with 20 steps).
    alpha
        HHT parameter in [0, 1/3]; 0 is the average-acceleration Newmark rule (no numerical
        damping); a small alpha damps the unresolved highest FE modes.
    solver
        ``"modal"`` (default, exact modal form, fast) or ``"physical"`` (factorised full matrices).
    contact
        Override of the contact parameters (e.g. another gap).

    Notes
    -----
    ``step(force)`` takes the force at the force DOF at the end of each step and returns an array
    ``(n, N_OUT)`` with the columns of :data:`rigtools.sim.vibro_impact.OUT_COLUMNS`.
    """

    def __init__(
        self,
        model: RigModel,
        dt: float,
        alpha: float = 0.0,
        solver: str = "modal",
        contact: ContactParams | None = None,
    ):
        if not 0.0 <= alpha <= 1.0 / 3.0:
            raise SimulationInputError(f"HHT alpha must be in [0, 1/3], got {alpha}")
        self.model = model
        self.contact = contact if contact is not None else model.params.contact
        self.dt = float(dt)
        self.alpha = float(alpha)
        self.solver = solver
        self._contact = kernel_contact(self.contact)
        self.system = full_modal_system(model)
        _check = _ContactView(self.system.contact_effective_mass(), self.contact)
        check_time_step(_check, self.dt)
        self.time = 0.0
        if solver == "modal":
            n = self.system.omega.size
            self._u, self._v, self._a = np.zeros(n), np.zeros(n), np.zeros(n)
        elif solver == "physical":
            self._setup_physical()
        else:
            raise ValueError(f"solver must be 'modal' or 'physical', got {solver!r}")
        self._s = np.zeros(2)

    # ----------------------------------------------------------------- physical coordinates
    def _setup_physical(self) -> None:
        m = self.model
        n = m.n_dofs
        a_, dt = self.alpha, self.dt
        beta, gamma = 0.25 * (1 + a_) ** 2, 0.5 + a_
        self._beta, self._gamma = beta, gamma
        S = (m.mass + (1 - a_) * (gamma * dt * m.damping + beta * dt * dt * m.stiffness)).toarray()
        self._S = scipy.linalg.cho_factor(S)
        self._M, self._C, self._K = m.mass.tocsr(), m.damping, m.stiffness.tocsr()
        if sp.issparse(self._C) and self._C.nnz > 0.2 * n * n:
            self._C = self._C.toarray()
        self._d = np.zeros(n)
        self._d[m.active_tip_dof] = 1.0
        self._d[m.passive_tip_dof] = -1.0
        self._eF = np.zeros(n)
        self._eF[m.force_dof] = 1.0
        self._z = scipy.linalg.cho_solve(self._S, self._d)
        self._u, self._v, self._a = np.zeros(n), np.zeros(n), np.zeros(n)

    def _step_physical(self, force: np.ndarray, out: np.ndarray) -> None:
        m = self.model
        a_, dt, beta, gamma = self.alpha, self.dt, self._beta, self._gamma
        gap, kc, cc, p, code = self._contact
        d, z = self._d, self._z
        dz = float(d @ z)
        ia, ip, iF = m.active_tip_dof, m.passive_tip_dof, m.force_dof
        for i, F_new in enumerate(force):
            F_old, lam_old = self._s
            u, v, a = self._u, self._v, self._a
            up = u + dt * v + dt * dt * (0.5 - beta) * a
            vp = v + dt * (1 - gamma) * a
            f0 = self._eF * F_old - d * lam_old
            f1 = self._eF * F_new
            r = (
                (1 - a_) * f1
                + a_ * f0
                - (1 - a_) * (self._C @ vp + self._K @ up)
                - a_ * (self._C @ v + self._K @ u)
            )
            a0 = scipy.linalg.cho_solve(self._S, r)
            g0 = d @ (up + beta * dt * dt * a0) - gap
            gd0 = d @ (vp + gamma * dt * a0)
            lam = solve_contact(
                g0, -beta * dt * dt * (1 - a_) * dz, gd0, -gamma * dt * (1 - a_) * dz, kc, cc, p, code
            )
            a1 = a0 - (1 - a_) * lam * z
            u1 = up + beta * dt * dt * a1
            v1 = vp + gamma * dt * a1
            self._u, self._v, self._a = u1, v1, a1
            self._s[:] = (F_new, lam)
            out[i, :] = 0.0
            out[i, 0:3] = u1[ia], v1[ia], a1[ia]
            out[i, 3:6] = u1[ip], v1[ip], a1[ip]
            out[i, 6:9] = u1[iF], v1[iF], a1[iF]
            out[i, 9] = lam
            out[i, 10] = F_new
            out[i, 12] = float(v1 @ (self._C @ v1))
            out[i, 14] = 1.0
            out[i, 15:17] = lam

    # ----------------------------------------------------------------------------- stepping
    def step(self, force: np.ndarray) -> np.ndarray:
        """Advance ``len(force)`` steps; returns ``(n, N_OUT)`` outputs at the step ends."""
        force = np.ascontiguousarray(force, dtype=float).ravel()
        out = np.empty((force.size, N_OUT))
        if self.solver == "modal":
            gap, kc, cc, p, code = self._contact
            sy = self.system
            _hht_modal(
                sy.omega,
                sy.cdiag,
                sy.rows[0].copy(),
                sy.rows[1].copy(),
                sy.rows[2].copy(),
                self._u,
                self._v,
                self._a,
                self._s,
                force,
                out,
                self.dt,
                self.alpha,
                gap,
                kc,
                cc,
                p,
                code,
            )
        else:
            self._step_physical(force, out)
        if not (
            np.isfinite(out).all() and np.abs(out[:, [0, 3, 6]]).max(initial=0.0) < DIVERGED_DISPLACEMENT
        ):
            raise SimulationDivergedError(
                diverged_message(
                    _ContactView(self.system.contact_effective_mass(), self.contact), self.dt, self.time
                )
            )
        self.time += self.dt * force.size
        return out


class _ContactView:
    """Just enough of a ReducedSystem for :func:`rigtools.sim.vibro_impact.check_time_step`."""

    def __init__(self, meff: float, contact: ContactParams):
        self._meff = meff
        self.contact = contact

    def contact_effective_mass(self) -> float:
        return self._meff


def run_full_order(
    model: RigModel,
    fe: float,
    force_amplitude: float,
    duration: float,
    dt: float,
    alpha: float = 0.0,
    record_periods: int = 10,
    contact: ContactParams | None = None,
) -> dict[str, np.ndarray]:
    """Force ``F0 sin(2 pi fe t)`` from rest for ``duration`` s; return the last
    ``record_periods`` periods of the outputs (keys of ``OUT_COLUMNS``), sampled every step.

    ``1 / (fe dt)`` must be an integer (whole periods of samples).
    """
    n = 1.0 / (fe * dt)
    if abs(n - round(n)) > 1e-6:
        raise SimulationInputError("1/(fe*dt) must be an integer number of steps per period")
    n = round(n)
    periods = math.ceil(duration * fe)
    if periods < record_periods + 1:  # the record starts at the end of a whole period
        raise SimulationInputError(
            f"duration {duration:g} s holds {periods} excitation periods; recording {record_periods} "
            f"needs at least {record_periods + 1}"
        )
    integ = FullOrderIntegrator(model, dt, alpha, contact=contact)
    w = 2 * np.pi * fe
    one = force_amplitude * np.sin(w * dt * np.arange(1, n + 1))
    keep = []
    for k in range(periods):
        o = integ.step(one)
        if k >= periods - record_periods - 1:
            keep.append(o)
    data = np.vstack(keep)
    # samples at t = 0 .. (P n - 1) dt of the record, force phase zero at t = 0 (as run_harmonic)
    data = data[n - 1 : n - 1 + record_periods * n]
    return {name: data[:, i] for i, name in enumerate(OUT_COLUMNS) if name != "coil_current"}
