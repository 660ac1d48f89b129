"""Safety on every block: channel limits, the maximum drive, and drive amplitude ramps.

Pure numpy; no hardware. The pieces:

* :class:`SafetyMonitor` -- per-channel warning and abort limits on the peak ``|value|`` of each
  block (force in N, accelerations in m/s^2, the drive in V). ``check`` returns the warnings and
  raises :class:`~rigtools.drivers.contracts.SafetyAbort` naming the channel, the value and the limit.
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
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from rigtools.drivers.contracts import (
    ConfigurationError,
    InputChannelSpec,
    SafetyAbort,
)

# the drive generators live in rigtools.drivers.drive_signals; kept importable from here
from rigtools.drivers.drive_signals import AmplitudeEnvelope, SineDrive, raised_cosine  # noqa: F401

MAX_ABORT_RAMP = 0.1  # s; the ramp-down on abort never takes longer
MAX_TIME_TO_ZERO = 0.1  # s; from a fault's detection to 0 V at the output, queue included
QUEUE_MARGIN = 0.9  # the queue gets this share of what the ramp leaves of that time
DRIVE = "drive"  # name of the drive output in limits


@dataclass(frozen=True)
class ChannelLimit:
    """Warning and abort limits on the peak ``|value|`` of a channel, in its SI units."""

    channel: str
    warning: float
    abort: float
    units: str = ""

    def __post_init__(self) -> None:
        if not 0 < self.warning < self.abort:
            raise ConfigurationError(
                f"limits of {self.channel!r}: need 0 < warning ({self.warning}) < abort ({self.abort})"
            )


@dataclass(frozen=True)
class SafetyWarning:
    """A channel whose block peak reached its warning limit (but not its abort limit)."""

    channel: str
    value: float
    limit: float
    units: str = ""

    def __str__(self) -> str:
        u = f" {self.units}" if self.units else ""
        return f"{self.channel} peak {self.value:.4g}{u} is above the warning limit {self.limit:.4g}{u}"


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

    def __init__(
        self,
        limits: Iterable[ChannelLimit],
        channels: Sequence[InputChannelSpec] | Sequence[str],
        max_drive: float = math.inf,
    ) -> None:
        names = [c.name if isinstance(c, InputChannelSpec) else str(c) for c in channels]
        units = {c.name: c.units for c in channels if isinstance(c, InputChannelSpec)}
        self.limits: dict[str, ChannelLimit] = {}
        for lim in limits:
            if lim.channel not in names and lim.channel != DRIVE:
                raise ConfigurationError(
                    f"safety limit for unknown channel {lim.channel!r} (channels: "
                    f"{', '.join(names)}, {DRIVE})"
                )
            if not lim.units:
                lim = ChannelLimit(
                    lim.channel,
                    lim.warning,
                    lim.abort,
                    "V" if lim.channel == DRIVE else units.get(lim.channel, ""),
                )
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
            raise ValueError(f"block of shape {block.shape} does not match {len(self.channels)} channels")
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
                channel=DRIVE,
                value=peak,
                limit=self.max_drive,
                partial=block,
            )
        lim = self.limits.get(DRIVE)
        if lim is None:
            return []
        warning = self._judge(lim, peak, block)
        return [warning] if warning else []

    @staticmethod
    def _judge(lim: ChannelLimit, peak: float, block: np.ndarray | None) -> SafetyWarning | None:
        u = f" {lim.units}" if lim.units else ""
        if not math.isfinite(peak):
            raise SafetyAbort(
                f"{lim.channel} is not finite ({peak})",
                channel=lim.channel,
                value=peak,
                limit=lim.abort,
                partial=block,
            )
        if peak >= lim.abort:
            raise SafetyAbort(
                f"{lim.channel} peak {peak:.4g}{u} reached the abort limit {lim.abort:.4g}{u}",
                channel=lim.channel,
                value=peak,
                limit=lim.abort,
                partial=block,
            )
        if peak >= lim.warning:
            return SafetyWarning(lim.channel, peak, lim.warning, lim.units)
        return None


def output_queue_limit(
    sample_rate: float, abort_ramp_time: float, max_time_to_zero: float = MAX_TIME_TO_ZERO
) -> int:
    """Most drive samples a device may hold queued ahead of the inputs.

    On a stop the queued drive plays out before the ramp to zero (a non-regenerating output
    cannot be rewritten), so ``queue / rate + abort_ramp_time <= max_time_to_zero``; the queue
    gets :data:`QUEUE_MARGIN` of the time the ramp leaves (at least 25 ms). 0.1 s with a 50 ms
    ramp at 51.2 kS/s: 2304 samples (45 ms).

    Raises
    ------
    ConfigurationError
        If the ramp alone takes ``max_time_to_zero`` or longer.
    """
    # an abort ramp above 75 ms leaves the queue 25 ms (time to zero = ramp + 25 ms)
    max_time_to_zero = max(max_time_to_zero, abort_ramp_time + 0.025)
    room = (max_time_to_zero - abort_ramp_time) * QUEUE_MARGIN * sample_rate
    if room < 2:
        raise ConfigurationError(
            f"abort ramp {abort_ramp_time:g} s leaves no room for queued drive within "
            f"{max_time_to_zero:g} s to zero"
        )
    return math.floor(room)
