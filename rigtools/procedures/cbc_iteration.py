"""Control-based continuation in the harmonic domain: the arithmetic, without hardware.

Everything here works on complex harmonic amplitudes ``Z[k-1]`` (k = 1..H) of a signal
``z(t) = Re(sum_k Z_k exp(i k w t))`` with ``w = 2 pi fe`` and ``t`` the stream time (the
device's sample index over its rate), so that a response, its target and the drive share one
phase reference.

The feedback (:func:`control_drive`) is the harmonic-domain form of a PD law on the response
``x`` (the active shroud's displacement) with a multi-harmonic target ``x*``::

    u(t) = u_ff(t) + Kp (x*(t) - x(t)) + Kd (x*'(t) - x'(t))
    U_k  = Uff_k + (Kp + i k w Kd) (X*_k - X_k)

The control is non-invasive when ``u = u_ff`` and ``u_ff`` is a pure sine: the feedforward
carries only the fundamental, so the drive's harmonics 2..H vanish exactly when the target's
harmonics 2..H equal the response's. The outer iteration (:func:`picard_update`) makes them
equal -- the target's higher harmonics take the measured ones (a fixed-point, or Picard,
iteration, Barton & Sieber 2013) -- and moves the feedforward's fundamental to the drive's, so
that the control term of the fundamental vanishes too and the response's fundamental meets its
target. The measure of non-invasiveness is on the drive VOLTAGE (:func:`drive_harmonics_ratio`):
the force carries the impacts' harmonics whatever the control does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Harmonics of the drive held against its fundamental (2..10), as ``--json`` reports them.
RATIO_HARMONICS = 10


@dataclass(frozen=True)
class EnvelopeGains:
    """The delay-aware law on the fundamental's complex amplitude, played once per block (the
    buffered loop). In the orbit's own frame -- the error turned by the target's phase, the
    correction by the feedforward's, so that the law does not depend on where the stream's phase
    started -- with ``e`` the error ``X1 - X1*`` and ``d`` the change of ``X1`` since the previous
    block as real 2-vectors (in phase, in quadrature) of the one-period estimate::

        U1 = Uff1 + exp(i arg Uff1) (-K e - D d),   e = (X1 - X1*) exp(-i arg X1*)

    ``K``, ``D`` real 2x2 (V/m, row-major tuples): a real matrix acts on amplitude and phase
    separately (the orbit's slow flow is not complex-linear) and ``D`` is the phase lead the
    output queue's two blocks of delay need; the gains come from
    :func:`rigtools.procedures.cbc_delay.design_envelope_gains`.
    """

    k: tuple[float, float, float, float]
    d: tuple[float, float, float, float]

    def correction(self, error: complex, change: complex, target: complex, feedforward: complex) -> complex:
        """``U1 - Uff1``, V, for the error and change of ``X1`` (m) at ``target`` and ``feedforward``."""
        turn = np.exp(-1j * np.angle(target)) if target != 0 else 1.0
        e, dx = error * turn, change * turn
        v = -np.reshape(self.k, (2, 2)) @ [e.real, e.imag] - np.reshape(self.d, (2, 2)) @ [dx.real, dx.imag]
        back = np.exp(1j * np.angle(feedforward)) if feedforward != 0 else 1.0
        return complex(complex(float(v[0]), float(v[1])) * back)


#: The simulated rig's delay-aware gains at 64 Hz, gap 0.5 mm (``benchmarks/cbc_delay_design.py``,
#: :mod:`rigtools.procedures.cbc_delay`): models identified at A 0.315, 0.340 and 0.350 mm, the
#: last moved to growths of 10 and 13 1/s, each with its drive gain x0.8/x1.25 and turned +-10 deg;
#: the largest closed-loop spectral radius over those 25 models is 0.969 per 20 ms block (the
#: design starts from the gains before it: a rerun refines these).
DELAY_GAINS = EnvelopeGains(
    k=(1043.04, 977.74, 220.83, -384.93),
    d=(-934.25, 528.47, 405.17, 458.74),
)


@dataclass(frozen=True)
class Gains:
    """PD gains of the feedback on the response (SI).

    Attributes
    ----------
    kp
        Proportional gain, V per m of displacement error.
    kd
        Derivative gain, V s per m (V per m/s of velocity error).
    harmonics
        Harmonics 1..``harmonics`` of the error are fed back (the buffered loop works on
        harmonic amplitudes and may leave the higher ones out; a per-sample loop feeds back all).
    envelope
        The buffered loop's delay-aware law on the fundamental (:class:`EnvelopeGains`), in
        place of ``Kp + i w Kd`` there; a per-sample loop ignores it.
    """

    kp: float
    kd: float = 0.0
    harmonics: int = 1
    envelope: EnvelopeGains | None = None  # the buffered loop's law on the fundamental, if set

    @property
    def zero(self) -> bool:
        return self.kp == 0.0 and self.kd == 0.0 and self.envelope is None

    def law(self, fe: float, n: int) -> np.ndarray:
        """Complex gains ``Kp + i k w Kd`` of harmonics k = 1..n (zero above :attr:`harmonics`)."""
        k = np.arange(1, n + 1)
        g = self.kp + 1j * k * 2 * math.pi * fe * self.kd
        return np.where(k <= self.harmonics, g, 0.0)

    @classmethod
    def from_loop_gain(cls, loop_gain: complex, plant: complex, fe: float, harmonics: int = 1) -> Gains:
        """The PD gains whose fundamental gain ``K`` makes ``K G = loop_gain`` for the measured
        plant ``G = X1 / U1`` (m/V): ``Kp = Re K``, ``Kd = Im K / w``."""
        if plant == 0 or not np.isfinite(plant):
            raise ValueError(f"plant gain {plant!r} must be finite and non-zero")
        k = complex(loop_gain) / complex(plant)
        return cls(float(k.real), float(k.imag / (2 * math.pi * fe)), harmonics)


def control_drive(
    feedforward: np.ndarray, target: np.ndarray, response: np.ndarray, gains: Gains, fe: float
) -> np.ndarray:
    """The drive's harmonics ``U_k = Uff_k + (Kp + i k w Kd)(X*_k - X_k)`` (V; arrays over k = 1..H)."""
    ff, tgt, x = (np.asarray(a, dtype=complex) for a in (feedforward, target, response))
    return ff + gains.law(fe, ff.size) * (tgt - x)


def drive_harmonics_ratio(drive: np.ndarray, k_max: int = RATIO_HARMONICS) -> float:
    """RMS of the drive's harmonics 2..k_max over the RMS of its fundamental:
    ``sqrt(sum_k |U_k|^2) / |U_1|`` (0 for a pure sine; ``inf`` without a fundamental)."""
    u = np.abs(np.asarray(drive, dtype=complex))
    if u.size == 0 or u[0] == 0:
        return math.inf
    return float(math.sqrt(float(np.sum(u[1:k_max] ** 2))) / u[0])


def displacement_from_acceleration(accel: np.ndarray, fe: float) -> np.ndarray:
    """Harmonics of displacement from those of acceleration: ``X_k = -A_k / (k w)^2``."""
    a = np.asarray(accel, dtype=complex)
    k = np.arange(1, a.size + 1)
    return -a / (k * 2 * math.pi * fe) ** 2


def half_peak_to_peak(harmonics: np.ndarray, samples: int = 2048) -> float:
    """Half the peak-to-peak of the periodic signal made of ``harmonics`` (k = 1..H)."""
    z = np.asarray(harmonics, dtype=complex)
    phase = 2 * math.pi * np.arange(samples) / samples
    x = np.real(np.exp(1j * np.outer(phase, np.arange(1, z.size + 1))) @ z)
    return float((x.max() - x.min()) / 2)


def picard_update(
    target: np.ndarray, feedforward: np.ndarray, response: np.ndarray, drive: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """One outer iteration: ``(target, feedforward)`` for the next hold.

    The target keeps its fundamental (the continuation parameter) and takes the response's
    harmonics 2..H; the feedforward becomes the drive's fundamental (a pure sine). At a fixed
    point the control term is zero in every harmonic: the drive is the feedforward.
    """
    tgt = np.array(target, dtype=complex)
    tgt[1:] = np.asarray(response, dtype=complex)[1:]
    ff = np.zeros_like(tgt)
    ff[0] = complex(np.asarray(drive, dtype=complex)[0])
    return tgt, ff


#: An outer iterate whose amplitude error is above this many times the best one's so far (and
#: above the tolerance) has diverged: the next one goes back towards the best (:func:`backtrack`)
ERROR_GROWTH = 2.0


def backtrack(
    best: tuple[np.ndarray, np.ndarray], tried: tuple[np.ndarray, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """``(target, feedforward)`` half way from the best iterate's back to those of an iterate
    that diverged (:data:`ERROR_GROWTH`): a backtracking line search on the outer iteration's
    step; the target's fundamental (the continuation parameter) is the best's."""
    target = 0.5 * (np.asarray(best[0], complex) + np.asarray(tried[0], complex))
    ff = 0.5 * (np.asarray(best[1], complex) + np.asarray(tried[1], complex))
    target[0] = best[0][0]
    return target, ff


def secant_predict(amplitudes: list[float], states: list[np.ndarray], amplitude: float) -> np.ndarray:
    """The predictor along the curve: the state (feedforward, target harmonics, ... as one vector)
    at ``amplitude`` extrapolated through the last two converged points (the last one alone: kept;
    none: zeros must be given by the caller)."""
    if not states:
        raise ValueError("no converged point to predict from")
    if len(states) == 1 or amplitudes[-1] == amplitudes[-2]:
        return np.array(states[-1], copy=True)
    s = (amplitude - amplitudes[-1]) / (amplitudes[-1] - amplitudes[-2])
    return np.asarray(states[-1]) + s * (np.asarray(states[-1]) - np.asarray(states[-2]))


def growth_rate(times: np.ndarray, deviation: np.ndarray, low: float, high: float) -> tuple[float, int]:
    """Exponential growth rate (1/s) of ``deviation(t)``: the least-squares slope of
    ``log(deviation)`` over the samples between ``low`` and ``high`` (the stretch where the
    departure from the orbit is above the noise and still linear); ``(rate, samples used)``;
    ``nan`` when fewer than three samples lie there."""
    t, d = np.asarray(times, float), np.asarray(deviation, float)
    first = np.flatnonzero(d >= low)
    if first.size == 0:
        return math.nan, 0
    start = int(first[0])
    over = np.flatnonzero(d[start:] > high)
    stop = start + int(over[0]) if over.size else d.size
    if stop - start < 3:
        return math.nan, stop - start
    slope = np.polyfit(t[start:stop], np.log(d[start:stop]), 1)[0]
    return float(slope), stop - start


def _real(z: complex) -> np.ndarray:
    return np.array([z.real, z.imag])


def _matrix(z: complex) -> np.ndarray:
    """The 2x2 real matrix of multiplication by ``z``."""
    return np.array([[z.real, -z.imag], [z.imag, z.real]])


class FeedforwardSecant:
    """Newton-like iteration on the feedforward's fundamental ``Uff_1`` so that the response's
    fundamental meets its target (the control term of the fundamental then vanishes): a Broyden
    update of the 2x2 real Jacobian ``d X_1 / d Uff_1``, started from the closed loop's ``1 / K``
    (the Picard step ``Uff_1 <- U_1``) or from the previous point's converged Jacobian.

    A Picard step alone fails where the open-loop curve U(A) falls with A (the drive needed drops
    as the amplitude grows, the stable side of the F1 minimum): there it moves the wrong way
    unless the gain dominates; the secant learns the slope from the steps it took.
    """

    def __init__(self, jacobian: np.ndarray, max_step: float = 0.02) -> None:
        self.jacobian = np.array(jacobian, dtype=float)
        self.max_step = max_step  # largest step, a fraction of |Uff_1| (the other orbits are near)
        self._last: tuple[np.ndarray, np.ndarray] | None = None

    @classmethod
    def from_probes(cls, x0: complex, x_re: complex, x_im: complex, delta: float) -> FeedforwardSecant:
        """The Jacobian by finite differences: responses to the feedforward, to it plus ``delta``
        (V) and to it plus ``i delta``."""
        return cls(np.column_stack([_real(x_re - x0), _real(x_im - x0)]) / delta)

    @classmethod
    def from_gain(cls, gain: complex) -> FeedforwardSecant:
        """Start from ``d X_1 / d Uff_1 = 1 / K`` (the Picard step's assumption)."""
        return cls(_matrix(1.0 / complex(gain)) if gain != 0 else np.eye(2) * 1e-3)

    def step(self, feedforward: complex, response: complex, target: complex) -> complex:
        """The next ``Uff_1`` from the present one and the response it gave."""
        u, x = _real(feedforward), _real(response)
        if self._last is not None:
            du, dx = u - self._last[0], x - self._last[1]
            if float(du @ du) > 0:
                self.jacobian += np.outer(dx - self.jacobian @ du, du) / float(du @ du)
        self._last = (u, x)
        try:
            du_new = np.linalg.solve(self.jacobian, _real(target) - x)
        except np.linalg.LinAlgError:
            return feedforward
        limit = self.max_step * float(np.hypot(*u))
        size = float(np.hypot(*du_new))
        if size > limit > 0:
            du_new *= limit / size
        return complex(*(u + du_new))
