"""Floquet multipliers of a measured periodic orbit, from the transient after a small probe.

The method is a least-squares fit of the Poincare map (the linear map over one forcing period)
to deviations from the orbit sampled once per period: as a dynamic-mode decomposition of the
stroboscopic samples. It needs no model and no input signal: after a small perturbation (a probe
of the drive or of a control target, or releasing a controller that held the orbit) the rig
runs open loop at the orbit's drive and its deviation from the orbit evolves, period to
period, by the monodromy matrix ``M``: ``z[p + 1] = M z[p]`` to first order.

1. ``d(t) = x(t) - x_orbit(t)`` on every channel (:func:`periodic_reference` fits the orbit as
   a Fourier series of ``fe`` over a stretch where the rig sat on it);
2. each period ``p`` gives one vector ``z[p]``: ``d`` of every channel at ``delays`` instants
   spread over the period (a delay embedding: with 8 instants one displacement channel already
   spans the slow modes' state);
3. the pairs ``(z[p], z[p + 1])`` over the periods where the deviation is above the noise and
   within the linear range give ``M`` restricted to the subspace the deviations span (its
   ``rank`` leading singular vectors): the exact-DMD estimate ``A = U* Z1 V S^-1``; its
   eigenvalues are the multipliers the transient shows: the slowest (largest) ones, those the
   stability of the orbit depends on. Multipliers whose modes decay within a period leave no
   trace and are not estimated.

Barton (2017) fits a periodic ARX model to closed-loop data instead, which also gives the
open-loop multipliers while a controller holds the orbit; this fit needs the loop released (or a
stable orbit probed), as on a rig with a real-time loop that can be switched off for a few periods.

References: D. A. W. Barton, "Control-based continuation: bifurcation and stability analysis for
physical experiments", Mech. Syst. Signal Process. 84 (2017) 54-64; P. J. Schmid, "Dynamic mode
decomposition of numerical and experimental data", J. Fluid Mech. 656 (2010) 5-28.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["MeasuredMultipliers", "floquet_multipliers", "periodic_reference"]


@dataclass(frozen=True)
class MeasuredMultipliers:
    """Multipliers estimated from a transient.

    Attributes
    ----------
    multipliers
        The estimated Floquet multipliers, by decreasing modulus.
    singular_values
        Of the stroboscopic deviations (relative to the largest): how many directions the
        transient excited above the rest.
    periods
        The periods the fit used (first, last).
    residual
        Relative least-squares residual of the one-period map over those periods.
    """

    multipliers: np.ndarray
    singular_values: np.ndarray
    periods: tuple[int, int]
    residual: float

    @property
    def max_modulus(self) -> float:
        """The largest modulus: above 1 the orbit is unstable."""
        return float(np.max(np.abs(self.multipliers))) if self.multipliers.size else 0.0


def periodic_reference(
    x: np.ndarray, fs: float, fe: float, start: int, stop: int, harmonics: int = 40
) -> np.ndarray:
    """The periodic orbit of ``x`` from the samples ``start:stop`` where the rig sat on it,
    evaluated at every sample.

    With a whole number of samples per period (``fs / fe`` an integer) it is the average of the
    whole periods in ``start:stop``, exact for every harmonic (an impacting orbit's
    accelerations have harmonics up to the sampler's band); otherwise the Fourier series of
    ``fe`` with ``harmonics`` harmonics fitted by least squares per channel.

    Parameters
    ----------
    x
        ``(channels, n)`` or ``(n,)`` samples at ``fs`` (S/s).
    fs, fe
        Sample rate and forcing frequency, Hz.
    start, stop
        The stretch where the rig sat on the orbit (at least one whole period).
    harmonics
        Harmonics of ``fe`` kept by the Fourier fit (below the Nyquist frequency).

    Returns
    -------
    np.ndarray
        The orbit at every sample, shaped as ``x``.
    """
    x = np.asarray(x, dtype=float)
    flat = x.reshape(-1, x.shape[-1])
    n = flat.shape[1]
    ratio = fs / fe
    p = round(ratio)
    if abs(ratio - p) < 1e-9 * ratio and stop - start >= p:
        whole = (stop - start) // p
        one = flat[:, start : start + whole * p].reshape(flat.shape[0], whole, p).mean(axis=1)
        phase = (np.arange(n) - start) % p
        return one[:, phase].reshape(x.shape)
    harmonics = min(harmonics, int((0.5 * fs) // fe))
    w = 2 * math.pi * fe * np.arange(1, harmonics + 1)

    def basis(k: np.ndarray) -> np.ndarray:
        ph = np.multiply.outer(k / fs, w)
        return np.column_stack([np.ones(k.size), np.cos(ph), np.sin(ph)])

    coef = np.linalg.lstsq(basis(np.arange(start, stop)), flat[:, start:stop].T, rcond=None)[0]
    return (basis(np.arange(n)) @ coef).T.reshape(x.shape)


def floquet_multipliers(
    deviation: np.ndarray,
    fs: float,
    fe: float,
    *,
    first_period: int = 0,
    last_period: int | None = None,
    delays: int = 8,
    rank: int | None = None,
    floor: float = 1e-3,
    limit: float | None = None,
) -> MeasuredMultipliers:
    """Floquet multipliers from deviations from a periodic orbit (see the module).

    Parameters
    ----------
    deviation
        ``(channels, n)`` or ``(n,)``: the measured signals minus the orbit
        (:func:`periodic_reference`), sample 0 at any phase, at ``fs``.
    fs, fe
        Sample rate and forcing frequency, Hz (any ratio: the instants are interpolated).
    first_period, last_period
        The periods fitted (default: from the first to the last whole one); choose them where
        the deviation is above the noise and small enough to be linear.
    delays
        Instants per period and channel.
    rank
        Directions kept (default: singular values above ``floor`` times the largest, at most
        half the periods fitted).
    floor
        See ``rank``.
    limit
        The fit ends before the first period whose largest deviation (any channel, in its
        units) exceeds it: the end of the linear range of a transient that grows.

    Returns
    -------
    MeasuredMultipliers

    Raises
    ------
    ValueError
        One line: fewer than three periods to fit, or no deviation.
    """
    d = np.atleast_2d(np.asarray(deviation, dtype=float))
    samples_per_period = fs / fe
    whole = math.floor((d.shape[1] - 1) / samples_per_period)
    last = whole - 1 if last_period is None else min(last_period, whole - 1)
    if limit is not None:
        p = math.ceil(samples_per_period)
        for period in range(first_period, last + 1):
            lo = int(period * samples_per_period)
            if np.max(np.abs(d[:, lo : lo + p])) > limit:
                last = period - 1
                break
    if last - first_period < 2:
        raise ValueError(
            f"{last - first_period + 1} periods to fit (periods {first_period}..{last}): give at least 3"
        )
    # each channel scaled to unit rms so that no unit dominates the fit
    scale = np.sqrt(np.mean(d**2, axis=1))
    if not np.any(scale > 0):
        raise ValueError("the deviation is zero: no transient to fit")
    d = d[scale > 0] / scale[scale > 0, None]
    k = np.arange(d.shape[1])
    periods = np.arange(first_period, last + 1)
    instants = (periods[:, None] + np.arange(delays)[None, :] / delays) * samples_per_period
    z = np.stack([np.interp(instants, k, row) for row in d], axis=1).reshape(periods.size, -1).T
    z0, z1 = z[:, :-1], z[:, 1:]
    u, s, vh = np.linalg.svd(z0, full_matrices=False)
    rel = s / s[0]
    r = rank if rank is not None else int(np.count_nonzero(rel > floor))
    r = max(1, min(r, z0.shape[1] // 2, s.size))
    a = u[:, :r].conj().T @ z1 @ vh[:r].conj().T / s[:r]
    mult = np.linalg.eigvals(a)
    mult = mult[np.argsort(-np.abs(mult))]
    predicted = u[:, :r] @ a @ (u[:, :r].conj().T @ z0)
    residual = float(np.linalg.norm(z1 - predicted) / np.linalg.norm(z1))
    return MeasuredMultipliers(mult, rel, (int(first_period), int(last)), residual)
