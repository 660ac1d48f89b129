"""The real-time inner loop as a contract: per-sample feedback at a stated rate and delay.

Control-based continuation holds an unstable orbit with a feedback on the response. Run by the
host on buffered I/O the correction reaches the rig 50-65 ms after the data it comes from (on
the NI path), which holds an orbit only while growth rate x delay stays well under 1 (at 64 Hz
``|mu| <~ 1.15``). The whole unstable sheet needs the loop closed next to the rig, per sample, at
a few kHz with 1-2 ms latency: a real-time target (FPGA, cRIO, microcontroller; the plan is in
the docs' *real-time inner loop* page). This module states what such a loop does:

* :class:`RealTimeLoop`: rate, latency and gains of the law

      u[k] = Kp (x*(t_k - D) - x(t_k - D)) + Kd (v*(t_k - D) - v(t_k - D)),

  ``x``, ``v`` the active shroud's displacement and velocity, ``t_k = k / rate`` the loop's
  ticks, ``D`` its latency; ``u`` (V) is held until the next tick and added to the drive at the
  amplifier's input. Target and measurement are compared at the instant the measurement stands
  for: on a true orbit of the rig with the target equal to it ``u = 0`` (non-invasive), and a
  change of target shows in ``u`` exactly ``D`` later (at the first tick ``t_k >= T + D``).
* :class:`rigtools.sim.delayed_feedback.HarmonicTarget`: the target, harmonics of ``fe``, which the
  host updates between blocks (the down-link); the host measures the response's harmonics from
  the blocks it reads (the up-link).
* :attr:`rigtools.drivers.contracts.AcquisitionDevice.has_realtime_loop`: whether a backend runs it.
  The simulated rig does (inside its integrator: :meth:`rigtools.drivers.simulated.SimulatedRig.set_realtime_loop`,
  :meth:`~rigtools.drivers.simulated.SimulatedRig.set_loop_target`); the NI-DAQmx backend does not, and a
  procedure says so in one line (:data:`NO_REALTIME_LOOP`) and runs its buffered variant.

The loop's clock: ``t = 0`` at the first sample of the stream, the clock of the inputs
(input sample ``n`` is the mean over ``[n / fs, (n + 1) / fs)``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rigtools.drivers.contracts import ConfigurationError
from rigtools.sim.delayed_feedback import HarmonicTarget

__all__ = ["CONVERTER_DELAY", "NO_REALTIME_LOOP", "HarmonicTarget", "RealTimeLoop"]

#: The converters' latency on the rig's DSA path, s (the sigma-delta ADC's group delay plus the
#: DAC's at the rates a loop runs at); a loop adds its own computation and output samples.
CONVERTER_DELAY = 0.84e-3

#: What a procedure says on a backend without a real-time inner loop (one line).
NO_REALTIME_LOOP = (
    "this backend has no real-time inner loop: the buffered feedback acts 50-65 ms late and holds "
    "an unstable orbit only while |mu| <~ 1.15 at 64 Hz; the whole unstable sheet needs a real-time "
    "target (FPGA, cRIO or microcontroller; docs: realtime-inner-loop)"
)


@dataclass(frozen=True)
class RealTimeLoop:
    """A per-sample feedback law on the active shroud's displacement (see the module).

    Parameters
    ----------
    kp
        Proportional gain, V (at the amplifier's input) per m.
    kd
        Derivative gain, V per (m/s).
    rate_hz
        The loop's tick rate, Hz (10 kHz: a few kHz is what the unstable sheet needs).
    converter_delay_s
        The converters' latency, s (:data:`CONVERTER_DELAY`).
    compute_samples
        Ticks spent computing and writing the output, on top of the converters.
    target
        The target to start with (``None``: output 0 until :meth:`rigtools.drivers.simulated.SimulatedRig.set_loop_target`).
    lowpass_hz
        The corner of the low-pass on the output, Hz (``None``: none), below half the rate.
    """

    kp: float = 0.0
    kd: float = 0.0
    rate_hz: float = 10_000.0
    converter_delay_s: float = CONVERTER_DELAY
    compute_samples: int = 2
    target: HarmonicTarget | None = None
    lowpass_hz: float | None = None

    def __post_init__(self) -> None:
        if self.lowpass_hz is not None and not (
            math.isfinite(self.lowpass_hz) and 0 < self.lowpass_hz < 0.5 * self.rate_hz
        ):
            raise ConfigurationError(
                f"real-time loop low-pass {self.lowpass_hz!r} Hz must lie between 0 and half its rate"
            )
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise ConfigurationError(f"real-time loop rate {self.rate_hz!r} Hz must be > 0")
        if not (math.isfinite(self.converter_delay_s) and self.converter_delay_s >= 0):
            raise ConfigurationError(
                f"real-time loop converter delay {self.converter_delay_s!r} s must be >= 0"
            )
        if self.compute_samples < 0 or self.delay_s <= 0:
            raise ConfigurationError(
                "real-time loop: its delay must be > 0 (a loop needs at least one sample)"
            )
        if not (math.isfinite(self.kp) and math.isfinite(self.kd)):
            raise ConfigurationError(
                f"real-time loop gains must be finite, got kp={self.kp!r}, kd={self.kd!r}"
            )

    @property
    def delay_s(self) -> float:
        """The whole latency ``D``: converters plus ``compute_samples`` ticks, s."""
        return self.converter_delay_s + self.compute_samples / self.rate_hz
