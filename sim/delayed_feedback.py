"""A per-sample feedback loop with a pure delay, run inside the vibro-impact integration.

The loop is what a real-time target next to the rig does (:mod:`rigtools.drivers.realtime`
describes it as a contract): at each of its ticks ``t_j = j / rate`` it puts out

    u_j = Kp (x*(t_j - D) - x(t_j - D)) + Kd (v*(t_j - D) - v(t_j - D))

held until the next tick (a zero-order-hold converter), added to the amplifier's input. ``x``,
``v`` are the active shroud's displacement and velocity (y), sampled at the instants
``t_j - D`` (``D`` the loop's whole latency: converters plus computation); ``x*``, ``v*`` the
target (:class:`HarmonicTarget`) at the same instants. Target and measurement are compared at
the instant the measurement stands for, so on a true orbit of the rig with the target equal to
it the control is zero (non-invasive), and a change of target reaches the amplifier ``D``
later, as a change of the measurement does.

Exact per-sample feedback without a per-sample call: because ``D`` is at least one integration
step, every tick whose output reaches the amplifier before ``t + D`` depends only on the state
up to ``t``. :meth:`DelayedFeedback.step` therefore advances the compiled stepper in chunks of
up to ``D``, computing each chunk's control from the history first (Hermite interpolation of
``x`` and ``v`` between the step ends, third order in the step), with no change to the kernel.
A second of simulated time is about a thousand chunks: 0.4 s of wall time at 51.2 kS/s
with a 40-harmonic target, against 0.06 s without the loop (``benchmarks/bench_realtime_loop.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import butter, lfilter, lfilter_zi

from rigtools.sim.params import SimulationInputError
from rigtools.sim.rig_physics import VibroImpactPhysics
from rigtools.sim.vibro_impact import N_OUT, OUT_COLUMNS

_X = OUT_COLUMNS.index("active_tip_displacement")
_V = OUT_COLUMNS.index("active_tip_velocity")
_EPS = 1e-9  # of a tick or a step: float round-off in the tick arithmetic, never a real offset
_T_EPS = 1e-12  # s: the same for a target's start time


@dataclass(frozen=True)
class HarmonicTarget:
    """A periodic target ``x*(t) = mean + sum_h (cos[h-1] cos(h w t) + sin[h-1] sin(h w t))``,
    ``w = 2 pi fe_hz``, ``h = 1..H`` (m; ``t`` in s on the clock of the loop).

    Examples
    --------
    >>> target = HarmonicTarget(64.0, cos=(0.0,), sin=(3e-4,))
    >>> x, v = target.evaluate(np.array([1 / 256]))  # a quarter period
    >>> round(float(x[0]) * 1e3, 6), round(float(v[0]), 9)
    (0.3, 0.0)
    """

    fe_hz: float
    cos: tuple[float, ...] = ()
    sin: tuple[float, ...] = ()
    mean: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.fe_hz) and self.fe_hz > 0):
            raise SimulationInputError(f"target frequency {self.fe_hz!r} Hz must be > 0")
        object.__setattr__(self, "cos", tuple(float(c) for c in self.cos))
        object.__setattr__(self, "sin", tuple(float(s) for s in self.sin))
        if len(self.cos) != len(self.sin):
            raise SimulationInputError(
                f"target: {len(self.cos)} cosine and {len(self.sin)} sine coefficients; give one of each per harmonic"
            )
        if not all(math.isfinite(c) for c in (*self.cos, *self.sin, self.mean)):
            raise SimulationInputError("target: a coefficient is not finite")

    @property
    def harmonics(self) -> int:
        """How many harmonics of ``fe_hz`` (H)."""
        return len(self.cos)

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(x*(t), v*(t))``, m and m/s, at the times ``t`` (s)."""
        t = np.asarray(t, dtype=float)
        if not self.cos:
            return np.full(t.shape, self.mean), np.zeros(t.shape)
        hw = 2.0 * math.pi * self.fe_hz * np.arange(1, self.harmonics + 1)
        phase = np.multiply.outer(t, hw)
        c, s = np.cos(phase), np.sin(phase)
        a, b = np.array(self.cos), np.array(self.sin)
        return self.mean + c @ a + s @ b, c @ (hw * b) - s @ (hw * a)

    @classmethod
    def fit(cls, t: np.ndarray, x: np.ndarray, fe_hz: float, harmonics: int) -> HarmonicTarget:
        """The target of ``harmonics`` harmonics nearest (least squares) to samples ``x`` (m) at
        times ``t`` (s): e.g. a periodic orbit's displacement over whole periods."""
        t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
        w = 2.0 * math.pi * fe_hz
        h = np.arange(1, harmonics + 1)
        basis = np.column_stack([np.ones_like(t), np.cos(np.outer(t, h * w)), np.sin(np.outer(t, h * w))])
        coef = np.linalg.lstsq(basis, x, rcond=None)[0]
        return cls(fe_hz, tuple(coef[1 : harmonics + 1]), tuple(coef[harmonics + 1 :]), float(coef[0]))


@dataclass
class _Schedule:
    """Targets and the times from which they hold (measurement instants at or after it)."""

    starts: list[float] = field(default_factory=list)
    targets: list[HarmonicTarget | None] = field(default_factory=list)

    def evaluate(self, tm: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(x*, v*, on)`` at measurement instants ``tm``; ``on`` False where no target holds."""
        x, v, on = np.zeros(tm.shape), np.zeros(tm.shape), np.zeros(tm.shape, dtype=bool)
        for i, (start, target) in enumerate(zip(self.starts, self.targets, strict=True)):
            end = self.starts[i + 1] if i + 1 < len(self.starts) else math.inf
            sel = (tm >= start - _T_EPS) & (tm < end - _T_EPS)
            if target is None or not sel.any():
                continue
            x[sel], v[sel] = target.evaluate(tm[sel])
            on[sel] = True
        return x, v, on

    def forget_before(self, t: float) -> None:
        """Drop the targets that ended before ``t``."""
        while len(self.starts) > 1 and self.starts[1] <= t:
            del self.starts[0], self.targets[0]


class DelayedFeedback:
    """Per-sample delayed PD feedback of the active shroud, inside :class:`VibroImpactPhysics`.

    Parameters
    ----------
    rate_hz
        The loop's tick rate, Hz.
    delay_s
        Its latency ``D``, s: from the instant a measurement stands for to the tick whose output
        it makes. At least one integration step.
    kp, kd
        Gains, V/m and V*s/m (volts at the amplifier's input).
    input_gain
        Coil volts per volt of control (the amplifier's gain).
    dt
        The integration step, s.
    lowpass_hz
        ``None``: the PD law as stated. Else its output, tick by tick, through a second-order
        Butterworth low-pass at this corner (a biquad by the bilinear transform at the tick rate,
        as a real-time target runs it): the impacts' broadband content is not fed back
        (:func:`loop_gain` gives the law's gain with it).

    Raises
    ------
    SimulationInputError
        One line: a rate, delay or gain out of range.
    """

    def __init__(
        self,
        rate_hz: float,
        delay_s: float,
        kp: float,
        kd: float,
        input_gain: float,
        dt: float,
        lowpass_hz: float | None = None,
    ) -> None:
        if not (math.isfinite(rate_hz) and rate_hz > 0):
            raise SimulationInputError(f"loop rate {rate_hz!r} Hz must be > 0")
        if not (math.isfinite(delay_s) and delay_s >= dt * (1.0 - _EPS)):
            raise SimulationInputError(
                f"loop delay {delay_s!r} s must be at least one integration step ({dt * 1e6:.3g} us)"
            )
        if not (math.isfinite(kp) and math.isfinite(kd)):
            raise SimulationInputError(f"loop gains must be finite, got kp={kp!r}, kd={kd!r}")
        self.rate_hz, self.delay_s, self.kp, self.kd = float(rate_hz), float(delay_s), float(kp), float(kd)
        self.input_gain, self.dt = float(input_gain), float(dt)
        # the step ends the next chunk's ticks can reach back to: D plus one tick
        self._keep = math.ceil((self.delay_s + 1.0 / self.rate_hz) / self.dt) + 4
        self._schedule = _Schedule()
        self.lowpass_hz: float | None = None
        self._biquad: tuple[np.ndarray, np.ndarray] | None = None
        self._zi: np.ndarray | None = None
        self.set_lowpass(lowpass_hz)
        self.reset()

    def set_lowpass(self, lowpass_hz: float | None) -> None:
        """The output low-pass's corner, Hz (``None``: none) from the next tick; switched on, its
        state starts at rest at the law's next output (no step from the switch)."""
        if lowpass_hz is not None and not (0 < lowpass_hz < 0.5 * self.rate_hz):
            raise SimulationInputError(
                f"loop low-pass {lowpass_hz!r} Hz must lie between 0 and half the loop rate"
            )
        if lowpass_hz != self.lowpass_hz:
            self._biquad = None if lowpass_hz is None else _butterworth2(lowpass_hz, self.rate_hz)
            self._zi = None
        self.lowpass_hz = lowpass_hz

    def reset(self) -> None:
        """At rest at t = 0, no target (the loop's output 0)."""
        self._zi = None
        self._last_tick = -1
        self._last_out = 0.0
        self._k = 0  # step ends known: 0 .. _k
        self._h0 = 0  # step index of the history's first entry
        self._hx = np.zeros(1)
        self._hv = np.zeros(1)
        self._schedule = _Schedule()

    @property
    def time(self) -> float:
        """The integration's time, s (0 at the last reset)."""
        return self._k * self.dt

    def set_target(self, target: HarmonicTarget | None, from_time: float | None = None) -> None:
        """Follow ``target`` for the measurement instants from ``from_time`` on (default: now,
        :attr:`time`); ``None``: no target from then, the loop's output 0."""
        start = self.time if from_time is None else float(from_time)
        while self._schedule.starts and self._schedule.starts[-1] >= start:
            del self._schedule.starts[-1], self._schedule.targets[-1]
        self._schedule.starts.append(start)
        self._schedule.targets.append(target)

    def _measured(self, tm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``x`` and ``v`` of the active shroud at instants ``tm <= time`` (rest before 0)."""
        dt = self.dt
        m0 = np.clip(np.floor(tm / dt + _EPS).astype(np.int64), self._h0, max(self._k - 1, self._h0))
        s = tm / dt - m0
        i = m0 - self._h0
        x0, x1 = self._hx[i], self._hx[np.minimum(i + 1, self._hx.size - 1)]
        d0, d1 = self._hv[i] * dt, self._hv[np.minimum(i + 1, self._hv.size - 1)] * dt
        s2, s3 = s * s, s * s * s
        x = (2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * d0 + (-2 * s3 + 3 * s2) * x1 + (s3 - s2) * d1
        v = (
            (6 * s2 - 6 * s) * x0 + (3 * s2 - 4 * s + 1) * d0 + (-6 * s2 + 6 * s) * x1 + (3 * s2 - 2 * s) * d1
        ) / dt
        before = tm < 0.0
        return np.where(before, 0.0, x), np.where(before, 0.0, v)

    def control(self, ticks: np.ndarray) -> np.ndarray:
        """The loop's outputs (V) at the ticks ``ticks`` (integers), from the history."""
        tm = ticks / self.rate_hz - self.delay_s
        target_x, target_v, on = self._schedule.evaluate(tm)
        x, v = self._measured(tm)
        return np.where(on, self.kp * (target_x - x) + self.kd * (target_v - v), 0.0)

    def _output(self, ticks: np.ndarray) -> np.ndarray:
        """The outputs at increasing ``ticks``: :meth:`control`, through the low-pass if set
        (stateful: each tick filtered once, in order; a tick asked again returns its value)."""
        if self._biquad is None:
            return self.control(ticks)
        out = np.empty(ticks.size)
        old = ticks <= self._last_tick
        out[old] = self._last_out
        new = ticks[~old]
        if new.size:
            raw = self.control(new)
            b, a = self._biquad
            if self._zi is None:
                self._zi = lfilter_zi(b, a) * raw[0]
            y, self._zi = lfilter(b, a, raw, zi=self._zi)
            out[~old] = y
            self._last_tick, self._last_out = int(new[-1]), float(y[-1])
        return out

    def step(
        self,
        physics: VibroImpactPhysics,
        coil_voltage: np.ndarray,
        impulses: np.ndarray | None = None,
        envelope: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance ``physics`` over ``coil_voltage`` (V at the coil, at the end of each step)
        with the loop's output added.

        Parameters
        ----------
        physics
            The integration (its state is the rig's).
        coil_voltage
            The host's drive at the coil, V, one value per step.
        impulses
            As :meth:`VibroImpactPhysics.step`.
        envelope
            A factor on the loop's output per step (a ramp to zero on a stop), default 1.

        Returns
        -------
        (signals, u, x)
            The interval means of :data:`rigtools.sim.rig_physics.SIGNALS` (``(8, n)``; the coil
            voltage row includes the loop's output), the loop's output at each step end (V at
            the amplifier's input) and the active shroud's displacement there (m).
        """
        drive = np.ascontiguousarray(coil_voltage, dtype=float)
        n = drive.size
        data = np.empty((n, N_OUT))
        e = np.empty(n)
        u = np.empty(n)
        per_step = self.dt * self.rate_hz
        i = 0
        while i < n:
            k = self._k
            # the last tick computable from the state up to k dt, and the last step end it covers
            j_max = math.floor((k * self.dt + self.delay_s) * self.rate_hz + _EPS)
            m_max = min(k + n - i, math.ceil((j_max + 1) / per_step - _EPS) - 1)
            ms = np.arange(k + 1, m_max + 1)
            ticks = np.floor(ms * per_step + _EPS)
            first, inverse = np.unique(ticks, return_inverse=True)
            c = self._output(first)[inverse]
            a, b = i, i + ms.size
            if envelope is not None:
                c = c * envelope[a:b]
            u[a:b] = c
            e[a:b] = drive[a:b] + self.input_gain * c
            physics.advance(e[a:b], data[a:b], None if impulses is None else impulses[a:b])
            self._remember(data[a:b])
            i = b
        self._schedule.forget_before(self._k * self.dt - self.delay_s - 2.0 / self.rate_hz)
        return physics.sampled(e, data, impulses), u, data[:, _X].copy()

    def _remember(self, data: np.ndarray) -> None:
        self._hx = np.concatenate([self._hx, data[:, _X]])[-self._keep :]
        self._hv = np.concatenate([self._hv, data[:, _V]])[-self._keep :]
        self._k += data.shape[0]
        self._h0 = self._k + 1 - self._hx.size


def _butterworth2(corner_hz: float, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    b, a = butter(2, corner_hz, fs=rate_hz)
    return np.asarray(b, float), np.asarray(a, float)


def loop_gain(
    kp: float,
    kd: float,
    delay_s: float,
    rate_hz: float,
    frequency_hz: float,
    lowpass_hz: float | None = None,
) -> complex:
    """The loop's output per unit displacement error on a sinusoid of ``frequency_hz``: the
    complex ``U / E`` of the delayed PD law held by a zero-order hold,

        U / E = (Kp + i w Kd) exp(-i w D) (1 - exp(-i w / rate)) / (i w / rate),

    (V/m; ``E`` the error ``x* - x``, ``w = 2 pi frequency_hz``). Its real part is the stiffness
    the loop adds at that frequency, its imaginary part over ``w`` the damping (V s/m): the
    delay turns part of ``Kp`` into negative damping, about ``-Kp sin(w D)``, which ``Kd`` must
    beat (at 64 Hz, 10 kHz and 1.04 ms: Kp 2000 V/m with Kd 2 V s/m nets -121 V/m, no damping
    left; with Kd 4 V s/m +608 V/m). ``lowpass_hz``: the law's output through the loop's
    second-order Butterworth low-pass (:class:`DelayedFeedback`), its ``H(exp(i w / rate))``.

    Examples
    --------
    >>> g = loop_gain(2000.0, 4.0, 1.04e-3, 10_000.0, 64.0)
    >>> round(g.real), round(g.imag)
    (2493, 608)
    """
    w = 2.0 * math.pi * frequency_hz
    hold = 1.0 if w == 0 else (1.0 - np.exp(-1j * w / rate_hz)) / (1j * w / rate_hz)
    g = (kp + 1j * w * kd) * np.exp(-1j * w * delay_s) * hold
    if lowpass_hz is not None:
        b, a = _butterworth2(lowpass_hz, rate_hz)
        z = np.exp(-1j * w / rate_hz) ** np.arange(3)
        g = g * (b @ z) / (a @ z)
    return complex(g)
