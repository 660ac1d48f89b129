"""Safety on every block: channel limits, the maximum drive, and drive amplitude ramps.

Pure numpy; no hardware. The pieces:

* :class:`SafetyMonitor` -- per-channel warning and abort limits on the peak |value| of each
  block (force in N, accelerations in m/s^2, the drive in V). ``check`` returns the warnings and
  raises :class:`~drivers.contracts.SafetyAbort` naming the channel, the value and the limit.
* :class:`SineDrive` -- the phase-continuous sine that goes to the shaker amplifier. Its
  amplitude never steps: every change follows a raised-cosine ramp (``ramp_time``) of its
  :class:`AmplitudeEnvelope`, the one owner of drive-amplitude ramps (the random drive uses it
  too), and it never exceeds ``max_drive``. The ramp to zero on an abort is the device's own
  (``stop()``, within ``abort_ramp_time`` <= 0.1 s).

A raised-cosine ramp from ``a0`` to ``a1`` over ``T`` is ``a0 + (a1 - a0) (1 - cos(pi t / T)) / 2``:
continuous in value and slope at both ends, so the shaker sees no step and no kink.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Iterable, Sequence

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


class AmplitudeEnvelope:
    """A drive amplitude that never steps: every change follows a raised-cosine ramp.

    The one owner of drive-amplitude ramps: :class:`SineDrive` and
    :class:`rigtools.acquisition.RandomDrive` multiply their unit signal by :meth:`take`.

    Parameters
    ----------
    sample_rate
        Samples per second of the drive.
    ramp_time
        Duration of every change unless :meth:`set_target` is given another, s (> 0).
    max_value
        Targets above it are refused, V.
    what
        Name of the amplitude in error messages (``"drive amplitude"``, ``"rms"``).

    Raises
    ------
    ConfigurationError
        If ``ramp_time`` or ``max_value`` is not > 0.
    """

    def __init__(self, sample_rate: float, ramp_time: float, max_value: float,
                 what: str = "drive amplitude") -> None:
        if not ramp_time > 0:
            raise ConfigurationError(f"ramp time {ramp_time!r} s must be > 0")
        if not max_value > 0:
            raise ConfigurationError(f"max drive {max_value!r} V must be > 0")
        self.sample_rate = float(sample_rate)
        self.ramp_time = float(ramp_time)
        self.max_value = float(max_value)
        self.what = what
        self._amp = 0.0                      # amplitude of the last sample taken
        self._ramp = np.empty(0)             # amplitudes still to come on the current ramp
        self._target = 0.0

    @property
    def amplitude(self) -> float:
        """Amplitude of the last sample taken."""
        return self._amp

    @property
    def target(self) -> float:
        return self._target

    @property
    def settled(self) -> bool:
        """True when the amplitude has reached its target (no ramp in progress)."""
        return self._ramp.size == 0

    def set_target(self, value: float, ramp_time: float | None = None) -> int:
        """Ramp from the present amplitude to ``value`` over ``ramp_time`` (default the envelope's).

        A new target during a ramp starts a new ramp from the present amplitude.

        Returns
        -------
        int
            Samples of the ramp: ``ceil(ramp_time * sample_rate)``, at least 1.

        Raises
        ------
        LimitExceeded
            If ``value`` is negative, not finite or above ``max_value``.
        """
        if not (math.isfinite(value) and 0.0 <= value <= self.max_value):
            raise LimitExceeded(f"{self.what} {value!r} V is outside 0..{self.max_value:g} V "
                                "(maximum drive)")
        duration = self.ramp_time if ramp_time is None else float(ramp_time)
        n = max(1, math.ceil(duration * self.sample_rate))
        self._target = float(value)
        if value == self._amp:
            self._ramp = np.empty(0)
        else:
            self._ramp = self._amp + (value - self._amp) * raised_cosine(n)
        return n

    def take(self, n: int) -> np.ndarray:
        """The amplitudes of the next ``n`` samples, continuing the ramp in progress."""
        amps = np.full(int(n), self._target)
        m = min(amps.size, self._ramp.size)
        amps[:m] = self._ramp[:m]
        self._ramp = self._ramp[m:]
        if amps.size:
            self._amp = float(amps[-1])
        return amps

    def stop_block(self, next_block: Callable[[int], np.ndarray]) -> np.ndarray:
        """A normal ramp to zero (``ramp_time``) as one block of ``next_block``; ends at 0 V.

        ``next_block(n)`` is the drive's, taking its amplitudes from this envelope. The ramp's
        last amplitude is exactly 0 (:func:`raised_cosine` ends at exactly 1); the last sample is
        set to +0.0 all the same (sign, clipping).
        """
        block = next_block(self.set_target(0.0))
        block[-1] = 0.0
        return block


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

    Examples
    --------
    >>> drive = SineDrive(51200.0, 60.0, max_drive=5.0, ramp_time=0.5)
    >>> drive.set_target(2.0)                  # ramps up over 0.5 s from the next sample
    >>> block = drive.next_block(5120)
    >>> tail = drive.stop_block()              # 0.5 s of samples ending at 0 V
    """

    def __init__(self, sample_rate: float, frequency: float, max_drive: float, ramp_time: float,
                 phase: float = 0.0) -> None:
        if not (sample_rate > 0 and math.isfinite(sample_rate)):
            raise ConfigurationError(f"sample rate {sample_rate!r} must be > 0")
        self._envelope = AmplitudeEnvelope(sample_rate, ramp_time, max_drive)
        self.sample_rate = float(sample_rate)
        self.max_drive = float(max_drive)
        self.ramp_time = float(ramp_time)
        self._phase = float(phase)           # phase of the next sample, rad
        self._omega = 0.0
        self.set_frequency(frequency)
        self.samples_written = 0

    @property
    def amplitude(self) -> float:
        """Amplitude (V peak) of the last sample produced."""
        return self._envelope.amplitude

    @property
    def target(self) -> float:
        return self._envelope.target

    @property
    def frequency(self) -> float:
        return self._omega * self.sample_rate / (2 * math.pi)

    @property
    def settled(self) -> bool:
        """True when the amplitude has reached its target (no ramp in progress)."""
        return self._envelope.settled

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
        self._envelope.set_target(amplitude, ramp_time)

    def next_block(self, n: int) -> np.ndarray:
        """The next ``n`` drive samples (V), continuing phase and ramp."""
        n = int(n)
        amps = self._envelope.take(n)
        phases = self._phase + self._omega * np.arange(n)
        self._phase = float((self._phase + self._omega * n) % (2 * math.pi))
        self.samples_written += n
        return amps * np.sin(phases)

    def stop_block(self) -> np.ndarray:
        """A normal ramp to zero (``ramp_time``) as one block; the last sample is 0 V."""
        return self._envelope.stop_block(self.next_block)
