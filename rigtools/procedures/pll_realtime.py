"""The phase-locked loop on the backend's real-time PLL (:mod:`rigtools.drivers.realtime_pll`;
the simulated rig runs it per sample inside its integrator).

The split of the work, as on a rig with a real-time target next to it:

* the loop (per sample, 10 kHz): phase detector, PI on the frequency, the phase-continuous sine
  at the amplitude the host sets; it is the whole drive at the amplifier's input (the host's
  stream writes zeros, which keep the converters' clock and the safety checks running);
* the host (per block): the phase target, moved towards the point's at ``phase_rate``; the
  force loop of :class:`rigtools.procedures.pll_run.PllRun` (the amplitude, every
  ``force_periods`` periods at least); the lock criterion and the record, on its own phase
  measurement: the fundamentals of force and response fitted on the loop's oscillator phase
  (the up-link, :meth:`rigtools.drivers.simulated.SimulatedRig.pll_oscillator`), as the buffered
  PLL fits them on the phase of the drive it wrote;
* the recording's drive row and the safety checks take the loop's output (what reached the
  amplifier), not the zeros written.

The drive reaches zero on every exit: at the end (and on a stop request) the amplitude is sent
to zero over the ramp and the blocks carrying the ramp are read and recorded; on a fault the
device ramps the loop's output down as it ramps any drive.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rigtools.acquisition import BlockStream
from rigtools.drivers.contracts import ConfigurationError
from rigtools.drivers.realtime_pll import (
    DEEP_PHASE,
    REALTIME_PLL_DEEP_GAINS,
    REALTIME_PLL_GAINS,
    PllCommand,
    RealTimePll,
)
from rigtools.procedures.pll_run import PllRun

#: Past the fold (a target below DEEP_PHASE), unless given: the target moves at 5 deg/s between
#: points (at 30 deg/s -165 deg is lost on the way from -156 deg), and the force is held within
#: 0.2 % (there fe moves about 0.1 % per 0.8 % of F1: a 1 % force tolerance spends the fe budget).
DEEP_DEFAULTS = {"phase_rate": 5.0, "force_tolerance": 0.004, "lock_tolerance": 0.5}


class OscillatorPhase:
    """The loop's oscillator phase as the detector's phase history (the :class:`~rigtools.procedures.pll_loop.PhaseLog`
    interface of :mod:`rigtools.procedures.pll_loop`), on stream sample indices: index ``i``
    holds the phase at the end of sample ``i``."""

    def __init__(self, device: Any, rate: float) -> None:
        self.device, self.rate = device, float(rate)

    def phase(self, samples: np.ndarray) -> np.ndarray:
        """The oscillator's phase (rad, unwrapped) at fractional sample indices ``samples``."""
        samples = np.asarray(samples, dtype=float)
        lo = max(0, math.floor(float(samples.min())))
        hi = min(int(self.device.drive_samples), math.ceil(float(samples.max())) + 1)
        theta = self.device.pll_oscillator(lo, hi - lo)[0]
        return np.interp(samples, np.arange(lo, hi, dtype=float), theta)

    def mean_frequency(self, first: float, last: float) -> float:
        """The mean frequency over samples ``[first, last]``, Hz."""
        p = self.phase(np.array([first, last]))
        return float((p[1] - p[0]) * self.rate / (2 * math.pi * (last - first)))

    def change(self, sample: float, fe: float) -> None:
        """The loop sets its own frequency: nothing to log."""


class LoopDrive:
    """The sine drive's interface (:class:`rigtools.drivers.drive_signals.SineDrive`) that the
    session and the PLL use, kept by the real-time loop: amplitude and phase target go down to
    it as commands, the frequency comes up from it; the blocks written are zeros."""

    def __init__(self, device: Any, sine: Any, phase_deg: float, gains: tuple[float, float]) -> None:
        self.device = device
        self.gains = gains  # the loop's PI gains, sent with every command
        self.sample_rate = float(sine.sample_rate)
        self.max_drive = float(sine.max_drive)
        self.ramp_time = float(sine.ramp_time)
        self.samples_written = 0
        self.phase_offset = 0.0
        self._target = 0.0
        self._phase = float(phase_deg)
        self._settled_at = 0  # amplifier sample from which the last ramp is done
        self._fe = float(sine.frequency)

    @property
    def target(self) -> float:
        return self._target

    @property
    def amplitude(self) -> float:
        return self._target if self.settled else math.nan

    @property
    def frequency(self) -> float:
        """The loop's frequency at the last sample read, Hz."""
        n = int(self.device.drive_samples)
        if n > 0:
            self._fe = float(self.device.pll_oscillator(n - 1, 1)[1, 0])
        return self._fe

    @property
    def settled(self) -> bool:
        return int(self.device.drive_samples) >= self._settled_at

    def set_frequency(self, frequency: float) -> None:
        """The loop's PI sets the frequency; a request from the host is ignored."""

    def set_phase(self, phase_deg: float) -> None:
        """The loop's phase target from its next tick."""
        self._phase = float(phase_deg)
        self._send(self._target, 0.0)

    def set_target(self, amplitude: float, ramp_time: float | None = None) -> None:
        amplitude = min(max(float(amplitude), 0.0), self.max_drive)
        ramp = self.ramp_time if ramp_time is None else float(ramp_time)
        self._send(amplitude, ramp)
        self._target = amplitude
        self._settled_at = int(self.device.drive_samples) + math.ceil(ramp * self.sample_rate)

    def _send(self, amplitude: float, ramp: float) -> None:
        self.device.set_pll_command(
            PllCommand(self._phase, amplitude, ramp, kp=self.gains[0], ki=self.gains[1])
        )

    def next_block(self, n: int) -> np.ndarray:
        self.samples_written += n
        return np.zeros(n)

    def stop_block(self, ramp_time: float | None = None) -> np.ndarray:
        """The amplitude to zero over the ramp (from the loop's next tick); zeros as long as it."""
        ramp = self.ramp_time if ramp_time is None else float(ramp_time)
        self.set_target(0.0, ramp)
        return np.zeros(max(1, math.ceil(ramp * self.sample_rate)))


class LoopBlockStream(BlockStream):
    """The session's stream with the loop's output (what reached the amplifier) as the drive
    played: recorded as the drive row and checked by the safety monitor."""

    def _store(self, block: np.ndarray, played: np.ndarray) -> None:
        n = block.shape[1]
        device: Any = self.device  # a backend with a real-time loop
        back = int(device.drive_samples) - int(self.stats.samples)  # this block to the latest sample
        if n and back >= n:
            try:
                played[:n] = device.loop_log_tail(back)[0, :n]
            except ValueError:  # the record no longer holds the block
                pass
        super()._store(block, played)


class RealTimePllRun(PllRun):
    """:class:`PllRun` with the backend's real-time PLL as its inner loop (see the module).

    Raises
    ------
    ConfigurationError
        The device has no real-time loop.
    """

    name = "realtime"

    def __init__(self, proc: Any, session: Any, params: Any) -> None:
        device = session.device
        if not getattr(device, "has_realtime_loop", False):
            raise ConfigurationError(f"the {device.backend} backend has no real-time inner loop")
        lo, hi = params.frequency_range()
        given = params.model_fields_set
        deep = min(params.phases) < DEEP_PHASE
        # the gains by the target (a schedule), unless given: near resonance and past the fold
        self.gains = {
            False: (
                params.kp if "kp" in given else REALTIME_PLL_GAINS[0],
                params.ki if "ki" in given else REALTIME_PLL_GAINS[1],
            ),
            True: (
                params.kp if "kp" in given else REALTIME_PLL_DEEP_GAINS[0],
                params.ki if "ki" in given else REALTIME_PLL_DEEP_GAINS[1],
            ),
        }
        first_phase = params.targets()[0][1]
        kp, ki = self.gains[first_phase < DEEP_PHASE]
        if deep:  # past the fold: the target moves slower, the force is held closer
            update = {k: v for k, v in DEEP_DEFAULTS.items() if k not in given}
            params = params.model_copy(update=update)
        self.law = RealTimePll(f_start=float(session.fe), f_min=lo, f_max=hi, kp=kp, ki=ki)
        device.set_realtime_loop(self.law)
        old = session.stream
        drive = LoopDrive(device, session.drive, first_phase, (kp, ki))
        session.drive = drive
        session.stream = LoopBlockStream(
            device,
            drive,
            sink=old.sink,
            safety=old.safety,
            record_drive=True,
            abort_ramp_time=old.abort_ramp_time,
            hurry=old.hurry,
        )
        super().__init__(proc, session, params)
        self.delay = 0.5  # the oscillator's record holds step ends, the inputs step means
        self.log = OscillatorPhase(device, self.rate)  # type: ignore[assignment]  # PhaseLog's interface

    def _set_frequency(self, fe: float) -> None:
        """The loop's PI sets the frequency."""

    def _steer(self, error: float, dt: float) -> None:
        """The loop follows the host's (moving) phase target."""
        assert self.target is not None  # set by _update before steering
        self.s.drive.gains = self.gains[self.target < DEEP_PHASE]
        self.s.drive.set_phase(self.target)


__all__ = ["LoopBlockStream", "LoopDrive", "OscillatorPhase", "RealTimePllRun"]
