"""The simulated rig's physics: the shaker coupled to the test article, block by block.

Two propagators, both carrying their state from block to block and both returning, per step,
the mean of each physical signal (:data:`SIGNALS`) over the step, as the integrating sampler of
a DSA input reports it (:func:`interval_means`):

:class:`VibroImpactPhysics`
    The vibro-impact stepper (:class:`rigtools.sim.vibro_impact.VibroImpactStepper`) on the
    reduced test-article model, with the shroud contact and the shaker coupling; impulses (an
    impact hammer's) can be put into either blade.
:class:`LinearModalPhysics`
    Exact discrete-time propagation of the active blade's modes coupled to the shaker, without
    contact (a cross-check of the vibro-impact path with impacts off).

The device around them (delay line, amplifier, channels, noise, faults, timing, the hammer's
schedule) is :class:`rigtools.drivers.simulated.SimulatedRig`. Inputs are coil voltages (the
amplifier's gain already applied), one per step, each the value at the END of its step.
"""

from __future__ import annotations

import numba
import numpy as np
import scipy.linalg

from rigtools.sim.modal import lowest_modes
from rigtools.sim.params import SimulationInputError
from rigtools.sim.reduction import damping_ratios, reduce_rig_model
from rigtools.sim.rig_model import RigModel
from rigtools.sim.vibro_impact import N_OUT, OUT_COLUMNS, ShakerCoupling, VibroImpactStepper

SIGNALS = (
    "force",  # N, force through the sensor into the active blade
    "active_tip_accel",  # m/s^2, active shroud, y
    "passive_tip_accel",  # m/s^2, passive shroud, y
    "force_point_accel",  # m/s^2, active blade at the force sensor, y
    "coil_voltage",  # V, amplifier output
    "coil_current",  # A
    "contact_force",  # N, between the shrouds (>= 0)
    "hammer_force",  # N, impact hammer's force (0 without one)
)
SIGNAL_INDEX = {name: i for i, name in enumerate(SIGNALS)}
_INDEX = SIGNAL_INDEX


class LinearModalPhysics:
    """Exact propagation of the linear active blade coupled to the shaker (no contact).

    The active blade's modes below ``f_max`` that move the force point or the tip (mass-normalised
    shapes ``Phi`` of the FE model, damping ``Phi^T C Phi``) and the shaker form one linear
    state-space system ``x' = A x + B e`` in ``x = [q, q', i]`` (``i`` the coil current; without
    inductance ``i`` is algebraic). ``A`` is diagonalised once; each step is then, per
    eigen-coordinate, ``z1 = exp(lambda dt) z0 + g0 e0 + g1 e1``, exact for a coil voltage varying
    linearly over the step (first-order hold). As in :class:`rigtools.sim.vibro_impact.VibroImpactStepper`,
    ``e[k]`` is the input at the end of step ``k`` (the input before the first call is 0);
    output ``k`` is the mean over step ``k``, exact from ``z' = lambda z + b e``:
    ``mean z = (z1 - z0 - b (e0 + e1) dt / 2) / (lambda dt)`` (what the integrating sampler of
    :func:`interval_means` reports). The passive blade stays at rest.

    Parameters
    ----------
    model
        The rig model (:class:`rigtools.sim.rig_model.RigModel`) of the test article.
    shaker
        Shaker parameters (the amplifier gain is applied before :meth:`step`).
    dt
        Time step, s.
    f_max
        Highest modal frequency kept, Hz (default 20 kHz; the propagation is exact for any mode).
    """

    def __init__(
        self, model: RigModel, shaker: ShakerCoupling, dt: float, f_max: float | None = None
    ) -> None:
        blade = model.active
        f_max = f_max if f_max is not None else 2e4
        # only the group of modes that can move the force point or the tip (sparse solver)
        modes = lowest_modes(blade, below_hz=f_max, dofs=[model.force_dof, model.active_tip_dof])
        phi_all = modes.shapes
        pf_all, pt_all = phi_all[model.force_dof], phi_all[model.active_tip_dof]
        scale = max(np.max(np.abs(pf_all)), np.max(np.abs(pt_all)))
        keep = (modes.frequencies_hz < f_max) & (
            (np.abs(pf_all) > 1e-6 * scale) | (np.abs(pt_all) > 1e-6 * scale)
        )
        phi = phi_all[:, keep]
        self.frequencies_hz = modes.frequencies_hz[keep]
        n = phi.shape[1]
        pf, pt = phi[model.force_dof], phi[model.active_tip_dof]
        # modal damping in modal space: the FE damping is diagonal on mass-normalised modes
        omega = 2 * np.pi * self.frequencies_hz
        c_modal = np.diag(2.0 * damping_ratios(omega, model.params.damping) * omega)
        s = shaker
        ff = np.outer(pf, pf)
        minv = np.linalg.inv(np.eye(n) + s.armature_mass * ff)
        k = np.diag((2 * np.pi * self.frequencies_hz) ** 2) + s.suspension_stiffness * ff
        c = c_modal + s.suspension_damping * ff
        bl, r, ell = s.force_factor, s.coil_resistance, s.coil_inductance
        z = np.zeros((n, n))
        if ell > 0:
            ns = 2 * n + 1
            qdd = np.hstack([-minv @ k, -minv @ c, (minv @ pf * bl)[:, None]])  # q'' = qdd @ x
            a = np.vstack(
                [
                    np.hstack([z, np.eye(n), np.zeros((n, 1))]),
                    qdd,
                    np.concatenate([np.zeros(n), -bl * pf / ell, [-r / ell]])[None, :],
                ]
            )
            b = np.zeros(ns)
            b[-1] = 1.0 / ell
            qdd_d = np.zeros(n)
            cur, cur_d = np.zeros(ns), 0.0
            cur[-1] = 1.0
        else:  # i = (e - Bl v_f) / R
            ns = 2 * n
            c_eff = c + bl**2 / r * ff
            qdd = np.hstack([-minv @ k, -minv @ c_eff])
            a = np.vstack([np.hstack([z, np.eye(n)]), qdd])
            qdd_d = minv @ pf * bl / r
            b = np.concatenate([np.zeros(n), qdd_d])
            cur = np.concatenate([np.zeros(n), -bl * pf / r])
            cur_d = 1.0 / r
        disp_f = np.concatenate([pf, np.zeros(ns - n)])
        vel_f = np.concatenate([np.zeros(n), pf, np.zeros(ns - 2 * n)])
        acc_f, acc_f_d = pf @ qdd, pf @ qdd_d
        out = np.zeros((len(SIGNALS), ns))
        d = np.zeros(len(SIGNALS))
        out[_INDEX["force_point_accel"]], d[_INDEX["force_point_accel"]] = acc_f, acc_f_d
        out[_INDEX["active_tip_accel"]], d[_INDEX["active_tip_accel"]] = pt @ qdd, pt @ qdd_d
        out[_INDEX["coil_current"]], d[_INDEX["coil_current"]] = cur, cur_d
        out[_INDEX["force"]] = (
            bl * cur
            - s.armature_mass * acc_f
            - s.suspension_stiffness * disp_f
            - s.suspension_damping * vel_f
        )
        d[_INDEX["force"]] = bl * cur_d - s.armature_mass * acc_f_d
        d[_INDEX["coil_voltage"]] = 1.0
        lam, vec = scipy.linalg.eig(a)
        b_modal = np.linalg.solve(vec, b)
        # a real system's eigenvalues come in conjugate pairs: keep one of each, weight 2
        upper = lam.imag > 1e-9 * np.abs(lam)
        real = np.abs(lam.imag) <= 1e-9 * np.abs(lam)
        sel = upper | real
        weight = np.where(upper, 2.0, 1.0)[sel]
        lam, vec, b_modal = lam[sel], vec[:, sel], b_modal[sel]
        h = lam * dt
        self._mu = np.exp(h)
        gamma1 = np.expm1(h) / lam * b_modal  # int_0^dt e^{lam (dt - s)} ds
        gamma2 = (np.expm1(h) - h) / (lam * h) * b_modal  # same, weighted by s / dt
        self._g0, self._g1 = gamma1 - gamma2, gamma2
        self._hb = 0.5 * dt * b_modal  # mean z = (z1 - z0 - hb (e0 + e1)) * ih
        self._ih = 1.0 / h
        self._cz = (out @ vec) * weight
        self._d = d
        self._z = np.zeros(lam.size, dtype=complex)
        self._e_last = np.zeros(1)
        self.dt = dt

    def reset(self) -> None:
        """Back to rest."""
        self._z[:] = 0.0
        self._e_last[:] = 0.0

    def step(self, coil_voltage: np.ndarray) -> np.ndarray:
        """Advance over ``coil_voltage`` (one value per step, V); returns ``(len(SIGNALS), n)``."""
        e = np.ascontiguousarray(coil_voltage, dtype=float)
        y = np.empty((len(SIGNALS), e.size))
        _propagate(
            self._mu, self._g0, self._g1, self._hb, self._ih, self._cz, self._d, self._z, self._e_last, e, y
        )
        return y


@numba.njit(cache=True)
def _propagate(mu, g0, g1, hb, ih, cz, d, z, e_last, e, y):  # pragma: no cover - compiled
    """Per step k: z <- mu z + g0 e[k-1] + g1 e[k]; y[:, k] = Re(cz @ mean z) + d (e[k-1] + e[k]) / 2
    with mean z = (z_new - z_old - hb (e[k-1] + e[k])) * ih (z, e_last in place)."""
    n_out, n_z = cz.shape
    czr, czi = cz.real.copy(), cz.imag.copy()
    zr, zi = z.real.copy(), z.imag.copy()
    mr, mi = np.empty(n_z), np.empty(n_z)
    mur, mui = mu.real, mu.imag
    e0 = e_last[0]
    for k in range(e.size):
        e1 = e[k]
        es = e0 + e1
        for j in range(n_z):
            br = g0[j].real * e0 + g1[j].real * e1
            bi = g0[j].imag * e0 + g1[j].imag * e1
            r = mur[j] * zr[j] - mui[j] * zi[j] + br
            i = mur[j] * zi[j] + mui[j] * zr[j] + bi
            dr = r - zr[j] - hb[j].real * es
            di = i - zi[j] - hb[j].imag * es
            mr[j] = dr * ih[j].real - di * ih[j].imag
            mi[j] = dr * ih[j].imag + di * ih[j].real
            zr[j] = r
            zi[j] = i
        for o in range(n_out):
            acc = 0.5 * d[o] * es
            for j in range(n_z):
                acc += czr[o, j] * mr[j] - czi[o, j] * mi[j]
            y[o, k] = acc
        e0 = e1
    e_last[0] = e0
    for j in range(n_z):
        z[j] = zr[j] + 1j * zi[j]


class VibroImpactPhysics:
    """The vibro-impact stepper (:class:`rigtools.sim.vibro_impact.VibroImpactStepper`) on the reduced
    test-article model (:func:`rigtools.sim.reduction.reduce_rig_model`: modes plus static correction),
    with the shroud contact and the shaker coupling.

    Parameters
    ----------
    model
        Rig model of the test article.
    shaker
        The shaker coupling (the amplifier gain is applied before :meth:`step`).
    dt
        Time step, s (the sample period); it must resolve the contact period.

    Raises
    ------
    SimulationInputError
        If the step is too coarse for the contact stiffness (one line from the stepper).
    """

    def __init__(self, model: RigModel, shaker: ShakerCoupling, dt: float) -> None:
        self.system = reduce_rig_model(model, keep_bases=True)
        self._model = model
        self._stepper = VibroImpactStepper(self.system, dt, shaker=shaker)
        self._cols = [
            OUT_COLUMNS.index(c)
            for c in (
                "active_tip_velocity",
                "passive_tip_velocity",
                "force_point_velocity",
                "force_point_displacement",
                "contact_force",
                "coil_current",
            )
        ]
        self._shaker = shaker
        self._last = np.zeros(7)  # the end values of the previous step (at rest: zero)
        self.dt = dt
        self._kick = np.zeros(0)
        self._phi_f = np.ascontiguousarray(self._stepper.system.shapes[2])

    @property
    def stepper(self) -> VibroImpactStepper:
        """The stepper (its state is the rig's state)."""
        return self._stepper

    def reset(self) -> None:
        """Back to rest."""
        self._stepper.reset()
        self._last[:] = 0.0

    def set_hit_point(self, blade: str | None, position: float = 0.0) -> None:
        """Where the impulses given to :meth:`step` go in: ``blade`` (``"active"`` or
        ``"passive"``; ``None``: nowhere) at ``position`` (m from the root), normal to it (y).

        An impulse ``I`` over a sample interval goes into the modal velocities at the start of
        that interval: ``dv_j = phi_j(x_h) * I`` with ``phi_j(x_h)`` the Ritz vector ``j`` of
        the reduced model at the hit DOF (the kept normal modes and the static-correction
        shapes of the blade; on the active blade in the basis re-diagonalised with the shaker
        armature, :meth:`rigtools.sim.reduction.ReducedSystem.with_attached`). Exact for modes with
        periods much longer than a sample; a hammer's pulse (0.2-1 ms) spans tens of samples.

        Raises
        ------
        SimulationInputError
            One line: the position is not on the blade.
        """
        if blade is None:
            self._kick = np.zeros(0)
            return
        model_blade = self._model.blade(blade)
        length = float(model_blade.node_x[-1])
        if not 0 < position <= length:
            raise SimulationInputError(
                f"hammer position {position * 1e3:g} mm is not on the "
                f"{blade} blade (0 .. {length * 1e3:g} mm from the root)"
            )
        node = model_blade.node_at(position)
        assert self.system.bases is not None  # reduced with keep_bases=True
        phi_h = self.system.bases[blade][model_blade.dof(node, 1)]
        attached = self._stepper.system
        which = np.flatnonzero(attached.blade == (0 if blade == "active" else 1))
        if blade == "active" and self._stepper.shaker is not None:
            # the same re-diagonalisation as ReducedSystem.with_attached
            sh = self._stepper.shaker
            pf = self.system.shapes[2, which]
            m = np.eye(which.size) + sh.armature_mass * np.outer(pf, pf)
            k = np.diag(self.system.omega[which] ** 2) + sh.suspension_stiffness * np.outer(pf, pf)
            _, t = scipy.linalg.eigh(k, m)
            phi_h = phi_h @ t
        self._kick = np.zeros(attached.n_modes)
        self._kick[which] = phi_h

    @property
    def gap(self) -> float:
        """The shroud gap in use, m."""
        return self._stepper._contact[0]

    def set_gap(self, gap: float) -> None:
        """Change the shroud gap between steps (the state carries on), m."""
        _, kc, cc, p, code = self._stepper._contact
        self._stepper._contact = (float(gap), kc, cc, p, code)

    def step(self, coil_voltage: np.ndarray, impulses: np.ndarray | None = None) -> np.ndarray:
        """Advance over ``coil_voltage`` (V, at the end of each step); ``(len(SIGNALS), n)`` out,
        each value the mean of the signal over its step (:func:`interval_means`).

        ``impulses`` (N*s, one per step, or ``None``) go in at the start of their steps at the
        point set by :meth:`set_hit_point`; row ``hammer_force`` reports them as mean forces.
        """
        e = np.ascontiguousarray(coil_voltage, dtype=float)
        data = np.empty((e.size, N_OUT))
        self.advance(e, data, impulses)
        return self.sampled(e, data, impulses)

    def advance(self, e: np.ndarray, data: np.ndarray, impulses: np.ndarray | None = None) -> None:
        """Step over ``e`` (contiguous, V) writing the stepper's outputs into ``data``
        (``(e.size, N_OUT)``, :data:`rigtools.sim.vibro_impact.OUT_COLUMNS`), the impulses put in
        at the start of their intervals."""
        if impulses is None or not impulses.any() or self._kick.size == 0:
            self._stepper.advance(e, data)
            return
        start = 0
        for k in np.flatnonzero(impulses):
            if k > start:
                self._stepper.advance(e[start:k], data[start:k])
            st = self._stepper.state
            dv = self._kick * impulses[k]
            st.v += dv
            if self._stepper.shaker is not None:
                st.scalars[4] += float(self._phi_f @ dv)  # the coil sees the force point's velocity
            start = int(k)
        self._stepper.advance(e[start:], data[start:])

    def sampled(self, e: np.ndarray, data: np.ndarray, impulses: np.ndarray | None = None) -> np.ndarray:
        """The interval means (:data:`SIGNALS` rows) of a block stepped by :meth:`advance` with
        coil voltages ``e``; carries the block's end values to the next call."""
        ends = np.empty((7, e.size + 1))
        ends[:, 0] = self._last
        for row, c in enumerate(self._cols):
            ends[row, 1:] = data[:, c]
        ends[6, 1:] = e
        self._last = ends[:, -1].copy()
        y = interval_means(ends, self.dt, self._shaker)
        if impulses is not None:
            y[_INDEX["hammer_force"]] = impulses / self.dt
        return y


def interval_means(ends: np.ndarray, dt: float, shaker) -> np.ndarray:
    """What an integrating sampler reports: the mean of each signal over each sample interval.

    A delta-sigma DSA input has an anti-alias filter; a point sample of the model would fold the
    broadband content of the contact (the accelerations jump at each impact) down between the
    harmonics. The interval mean (a boxcar of one sample period) has zeros at every multiple of
    the sample rate, exactly where that content would fold from, and a group delay of half a
    sample on every channel alike (reported in
    :meth:`rigtools.drivers.simulated.SimulatedRig.input_to_output_delay`).

    Parameters
    ----------
    ends
        ``(7, n + 1)`` values at the step ends, the previous block's last step first; rows:
        velocities of the active tip, passive tip and force point, force-point displacement,
        contact force, coil current, coil voltage.
    dt
        Step, s.
    shaker
        The shaker (:class:`rigtools.sim.vibro_impact.ShakerCoupling`).

    Returns
    -------
    ``(len(SIGNALS), n)``. Exact means from the end values wherever a signal is the derivative of
    one carried: accelerations ``(v[k] - v[k-1]) / dt``; force-point velocity ``dx / dt``; coil
    current from the mean of ``L di/dt + R i + Bl v = e`` (the voltage is a first-order hold: its
    mean is the trapezoid); sensor force ``Bl i - c_s v - m_a a - k_s x`` from these (``x`` by the
    cubic Hermite rule from its velocity). The contact force by the trapezoid.
    """
    a0, a1 = ends[:, :-1], ends[:, 1:]
    d = (a1 - a0) / dt
    trap = 0.5 * (a0 + a1)
    s = shaker
    y = np.empty((len(SIGNALS), a0.shape[1]))
    y[_INDEX["active_tip_accel"]] = d[0]
    y[_INDEX["passive_tip_accel"]] = d[1]
    y[_INDEX["force_point_accel"]] = d[2]
    x_mean = trap[3] - d[2] * (dt * dt / 12.0)
    e_mean = trap[6]
    i_mean = (e_mean - s.force_factor * d[3] - s.coil_inductance * d[5]) / s.coil_resistance
    y[_INDEX["force"]] = (
        s.force_factor * i_mean
        - s.suspension_damping * d[3]
        - s.armature_mass * d[2]
        - s.suspension_stiffness * x_mean
    )
    y[_INDEX["contact_force"]] = trap[4]
    y[_INDEX["coil_current"]] = i_mean
    y[_INDEX["coil_voltage"]] = e_mean
    y[_INDEX["hammer_force"]] = 0.0  # the hammer is not part of the shaker's physics
    return y
