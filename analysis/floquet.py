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

Several short transients of the same orbit (a controller released and re-engaged a few times,
each release kept short enough that it catches the orbit again) are pooled by
:func:`pooled_floquet_multipliers`: their pairs fitted together, none straddling two of them.

Barton (2017) fits a periodic ARX model to closed-loop data instead, which also gives the
open-loop multipliers while a controller holds the orbit; this fit needs the loop released (or a
stable orbit probed), as on a rig with a real-time loop that can be switched off for a few periods.

References: D. A. W. Barton, "Control-based continuation: bifurcation and stability analysis for
physical experiments", Mech. Syst. Signal Process. 84 (2017) 54-64; P. J. Schmid, "Dynamic mode
decomposition of numerical and experimental data", J. Fluid Mech. 656 (2010) 5-28.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "MeasuredMultipliers",
    "TransientPiece",
    "floquet_multipliers",
    "periodic_reference",
    "pooled_floquet_multipliers",
]


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
    harmonics: int | None = None,
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
    harmonics
        Instead of ``delays`` instants, each period's vector holds the mean and harmonics
        1..``harmonics`` of ``fe`` of the deviation over that period (least squares over its
        samples): a smooth embedding that leaves out what an impact's shifted instant puts in
        a few samples (not linear in the deviation beyond the smallest ones).

    Returns
    -------
    MeasuredMultipliers

    Raises
    ------
    ValueError
        One line: fewer than three periods to fit, or no deviation.
    """
    piece = TransientPiece(deviation, first_period, last_period)
    return pooled_floquet_multipliers(
        [piece], fs, fe, delays=delays, rank=rank, floor=floor, limit=limit, harmonics=harmonics
    )


@dataclass(frozen=True)
class TransientPiece:
    """One transient of a pooled fit (:func:`pooled_floquet_multipliers`): ``deviation``
    ``(channels, n)`` or ``(n,)`` from the orbit, and the periods of it fitted (``last_period``
    ``None``: to the last whole one)."""

    deviation: np.ndarray
    first_period: int = 0
    last_period: int | None = None


def pooled_floquet_multipliers(
    pieces: Sequence[TransientPiece],
    fs: float,
    fe: float,
    *,
    delays: int = 8,
    rank: int | None = None,
    floor: float = 1e-3,
    limit: float | None = None,
    harmonics: int | None = None,
) -> MeasuredMultipliers:
    """Floquet multipliers of one orbit from several transients (each its own perturbation of
    the same orbit, e.g. successive short releases of a controller): the one-period map fitted
    to the pairs ``(z[p], z[p + 1])`` of every piece together (pairs never straddle two pieces).
    Parameters as :func:`floquet_multipliers`; ``limit`` ends each piece's fit separately; the
    ``periods`` of the result count the pairs fitted as ``(0, pairs)``, or the one piece's
    periods.

    Raises
    ------
    ValueError
        One line: fewer than two pairs to fit in all (a piece with fewer than two periods in
        range adds none), or no deviation.
    """
    samples_per_period = fs / fe
    spans: list[tuple[np.ndarray, int, int]] = []
    for piece in pieces:
        d = np.atleast_2d(np.asarray(piece.deviation, dtype=float))
        whole = math.floor((d.shape[1] - 1) / samples_per_period)
        first = piece.first_period
        last = whole - 1 if piece.last_period is None else min(piece.last_period, whole - 1)
        if limit is not None:
            p = math.ceil(samples_per_period)
            for period in range(first, last + 1):
                lo = int(period * samples_per_period)
                if np.max(np.abs(d[:, lo : lo + p])) > limit:
                    last = period - 1
                    break
        spans.append((d, first, last))
    usable = [span for span in spans if span[2] > span[1]]
    pairs = sum(last - first for _, first, last in usable)
    if pairs < 2:
        if len(spans) == 1:
            first, last = spans[0][1], spans[0][2]
            raise ValueError(f"{last - first + 1} periods to fit (periods {first}..{last}): give at least 3")
        raise ValueError(f"{pairs} pairs of periods to fit in {len(spans)} pieces: give at least 2")
    # each channel scaled to unit rms (over all pieces) so that no unit dominates the fit
    scale = np.sqrt(np.mean(np.concatenate([d for d, _, _ in usable], axis=1) ** 2, axis=1))
    if not np.any(scale > 0):
        raise ValueError("the deviation is zero: no transient to fit")
    z0s, z1s = [], []
    for d, first, last in usable:
        d = d[scale > 0] / scale[scale > 0, None]
        if harmonics is None:
            z = _snapshots(d, samples_per_period, first, last, delays)
        else:
            z = _period_harmonics(d, samples_per_period, first, last, harmonics)
        z0s.append(z[:, :-1])
        z1s.append(z[:, 1:])
    z0, z1 = np.concatenate(z0s, axis=1), np.concatenate(z1s, axis=1)
    u, s, vh = np.linalg.svd(z0, full_matrices=False)
    rel = s / s[0]
    r = rank if rank is not None else int(np.count_nonzero(rel > floor))
    r = max(1, min(r, z0.shape[1] // 2, s.size))
    a = u[:, :r].conj().T @ z1 @ vh[:r].conj().T / s[:r]
    mult = np.linalg.eigvals(a)
    mult = mult[np.argsort(-np.abs(mult))]
    predicted = u[:, :r] @ a @ (u[:, :r].conj().T @ z0)
    residual = float(np.linalg.norm(z1 - predicted) / np.linalg.norm(z1))
    periods = (int(spans[0][1]), int(spans[0][2])) if len(pieces) == 1 else (0, int(z0.shape[1]))
    return MeasuredMultipliers(mult, rel, periods, residual)


def _snapshots(d: np.ndarray, samples_per_period: float, first: int, last: int, delays: int) -> np.ndarray:
    """``(channels * delays, periods)``: each period's vector of ``d`` at ``delays`` instants."""
    k = np.arange(d.shape[1])
    periods = np.arange(first, last + 1)
    instants = (periods[:, None] + np.arange(delays)[None, :] / delays) * samples_per_period
    return np.stack([np.interp(instants, k, row) for row in d], axis=1).reshape(periods.size, -1).T


def _period_harmonics(
    d: np.ndarray, samples_per_period: float, first: int, last: int, harmonics: int
) -> np.ndarray:
    """``(channels * (2 harmonics + 1), periods)``: each period's mean and harmonics 1..``harmonics``
    (cosine, sine) of every channel, least squares over the samples of that period."""
    cols = []
    for period in range(first, last + 1):
        lo, hi = math.ceil(period * samples_per_period), math.ceil((period + 1) * samples_per_period)
        phase = 2 * math.pi * (np.arange(lo, hi) / samples_per_period - period)
        k = np.arange(1, harmonics + 1)
        basis = np.column_stack([np.ones(hi - lo), np.cos(np.outer(phase, k)), np.sin(np.outer(phase, k))])
        cols.append(np.linalg.lstsq(basis, d[:, lo:hi].T, rcond=None)[0].T.reshape(-1))
    return np.array(cols).T
