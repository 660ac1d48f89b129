"""Exact Fourier coefficients of the contact force of a settled run (:func:`contact_force_harmonics`)."""

from __future__ import annotations

from typing import Protocol

import numpy as np


class SettledRun(Protocol):
    """What :func:`contact_force_harmonics` reads of a run
    (:class:`rigtools.sim.vibro_impact.VibroImpactRun`)."""

    fe: float
    dt: float
    outputs: dict[str, np.ndarray]


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


def contact_force_harmonics(run: SettledRun, k_max: int = 30) -> np.ndarray:
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
        A :class:`rigtools.sim.vibro_impact.VibroImpactRun` (from
        :func:`rigtools.sim.vibro_impact.run_harmonic`).
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
