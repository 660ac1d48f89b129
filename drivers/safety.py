"""Safety on every block: channel limits, the maximum drive, and drive amplitude ramps.

Pure numpy; no hardware. Two pieces:

* :class:`SafetyMonitor` -- per-channel warning and abort limits on the peak |value| of each
  block (force in N, accelerations in m/s^2, the drive in V). ``check`` returns the warnings and
  raises :class:`~drivers.contracts.SafetyAbort` naming the channel, the value and the limit.
* :class:`SineDrive` -- the phase-continuous sine that goes to the shaker amplifier. Its
  amplitude never steps: every change follows a raised-cosine ramp (``ramp_time``), an abort
  ramps down within ``abort_ramp_time`` (at most 0.1 s), and it never exceeds ``max_drive``.

A raised-cosine ramp from ``a0`` to ``a1`` over ``T`` is ``a0 + (a1 - a0) (1 - cos(pi t / T)) / 2``:
continuous in value and slope at both ends, so the shaker sees no step and no kink.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from drivers.contracts import (
    ConfigurationError,
    InputChannelSpec,
    LimitExceeded,
    SafetyAbort,
)

MAX_ABORT_RAMP = 0.1      # s; the ramp-down on abort never takes longer
DRIVE = "drive"           # name of the drive output in limits


@dataclass(frozen=True)
class ChannelLimit:
    """Warning and abort limits on the peak |value| of a channel, in its SI units."""

    channel: str
    warning: float
    abort: float
    units: str = ""

    def __post_init__(self) -> None:
        if not 0 < self.warning < self.abort:
            raise ConfigurationError(
                f"limits of {self.channel!r}: need 0 < warning ({self.warning}) < abort "
                f"({self.abort})")


@dataclass(frozen=True)
class SafetyWarning:
    """A channel whose block peak reached its warning limit (but not its abort limit)."""

    channel: str
    value: float
    limit: float
    units: str = ""

    def __str__(self) -> str:
        u = f" {self.units}" if self.units else ""
        return (f"{self.channel} peak {self.value:.4g}{u} is above the warning limit "
                f"{self.limit:.4g}{u}")


class SafetyMonitor:
    """Checks every block against per-channel warning and abort limits.

    Parameters
    ----------
    limits
        One :class:`ChannelLimit` per limited channel; the drive output is named ``"drive"``.
    channels
        Input channels in block row order (specs or names).
    max_drive
        Peak drive voltage never to be exceeded (checked on every drive block), V.

    Raises
    ------
    ConfigurationError
        If a limit names a channel that is not among ``channels`` (nor ``"drive"``).
    """

    def __init__(self, limits: Iterable[ChannelLimit],
                 channels: Sequence[InputChannelSpec] | Sequence[str],
                 max_drive: float = math.inf) -> None:
        names = [c.name if isinstance(c, InputChannelSpec) else str(c) for c in channels]
        units = {c.name: c.units for c in channels if isinstance(c, InputChannelSpec)}
        self.limits: dict[str, ChannelLimit] = {}
        for lim in limits:
            if lim.channel not in names and lim.channel != DRIVE:
                raise ConfigurationError(
                    f"safety limit for unknown channel {lim.channel!r} (channels: "
                    f"{', '.join(names)}, {DRIVE})")
            if not lim.units:
                lim = ChannelLimit(lim.channel, lim.warning, lim.abort,
                                   "V" if lim.channel == DRIVE else units.get(lim.channel, ""))
            self.limits[lim.channel] = lim
        if not max_drive > 0:
            raise ConfigurationError(f"max_drive {max_drive!r} V must be > 0")
        self.max_drive = float(max_drive)
        self.channels = tuple(names)
        self._rows = [(i, self.limits[n]) for i, n in enumerate(names) if n in self.limits]

    def check(self, block: np.ndarray, drive: np.ndarray | None = None) -> list[SafetyWarning]:
        """Check one block of inputs (and optionally the drive written with it).

        Parameters
        ----------
        block
            ``(n_channels, n)`` in the row order given at construction, SI units.
        drive
            The drive block (V), if it is to be checked too.

        Returns
        -------
        list of SafetyWarning
            Channels at or above their warning limit, in channel order.

        Raises
        ------
        SafetyAbort
            At the first channel (in order, the drive last) at or above its abort limit, or with a
            non-finite peak; ``partial`` holds the block. Also if the drive exceeds ``max_drive``.
        """
        block = np.asarray(block)
        if block.ndim != 2 or block.shape[0] != len(self.channels):
            raise ValueError(f"block of shape {block.shape} does not match "
                             f"{len(self.channels)} channels")
        warnings: list[SafetyWarning] = []
        if block.shape[1]:
            peaks = np.max(np.abs(block), axis=1)
            for row, lim in self._rows:
                warning = self._judge(lim, float(peaks[row]), block)
                if warning:
                    warnings.append(warning)
        if drive is not None:
            warnings.extend(self.check_drive(drive, block))
        return warnings

    def check_drive(self, drive: np.ndarray, block: np.ndarray | None = None) -> list[SafetyWarning]:
        """Check a drive block against ``max_drive`` and the ``"drive"`` limits."""
        drive = np.asarray(drive, dtype=float)
        if drive.size == 0:
            return []
        peak = float(np.max(np.abs(drive)))
        if not math.isfinite(peak) or peak > self.max_drive * (1 + 1e-12):
            raise SafetyAbort(
                f"drive peak {peak:.4g} V exceeds the maximum drive {self.max_drive:.4g} V",
                channel=DRIVE, value=peak, limit=self.max_drive, partial=block)
        lim = self.limits.get(DRIVE)
        if lim is None:
            return []
        warning = self._judge(lim, peak, block)
        return [warning] if warning else []

    @staticmethod
    def _judge(lim: ChannelLimit, peak: float, block: np.ndarray | None) -> SafetyWarning | None:
        u = f" {lim.units}" if lim.units else ""
        if not math.isfinite(peak):
            raise SafetyAbort(f"{lim.channel} is not finite ({peak})", channel=lim.channel,
                              value=peak, limit=lim.abort, partial=block)
        if peak >= lim.abort:
            raise SafetyAbort(
                f"{lim.channel} peak {peak:.4g}{u} reached the abort limit {lim.abort:.4g}{u}",
                channel=lim.channel, value=peak, limit=lim.abort, partial=block)
        if peak >= lim.warning:
            return SafetyWarning(lim.channel, peak, lim.warning, lim.units)
        return None


def raised_cosine(n: int) -> np.ndarray:
    """``n`` samples of a 0 -> 1 raised-cosine ramp, excluding 0 and including 1.

    Sample ``k`` (1-based) is ``(1 - cos(pi k / n)) / 2``, so a ramp written after a sample at
    the start value ends exactly at the end value.
    """
    if n <= 0:
        return np.empty(0)
    k = np.arange(1, n + 1, dtype=float)
    return 0.5 * (1.0 - np.cos(np.pi * k / n))


class SineDrive:
    """Phase-continuous sine drive ``a(t) sin(2 pi f t + phi)`` with ramped amplitude ``a(t)``.

    Parameters
    ----------
    sample_rate
        Drive sample rate, S/s (use the device's actual rate).
    frequency
        Sine frequency, Hz.
    max_drive
        Peak voltage never exceeded: targets above it are refused.
    ramp_time
        Duration of every amplitude change (raised cosine), s.
    abort_ramp_time
        Duration of the ramp to zero on abort, s (at most 0.1 s).

    Examples
    --------
    >>> drive = SineDrive(51200.0, 60.0, max_drive=5.0, ramp_time=0.5)
    >>> drive.set_target(2.0)                  # ramps up over 0.5 s from the next sample
    >>> block = drive.next_block(5120)
    >>> tail = drive.abort_block()             # <= 0.1 s of samples ending at 0 V
    """

    def __init__(self, sample_rate: float, frequency: float, max_drive: float, ramp_time: float,
                 abort_ramp_time: float = 0.05, phase: float = 0.0) -> None:
        if not (sample_rate > 0 and math.isfinite(sample_rate)):
            raise ConfigurationError(f"sample rate {sample_rate!r} must be > 0")
        if not 0 < abort_ramp_time <= MAX_ABORT_RAMP:
            raise ConfigurationError(
                f"abort ramp time {abort_ramp_time!r} s must be in (0, {MAX_ABORT_RAMP}] s")
        if not ramp_time > 0:
            raise ConfigurationError(f"ramp time {ramp_time!r} s must be > 0")
        if not max_drive > 0:
            raise ConfigurationError(f"max drive {max_drive!r} V must be > 0")
        self.sample_rate = float(sample_rate)
        self.max_drive = float(max_drive)
        self.ramp_time = float(ramp_time)
        self.abort_ramp_time = float(abort_ramp_time)
        self._phase = float(phase)           # phase of the next sample, rad
        self._omega = 0.0
        self.set_frequency(frequency)
        self._amp = 0.0                      # amplitude of the last sample written
        self._ramp = np.empty(0)             # amplitudes still to come on the current ramp
        self._target = 0.0
        self.samples_written = 0

    @property
    def amplitude(self) -> float:
        """Amplitude (V peak) of the last sample produced."""
        return self._amp

    @property
    def target(self) -> float:
        return self._target

    @property
    def frequency(self) -> float:
        return self._omega * self.sample_rate / (2 * math.pi)

    @property
    def settled(self) -> bool:
        """True when the amplitude has reached its target (no ramp in progress)."""
        return self._ramp.size == 0

    def set_frequency(self, frequency: float) -> None:
        """Change the frequency; the phase stays continuous."""
        if not (frequency > 0 and frequency < self.sample_rate / 2):
            raise LimitExceeded(f"drive frequency {frequency!r} Hz must be in (0, "
                                f"{self.sample_rate / 2:g}) Hz (below Nyquist)")
        self._omega = 2 * math.pi * frequency / self.sample_rate

    def set_target(self, amplitude: float, ramp_time: float | None = None) -> None:
        """Move the amplitude to ``amplitude`` (V peak) along a raised-cosine ramp.

        A new target during a ramp starts a new ramp from the present amplitude.

        Raises
        ------
        LimitExceeded
            If ``amplitude`` is negative, not finite or above ``max_drive``.
        """
        if not (math.isfinite(amplitude) and 0.0 <= amplitude <= self.max_drive):
            raise LimitExceeded(f"drive amplitude {amplitude!r} V is outside 0..{self.max_drive:g} V "
                                "(maximum drive)")
        duration = self.ramp_time if ramp_time is None else float(ramp_time)
        n = max(1, math.ceil(duration * self.sample_rate))
        self._target = float(amplitude)
        if amplitude == self._amp:
            self._ramp = np.empty(0)
        else:
            self._ramp = self._amp + (amplitude - self._amp) * raised_cosine(n)

    def ramp_down(self) -> None:
        """Start a normal ramp to zero (``ramp_time``)."""
        self.set_target(0.0)

    def next_block(self, n: int) -> np.ndarray:
        """The next ``n`` drive samples (V), continuing phase and ramp."""
        n = int(n)
        amps = np.empty(n)
        m = min(n, self._ramp.size)
        amps[:m] = self._ramp[:m]
        amps[m:] = self._target
        self._ramp = self._ramp[m:]
        if n:
            self._amp = float(amps[-1])
        phases = self._phase + self._omega * np.arange(n)
        self._phase = float((self._phase + self._omega * n) % (2 * math.pi))
        self.samples_written += n
        return amps * np.sin(phases)

    def abort_block(self) -> np.ndarray:
        """Samples that bring the drive to exactly 0 V within ``abort_ramp_time`` (<= 0.1 s).

        The ramp starts from the present amplitude; the last sample is 0 V. Afterwards the
        target is 0 and :meth:`next_block` produces zeros.
        """
        n = max(1, math.ceil(self.abort_ramp_time * self.sample_rate))
        self.set_target(0.0, ramp_time=n / self.sample_rate)
        block = self.next_block(n)
        block[-1] = 0.0     # raised_cosine ends at exactly 1, so the amplitude is 0: make it exact
        return block

    def stop_block(self) -> np.ndarray:
        """A normal ramp to zero (``ramp_time``) as one block; the last sample is 0 V."""
        n = max(1, math.ceil(self.ramp_time * self.sample_rate))
        self.set_target(0.0)
        block = self.next_block(n)
        block[-1] = 0.0
        return block
