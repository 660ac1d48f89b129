"""The real-time phase-locked loop as a contract: the PLL run per sample next to the rig.

Held by the host on buffered I/O (:mod:`rigtools.procedures.pll_run`), the PLL sees the phase
over blocks and changes the frequency 40-65 ms after the data it comes from: enough on the
stable branches, not past the fold, where the orbits a stepped sine jumps over grow at a fixed
drive (at 5 N, gap 0.5 mm: ``|mu|`` 1.13-1.45 per period at -156 to -165 deg) faster than that
loop corrects. The field runs the PLL on a real-time target (NLtest; Peter & Leine 2017), per
sample. :class:`RealTimePll` states what such a loop does (the law in
:mod:`rigtools.sim.realtime_pll`):

* at ``rate_hz`` (10 kHz) it samples the force and the active shroud's displacement, ``delay_s``
  (the converters' 0.84 ms plus ``compute_samples`` ticks) before the tick whose output they make;
* phase detector: demodulation with its own oscillator, a moving mean over one period of it
  (the double frequency and the impacts' harmonics removed; group delay half a period);
* PI on the instantaneous frequency (``kp`` Hz/deg, ``ki`` Hz/(deg s)), within ``[f_min, f_max]``;
* a phase-continuous sine out, its amplitude from the host.

The host (down-link, :class:`PllCommand`, between blocks): the phase target (slewing at a rate)
and the amplitude, which its slower force loop sets; (up-link) the oscillator's phase and
frequency per sample, on which it measures the response's phase itself and judges the lock.
The simulated rig runs it inside its integrator
(:meth:`rigtools.drivers.simulated.SimulatedRig.set_realtime_loop` with a :class:`RealTimePll`,
:meth:`~rigtools.drivers.simulated.SimulatedRig.set_pll_command`,
:meth:`~rigtools.drivers.simulated.SimulatedRig.pll_oscillator`); the NI-DAQmx backend has no
real-time loop (``has_realtime_loop`` False): the procedure prints :data:`NO_REALTIME_PLL` and
runs the buffered PLL.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rigtools.drivers.contracts import ConfigurationError
from rigtools.drivers.realtime import CONVERTER_DELAY
from rigtools.sim.realtime_pll import PllCommand

__all__ = [
    "DEEP_PHASE",
    "NO_REALTIME_PLL",
    "REALTIME_PLL_DEEP_GAINS",
    "REALTIME_PLL_GAINS",
    "PllCommand",
    "RealTimePll",
]

#: The real-time PLL's gains by default (Hz/deg, Hz/(deg s)) near phase resonance: crossover
#: near 18 rad/s (``360 kp``); measured: 0.2 N locks in 94 periods (kp 0.1 there takes 192).
REALTIME_PLL_GAINS = (0.05, 0.5)
#: ... and past the fold (a run whose deepest target is below :data:`DEEP_PHASE`): crossover near
#: 90 rad/s (``360 kp``), just under what the detector's half period of delay (8 ms at 64 Hz)
#: plus the 1.04 ms latency allow, above the growth of the orbits there (ln|mu| fe, to ~23 s^-1
#: at -165 deg); measured at 5 N: kp 0.1 holds -156 deg and loses -165 deg, 0.25 holds -165 deg.
REALTIME_PLL_DEEP_GAINS = (0.25, 0.3)
DEEP_PHASE = -140.0

#: What the PLL says on a backend without a real-time loop (one line).
NO_REALTIME_PLL = (
    "this backend has no real-time inner loop: the buffered PLL acts 40-65 ms late and holds the "
    "phase only to about -150 deg past the fold at 5 N; deeper needs a real-time target (FPGA, "
    "cRIO or microcontroller; docs: realtime-inner-loop)"
)


@dataclass(frozen=True)
class RealTimePll:
    """A per-sample phase-locked loop (see the module).

    Parameters
    ----------
    f_start
        The oscillator's first frequency, Hz.
    f_min, f_max
        Its range, Hz.
    kp, ki
        PI gains on the frequency, Hz/deg and Hz/(deg s).
    rate_hz
        Tick rate, Hz.
    converter_delay_s
        The converters' latency, s (:data:`rigtools.drivers.realtime.CONVERTER_DELAY`).
    compute_samples
        Ticks spent computing and writing, on top of the converters.
    min_force
        Below this force fundamental (N) the loop holds its frequency (nothing to lock to).
    """

    f_start: float
    f_min: float
    f_max: float
    kp: float = REALTIME_PLL_GAINS[0]
    ki: float = REALTIME_PLL_GAINS[1]
    rate_hz: float = 10_000.0
    converter_delay_s: float = CONVERTER_DELAY
    compute_samples: int = 2
    min_force: float = 0.01

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise ConfigurationError(f"real-time PLL rate {self.rate_hz!r} Hz must be > 0")
        if not (0 < self.f_min <= self.f_start <= self.f_max < self.rate_hz / 4):
            raise ConfigurationError(
                f"real-time PLL: need 0 < f_min ({self.f_min:g}) <= f_start ({self.f_start:g}) "
                f"<= f_max ({self.f_max:g} Hz) < rate / 4"
            )
        if not (math.isfinite(self.kp) and math.isfinite(self.ki) and self.kp >= 0 and self.ki >= 0):
            raise ConfigurationError(f"real-time PLL gains must be >= 0, got kp={self.kp!r}, ki={self.ki!r}")
        if self.compute_samples < 0 or not (
            math.isfinite(self.converter_delay_s) and self.converter_delay_s >= 0
        ):
            raise ConfigurationError("real-time PLL: its delay must be >= 0")

    @property
    def delay_s(self) -> float:
        """The whole latency: converters plus ``compute_samples`` ticks, s."""
        return self.converter_delay_s + self.compute_samples / self.rate_hz
