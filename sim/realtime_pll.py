"""A phase-locked loop run per sample inside the vibro-impact integration.

What a real-time target next to the rig does for phase-locked-loop testing
(:mod:`rigtools.drivers.realtime_pll` states it as a contract; NLtest's real-time PLL is the
same law): at each of its ticks ``t_j = j / rate`` it

1. samples the force and the active shroud's displacement at ``t_j - D`` (``D`` the whole
   latency: converters plus computation; each sample the mean over an integration step, as the
   converters' filters give);
2. demodulates both with its own oscillator, ``s e^{-i theta_j}``, and low-pass filters the
   products by a moving mean over the last period of the oscillator (fractional length
   ``rate / f_j``: it removes the double frequency and every harmonic of the impacts exactly on
   a periodic response, at half a period of group delay);
3. takes the phase of the displacement's fundamental relative to the force's,
   ``phi = angle(X / F)`` (deg), and the error ``e = wrap(phi - phi*)`` to the target ``phi*``;
4. a PI on the instantaneous frequency, ``f_j = I_j + kp e``, ``I_{j+1} = I_j + ki e / rate``,
   both held in ``[f_min, f_max]`` (the integrator too: no wind-up); integration only while
   the force's window holds at least ``min_force`` N (no phase to measure before);
5. puts out ``u_j = a_j sin(theta_j)`` (V at the amplifier's input, held to the next tick) and
   advances its phase continuously, ``theta_{j+1} = theta_j + 2 pi f_j / rate``.

The host sends commands (:class:`PllCommand`: the phase target with the rate it slews at, the
amplitude with the time it ramps over) between blocks, and reads back the oscillator's phase and
frequency per amplifier sample (:meth:`PllFeedback.oscillator`), from which it measures the
response itself and judges the lock.

Per sample without a per-sample Python call: as :mod:`rigtools.sim.delayed_feedback` does, the
integration advances in chunks of up to ``D`` (every tick whose output reaches the amplifier
before ``t + D`` uses measurements up to ``t`` only); the ticks of a chunk run in one compiled
call (:func:`_pll_ticks`).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numba import njit

from rigtools.sim.params import SimulationInputError
from rigtools.sim.rig_physics import SIGNAL_INDEX, SIGNALS, VibroImpactPhysics
from rigtools.sim.vibro_impact import N_OUT, OUT_COLUMNS

_X = OUT_COLUMNS.index("active_tip_displacement")
_FORCE = SIGNAL_INDEX["force"]
_EPS = 1e-9  # of a tick or a step: float round-off in the tick arithmetic

# the loop's state vector (float64), one name per slot
_THETA, _FREQ, _INTEG, _AMP, _TARGET, _TICKS, _PHASE, _ERROR = range(8)


@dataclass(frozen=True)
class PllCommand:
    """What the host sends the loop (its down-link).

    Parameters
    ----------
    phase_deg
        The target phase of the displacement's fundamental relative to the force's, deg.
    amplitude
        The oscillator's amplitude, V peak at the amplifier's input.
    ramp_s
        Time over which the amplitude moves to ``amplitude`` (linearly), s.
    phase_rate
        Rate at which the target slews to ``phase_deg``, deg/s (``inf``: at once).
    kp, ki
        New PI gains, Hz/deg and Hz/(deg s) (``None``: as they are): a gain schedule.
    """

    phase_deg: float
    amplitude: float
    ramp_s: float = 0.05
    phase_rate: float = math.inf
    kp: float | None = None
    ki: float | None = None

    def __post_init__(self) -> None:
        values = (self.phase_deg, self.amplitude, self.ramp_s)
        if not all(math.isfinite(v) for v in values) or self.amplitude < 0 or self.ramp_s < 0:
            raise SimulationInputError(f"PLL command {self!r}: finite values, amplitude and ramp >= 0")
        if not self.phase_rate > 0:
            raise SimulationInputError(f"PLL command: phase rate {self.phase_rate!r} deg/s must be > 0")
        for gain in (self.kp, self.ki):
            if gain is not None and not (math.isfinite(gain) and gain >= 0):
                raise SimulationInputError(f"PLL command: gains must be finite and >= 0, got {gain!r}")


@njit(cache=True)
def _pll_ticks(force, disp, st, cum, cmd, out):  # pragma: no cover - compiled
    """Run the loop over one tick per measurement (``force``, ``disp``); ``st`` the state
    (``_THETA`` ...), ``cum`` ``(4, R)`` a ring of cumulative sums of the four products, ``cmd``
    ``[target, slew per tick, amplitude, amplitude step per tick, kp, ki, rate, f_min, f_max,
    min_force]``; ``out[:, i]`` = output, theta, frequency, phase of tick ``i``."""
    ring = cum.shape[1]
    target, slew, amp_cmd, amp_step = cmd[0], cmd[1], cmd[2], cmd[3]
    kp, ki, rate, f_min, f_max, min_force = cmd[4], cmd[5], cmd[6], cmd[7], cmd[8], cmd[9]
    for i in range(force.size):
        theta, freq = st[_THETA], st[_FREQ]
        j = int(st[_TICKS])
        c, s = math.cos(theta), math.sin(theta)
        now, before = j % ring, (j - 1) % ring
        cum[0, now] = cum[0, before] + force[i] * c
        cum[1, now] = cum[1, before] + force[i] * s
        cum[2, now] = cum[2, before] + disp[i] * c
        cum[3, now] = cum[3, before] + disp[i] * s
        window = rate / freq
        n0 = int(window)
        frac = window - n0
        if j > n0 + 1:
            a, b = (j - n0) % ring, (j - n0 - 1) % ring
            sums = np.empty(4)
            for r in range(4):
                sums[r] = cum[r, now] - ((1.0 - frac) * cum[r, a] + frac * cum[r, b])
            f1 = complex(sums[0], -sums[1])
            x1 = complex(sums[2], -sums[3])
            if abs(f1) * 2.0 / window > min_force:
                z = x1 / f1
                phase = math.degrees(math.atan2(z.imag, z.real))
                st[_PHASE] = phase
                err = (phase - st[_TARGET] + 180.0) % 360.0 - 180.0
                st[_ERROR] = err
                st[_INTEG] = min(max(st[_INTEG] + ki * err / rate, f_min), f_max)
                freq = min(max(st[_INTEG] + kp * err, f_min), f_max)
        # the commands: the target slews, the amplitude ramps
        gap = target - st[_TARGET]
        st[_TARGET] = target if abs(gap) <= slew else st[_TARGET] + math.copysign(slew, gap)
        da = amp_cmd - st[_AMP]
        st[_AMP] = amp_cmd if abs(da) <= amp_step else st[_AMP] + math.copysign(amp_step, da)
        out[0, i] = st[_AMP] * s
        out[1, i] = theta
        out[2, i] = freq
        out[3, i] = st[_PHASE]
        st[_FREQ] = freq
        st[_THETA] = theta + 2.0 * math.pi * freq / rate
        st[_TICKS] = j + 1


class PllFeedback:
    """The per-sample PLL (see the module) inside :class:`VibroImpactPhysics`; the same
    ``step`` as :class:`rigtools.sim.delayed_feedback.DelayedFeedback`, its output the whole
    drive at the amplifier's input.

    Parameters
    ----------
    rate_hz, delay_s
        Tick rate, Hz, and latency ``D``, s (at least 2.5 integration steps plus a tick).
    kp, ki
        PI gains, Hz/deg and Hz/(deg s).
    f_start, f_min, f_max
        The oscillator's first frequency and its range, Hz.
    min_force
        Force fundamental below which the loop holds its frequency, N.
    input_gain
        Coil volts per volt at the amplifier's input.
    dt
        Integration step, s.
    record_seconds
        How much of the oscillator's record :meth:`oscillator` keeps, s.

    Raises
    ------
    SimulationInputError
        One line: a rate, delay, gain or range out of bounds.
    """

    def __init__(
        self,
        rate_hz: float,
        delay_s: float,
        kp: float,
        ki: float,
        f_start: float,
        f_min: float,
        f_max: float,
        min_force: float,
        input_gain: float,
        dt: float,
        record_seconds: float = 8.0,
    ) -> None:
        if not (math.isfinite(rate_hz) and rate_hz > 0):
            raise SimulationInputError(f"PLL rate {rate_hz!r} Hz must be > 0")
        if not (math.isfinite(delay_s) and delay_s >= 2.5 * dt + 1.0 / rate_hz):
            raise SimulationInputError(
                f"PLL delay {delay_s!r} s must be at least 2.5 integration steps plus a tick"
            )
        if not (0 < f_min <= f_start <= f_max < rate_hz / 4):
            raise SimulationInputError(
                f"PLL frequencies: need 0 < f_min {f_min:g} <= f_start {f_start:g} <= f_max {f_max:g} Hz < rate / 4"
            )
        if not (math.isfinite(kp) and math.isfinite(ki) and kp >= 0 and ki >= 0):
            raise SimulationInputError(f"PLL gains must be finite and >= 0, got kp={kp!r}, ki={ki!r}")
        self.rate_hz, self.delay_s, self.dt = float(rate_hz), float(delay_s), float(dt)
        self.f_start, self.f_min, self.f_max = float(f_start), float(f_min), float(f_max)
        self.kp, self.ki, self.min_force = float(kp), float(ki), float(min_force)
        self.input_gain = float(input_gain)
        self._ring = int(rate_hz / f_min) + 4
        self._keep_record = max(1, int(record_seconds / dt))
        self._keep = math.ceil((self.delay_s + 1.0 / self.rate_hz) / self.dt) + 4
        self.reset()

    def reset(self) -> None:
        """At rest at t = 0: amplitude 0, the oscillator at ``f_start``, target -90 deg."""
        self._k = 0  # steps done
        self._h0 = 0  # step index of the history's first entry
        self._hf = np.zeros(0)  # force, mean over each step
        self._hx = np.zeros(0)  # displacement, mean over each step
        self._x_end = 0.0
        self._state = np.zeros(8)
        self._state[_FREQ] = self._state[_INTEG] = self.f_start
        self._state[_TARGET] = self._state[_PHASE] = -90.0
        self._cum = np.zeros((4, self._ring))
        self._cmd = np.array([-90.0, math.inf, 0.0, 0.0, self.kp, self.ki, self.rate_hz])
        self._cmd = np.concatenate([self._cmd, [self.f_min, self.f_max, self.min_force]])
        self._last = np.zeros(4)  # the last tick's output, theta, frequency, phase
        self._record: deque[np.ndarray] = deque()  # (3, n): theta, frequency, phase per step
        self._recorded = 0

    @property
    def time(self) -> float:
        """The integration's time, s (0 at the last reset)."""
        return self._k * self.dt

    @property
    def state(self) -> dict[str, float]:
        """The loop now: ``frequency`` Hz, ``phase`` and ``target`` deg, ``amplitude`` V."""
        st = self._state
        return {"frequency": st[_FREQ], "phase": st[_PHASE], "target": st[_TARGET], "amplitude": st[_AMP]}

    def set_command(self, command: PllCommand) -> None:
        """Follow ``command`` from the next tick on."""
        per_tick = self.rate_hz
        slew = command.phase_rate / per_tick
        step = abs(command.amplitude - self._state[_AMP]) / max(command.ramp_s * per_tick, 1.0)
        self._cmd[:4] = (command.phase_deg, slew, command.amplitude, step)
        if command.kp is not None:
            self._cmd[4] = command.kp
        if command.ki is not None:
            self._cmd[5] = command.ki

    def set_target(self, target: object, from_time: float | None = None) -> None:
        """The harmonic-target interface of the PD loop: a PLL has none (``None`` only)."""
        if target is not None:
            raise SimulationInputError("the real-time PLL takes a PllCommand, not a harmonic target")

    def _measured(self, tm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Force and displacement at instants ``tm`` (the step means stand for mid-step)."""
        pos = tm / self.dt - 0.5 - self._h0
        i = np.clip(np.floor(pos + _EPS).astype(np.int64), 0, max(self._hf.size - 2, 0))
        w = np.clip(pos - i, 0.0, 1.0)
        if self._hf.size < 2:
            return np.zeros(tm.shape), np.zeros(tm.shape)
        f = (1 - w) * self._hf[i] + w * self._hf[i + 1]
        x = (1 - w) * self._hx[i] + w * self._hx[i + 1]
        before = tm < 0.5 * self.dt
        return np.where(before, 0.0, f), np.where(before, 0.0, x)

    def _ticks(self, ticks: np.ndarray) -> np.ndarray:
        """``(4, n)`` output, theta, frequency, phase at the (consecutive) ``ticks``; new ticks
        are run, a tick already run gives its output again."""
        first, inverse = np.unique(ticks, return_inverse=True)
        out = np.empty((4, first.size))
        done = int(self._state[_TICKS]) - 1
        old = first <= done
        out[:, old] = self._last[:, None]
        new = first[~old]
        if new.size:
            if new[0] != done + 1:
                raise SimulationInputError(f"PLL ticks skipped: {done + 1} to {new[0]}")
            f, x = self._measured(new / self.rate_hz - self.delay_s)
            res = np.empty((4, new.size))
            _pll_ticks(f, x, self._state, self._cum, self._cmd, res)
            out[:, ~old] = res
            self._last = res[:, -1].copy()
        return out[:, inverse]

    def step(
        self,
        physics: VibroImpactPhysics,
        coil_voltage: np.ndarray,
        impulses: np.ndarray | None = None,
        envelope: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance ``physics`` over ``coil_voltage`` (V at the coil, one per step) with the loop's
        output added; as :meth:`rigtools.sim.delayed_feedback.DelayedFeedback.step`.

        Returns
        -------
        (signals, u, x)
            The interval means of :data:`rigtools.sim.rig_physics.SIGNALS` (the coil voltage
            row includes the loop's output), the loop's output at each step (V at the
            amplifier's input) and the active shroud's displacement at each step's end (m).
        """
        drive = np.ascontiguousarray(coil_voltage, dtype=float)
        n = drive.size
        data = np.empty((n, N_OUT))
        signals = np.empty((len(SIGNALS), n))
        e, u, rec = np.empty(n), np.empty(n), np.empty((3, n))
        per_step = self.dt * self.rate_hz
        i = 0
        while i < n:
            k = self._k
            # the last tick whose measurement instant has both its neighbouring step means
            j_max = math.floor(((k - 1.5) * self.dt + self.delay_s) * self.rate_hz + _EPS)
            m_max = min(k + n - i, math.ceil((j_max + 1) / per_step - _EPS) - 1)
            ms = np.arange(k + 1, m_max + 1)
            ticks = np.floor(ms * per_step + _EPS).astype(np.int64)
            out = self._ticks(ticks)
            a, b = i, i + ms.size
            c = out[0] if envelope is None else out[0] * envelope[a:b]
            u[a:b] = c
            e[a:b] = drive[a:b] + self.input_gain * c
            # the oscillator's phase at each step's end (it runs on between ticks)
            rec[0, a:b] = out[1] + 2 * math.pi * out[2] * (ms * self.dt - ticks / self.rate_hz)
            rec[1, a:b], rec[2, a:b] = out[2], out[3]
            physics.advance(e[a:b], data[a:b], None if impulses is None else impulses[a:b])
            signals[:, a:b] = physics.sampled(e[a:b], data[a:b], None if impulses is None else impulses[a:b])
            self._remember(signals[_FORCE, a:b], data[a:b, _X])
            i = b
        self._record.append(rec)
        self._recorded += n
        while self._record and self._recorded - self._record[0].shape[1] >= self._keep_record:
            self._recorded -= self._record.popleft().shape[1]
        return signals, u, data[:, _X].copy()

    def _remember(self, force: np.ndarray, x_end: np.ndarray) -> None:
        x_prev = np.concatenate([[self._x_end], x_end[:-1]])
        self._x_end = float(x_end[-1])
        self._hf = np.concatenate([self._hf, force])[-self._keep :]
        self._hx = np.concatenate([self._hx, 0.5 * (x_prev + x_end)])[-self._keep :]
        self._k += force.size
        self._h0 = self._k - self._hf.size

    def oscillator(self, first: int, n: int) -> np.ndarray:
        """The loop's up-link: ``(3, n)`` its oscillator's phase (rad, unwrapped) and frequency
        (Hz) at the ends of steps ``first .. first + n - 1`` (amplifier samples since the
        stream began), and its phase estimate (deg).

        Raises
        ------
        SimulationInputError
            Samples not (or no longer) in the record.
        """
        if first + n > self._k or first < self._k - self._recorded:
            start = self._k - self._recorded
            raise SimulationInputError(
                f"the PLL's record holds steps {start}..{self._k}, not {first}..{first + n}"
            )
        parts, start = [], self._k  # the blocks from the newest back to the one holding ``first``
        for block in reversed(self._record):
            parts.append(block)
            start -= block.shape[1]
            if start <= first:
                break
        rec = parts[0] if len(parts) == 1 else np.concatenate(parts[::-1], axis=1)
        return rec[:, first - start : first - start + n]
