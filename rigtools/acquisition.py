"""The block loop every experiment procedure stands on: stream a drive, read blocks, stay safe.

:class:`BlockStream` drives an :class:`~rigtools.drivers.contracts.AcquisitionDevice` that is already
configured (channels, sample rate):

* it primes the non-regenerating output with two drive blocks, starts the device, and then for
  every block reads the inputs and writes the next drive block (staying two blocks ahead);
* every block is appended to a *sink* (a recording point, see
  :class:`rigtools.recording.RecordingWriter`, or anything with ``append(block)``) and then
  checked by the :class:`~rigtools.drivers.safety.SafetyMonitor` together with the drive block that was
  played while it was measured;
* on ANY error (a device fault, a safety abort, a sink error, Ctrl-C) it stops the device at
  once: per the device contract, :meth:`~rigtools.drivers.contracts.AcquisitionDevice.stop` ramps the
  drive to zero (the simulated rig within its ``abort_ramp_time`` <= 0.1 s). What was read
  before the error stays in the sink, including the partial block a fault carries. The error is
  re-raised as :class:`AcquisitionAborted` (one line naming the fault, when, and what was kept);
  Ctrl-C is re-raised as it is, after the safe stop;
* :meth:`BlockStream.finish` ramps the drive down normally (the drive's own ramp), reads the
  blocks that carry the ramp (and the device's input-to-output delay), and stops.

Drives are objects with ``next_block(n)`` and ``stop_block()`` (and ``settled``):
:class:`rigtools.drivers.safety.SineDrive` for sines, :class:`RandomDrive` here for (burst) random. The
drive ramps its own amplitude, so no step ever reaches the shaker.

Procedures (dwell, stepped sine, sweep, burst random) are loops over :meth:`BlockStream.read`
that change the drive (``set_target``, ``set_frequency``) and switch the sink between recording
points; :func:`acquire` is the simplest one: a fixed duration at one drive setting.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NoReturn, Protocol

import numpy as np

from rigtools.drivers.contracts import AcquisitionDevice, DaqFault, DriverError, SafetyAbort
from rigtools.drivers.drive_signals import RandomDrive  # noqa: F401  (kept importable from here)
from rigtools.drivers.safety import SafetyMonitor
from rigtools.errors import FaultError, one_line

if TYPE_CHECKING:
    from typing import Self


class Drive(Protocol):
    """What the loop needs from a drive signal (volts at the device's sample rate)."""

    def next_block(self, n: int) -> np.ndarray: ...

    def stop_block(self, ramp_time: float | None = None) -> np.ndarray: ...


class Sink(Protocol):
    def append(self, block: np.ndarray) -> None: ...


class AcquisitionAborted(FaultError):
    """An acquisition stopped on an error, with the drive brought to zero.

    Attributes
    ----------
    fault
        The fault's name (e.g. ``"input overflow"``, ``"safety abort"``), or the exception type.
    cause
        The original exception.
    samples_kept
        Samples per channel that reached the sink before the error.
    time
        Time of the error from the start of the stream, s.
    """

    def __init__(
        self, message: str, *, fault: str, cause: BaseException, samples_kept: int, time: float
    ) -> None:
        super().__init__(message)
        self.fault = fault
        self.cause = cause
        self.samples_kept = samples_kept
        self.time = time


@dataclass
class StreamStats:
    """What a stream did."""

    sample_rate: float
    blocks: int = 0
    samples: int = 0  # per channel, read and passed to the sink
    warnings: list = field(default_factory=list)  # SafetyWarning, in order

    @property
    def duration(self) -> float:
        return self.samples / self.sample_rate


def stream_piece(device: AcquisitionDevice) -> int:
    """Samples per read/write: the device's block, split into equal pieces so that two of them
    (the drive kept queued ahead) fit its :attr:`~rigtools.drivers.contracts.AcquisitionDevice.output_queue_limit`."""
    block = int(device.block_size)
    limit = getattr(device, "output_queue_limit", None)
    if not limit or 2 * block <= limit:
        return block
    k = math.ceil(block / (limit // 2))
    return max(1, math.ceil(block / k))


class BlockStream:
    """Stream ``drive`` to a configured ``device`` block by block (see the module docstring).

    Parameters
    ----------
    device
        A configured acquisition device (not started).
    drive
        The drive signal source.
    sink
        Receives every block read (``(n_channels[+1], n)`` float64); ``None`` to keep nothing.
    safety
        Checked on every block with the drive played during it; ``None`` for no limits.
    record_drive
        Append the played drive as an extra last row of each block passed to the sink.
    on_block
        Called as ``on_block(block, stats)`` after each block is stored and checked.
    abort_ramp_time
        On a safety abort, ramp the drive to zero over this many seconds while still reading
        (the record keeps the ramp), then raise; ``None``: stop the device at once (its own
        ramp, not recorded).
    hurry
        Asked before each block of :meth:`finish`: once it returns True the rest of the ramp
        is replaced by zeros (after the two blocks already queued), e.g. a third Ctrl-C.

    Examples
    --------
    Half a second of a 0.2 V sine at 60 Hz on the simulated rig, with the rig file's limits:

    >>> from rigtools.config import load_rig
    >>> from rigtools.drivers.safety import SineDrive
    >>> from rigtools.procedures.rig import configure, open_device, safety_monitor
    >>> cfg = load_rig()
    >>> device = open_device(cfg, "sim", seed=1)
    >>> rate = configure(device, cfg)
    >>> rate  # samples per second, as the device runs it
    51200.0
    >>> drive = SineDrive(rate, 60.0, max_drive=cfg.safety.max_drive, ramp_time=0.05)
    >>> drive.set_target(0.2)
    >>> sink = BlockCollector()
    >>> with BlockStream(device, drive, sink=sink, safety=safety_monitor(cfg, device)) as stream:
    ...     while stream.stats.duration < 0.5:
    ...         block = stream.read()      # (channels, samples), also given to the sink
    ...     stats = stream.finish()
    >>> [channel.name for channel in device.input_channels], block.shape[0]
    (['force', 'active_shroud_accel', 'passive_shroud_accel'], 3)
    >>> sink.data.shape[1] == stats.samples, stats.duration >= 0.5, stats.warnings
    (True, True, [])
    """

    def __init__(
        self,
        device: AcquisitionDevice,
        drive: Drive,
        *,
        sink: Sink | None = None,
        safety: SafetyMonitor | None = None,
        record_drive: bool = False,
        on_block: Callable[[np.ndarray, StreamStats], None] | None = None,
        abort_ramp_time: float | None = None,
        hurry: Callable[[], bool] | None = None,
    ) -> None:
        self.device = device
        self.hurry = hurry
        self.abort_ramp_time = abort_ramp_time
        self.drive = drive
        self.sink = sink
        self.safety = safety
        self.record_drive = record_drive
        self.on_block = on_block
        self.n = stream_piece(device)
        self.stats = StreamStats(device.sample_rate)
        self._played: deque[np.ndarray] = deque()  # drive blocks written, not yet read
        self._pending: deque[np.ndarray] = deque()  # drive samples queued by finish()
        self._started = False
        self._finished = False

    # ------------------------------------------------------------------ life cycle

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc is not None:
            if not isinstance(exc, AcquisitionAborted):
                self._abort(exc)  # raises AcquisitionAborted, or re-raises Ctrl-C
            return
        if not self._finished:
            self.finish()

    def start(self) -> None:
        """Prime two drive blocks and start the device."""
        if self._started:
            return
        try:
            self._write(self._next_drive())
            self._write(self._next_drive())
            self.device.start()
        except BaseException as exc:  # noqa: BLE001 - _abort stops the device and re-raises
            self._abort(exc)
        self._started = True

    def _next_drive(self) -> np.ndarray:
        if self._pending:
            return self._pending.popleft()
        block = np.asarray(self.drive.next_block(self.n), dtype=float)
        if block.size != self.n:
            raise ValueError(f"drive returned {block.size} samples, expected {self.n}")
        return block

    def _write(self, block: np.ndarray) -> None:
        self.device.write(block)
        self._played.append(block)

    def read(self) -> np.ndarray:
        """Read one block, store it, check it, write the next drive block; returns the block.

        Raises
        ------
        AcquisitionAborted
            On any error, after the device has stopped (drive at zero).
        """
        if not self._started:
            self.start()
        try:
            block = self.device.read(self.n)
        except BaseException as exc:  # noqa: BLE001 - _abort stops the device and re-raises
            self._abort(exc, from_device=True)
        try:
            played = self._played.popleft()
            self._store(block, played)
            if self.safety is not None:
                try:
                    self.stats.warnings.extend(self.safety.check(block, played))
                except SafetyAbort as exc:
                    self._safety_ramp(exc)
            self._write(self._next_drive())
            if self.on_block is not None:
                self.on_block(block, self.stats)
        except BaseException as exc:  # noqa: BLE001 - _abort stops the device and re-raises
            self._abort(exc)
        return block

    def _store(self, block: np.ndarray, played: np.ndarray) -> None:
        if self.sink is not None and block.shape[1]:
            out = np.vstack([block, played[None, : block.shape[1]]]) if self.record_drive else block
            self.sink.append(out)
        self.stats.blocks += 1
        self.stats.samples += block.shape[1]

    def finish(self, ramp_time: float | None = None) -> StreamStats:
        """Ramp the drive down (the drive's own ramp, or over ``ramp_time`` s), read the blocks
        that carry the ramp (they reach the sink: a recording shows the drive ending at 0 V),
        stop the device."""
        if self._finished:
            return self.stats
        ramp = np.asarray(
            self.drive.stop_block() if ramp_time is None else self.drive.stop_block(ramp_time), dtype=float
        )
        delay = self.device.input_to_output_delay() * self.device.sample_rate
        # the ramp, then zeros: the two blocks already queued + the ramp + the delay, whole blocks
        tail = np.concatenate([ramp, np.zeros(math.ceil(delay))])
        n_blocks = math.ceil(tail.size / self.n)
        tail = np.concatenate([tail, np.zeros(n_blocks * self.n - tail.size)])
        self._pending.extend(tail.reshape(n_blocks, self.n))
        # after the tail, zeros keep the output fed until the last read
        remaining, cut = 2 + n_blocks, False
        while remaining > 0:
            if not cut and self.hurry is not None and self.hurry():
                # cut the ramp short: zeros from now on; three reads bring the two blocks
                # already queued back and record a zero block, so the record ends at zero
                cut = True
                self._pending.clear()
                remaining = min(remaining, 3)
            if not self._pending:
                self._pending.append(np.zeros(self.n))
            self.read()
            remaining -= 1
        self._finished = True
        self.device.stop()
        return self.stats

    def _safety_ramp(self, exc: SafetyAbort) -> None:
        """A safety limit was crossed on good samples: ramp the drive to zero over the device's
        abort ramp while still reading, so the record shows the peak and the ramp; then raise."""
        if self.abort_ramp_time is not None and not self._pending:
            self.safety = None
            try:
                self.finish(ramp_time=self.abort_ramp_time)
            except BaseException:  # noqa: BLE001, S110 - the device failed meanwhile: _abort stopped it; the abort follows
                pass
        raise exc

    def _abort(self, exc: BaseException, from_device: bool = False) -> NoReturn:
        """Stop the device (drive to zero), keep what was read, re-raise as AcquisitionAborted.

        A fault raised by the device's read carries the samples of the failed block read before
        it (``partial``); they are stored too.
        """
        self._finished = True
        try:
            self.device.stop()
        finally:
            if (
                from_device
                and isinstance(exc, DaqFault)
                and exc.partial is not None
                and self.sink is not None
            ):
                partial = np.asarray(exc.partial)
                if partial.ndim == 2 and partial.shape[1]:
                    played = self._played[0] if self._played else np.zeros(partial.shape[1])
                    self._store(partial, played)
        if not isinstance(exc, Exception):  # Ctrl-C, SystemExit: stopped safely, pass on
            raise exc
        if isinstance(exc, AcquisitionAborted):
            raise exc
        fault = exc.fault if isinstance(exc, DriverError) else type(exc).__name__
        t = self.stats.samples / self.stats.sample_rate
        # a failed write (disk full) keeps what was flushed before it, not every sample read: the
        # writer's own sentence says so; the count read would claim samples the file never got
        if isinstance(exc, FaultError) and "everything flushed before is kept" in str(exc):
            kept = ""
        elif not getattr(self.sink, "records_every_sample", True):
            # a sink that records only some of what it reads (the CBC's points): no sample count
            kept = "; the points recorded before are kept"
        else:
            kept = f"; {self.stats.samples} samples per channel ({t:.3f} s) kept"
        raise AcquisitionAborted(
            f"acquisition aborted at t = {t:.3f} s: {one_line(exc, first=True)}; drive brought to zero{kept}",
            fault=fault,
            cause=exc,
            samples_kept=self.stats.samples,
            time=t,
        ) from exc


def acquire(
    device: AcquisitionDevice,
    drive: Drive,
    duration: float,
    *,
    sink: Sink | None = None,
    safety: SafetyMonitor | None = None,
    record_drive: bool = False,
    on_block: Callable[[np.ndarray, StreamStats], None] | None = None,
) -> StreamStats:
    """Stream ``drive`` for ``duration`` seconds (whole blocks), then ramp down and stop.

    The drive's amplitude ramps are its own (set its target before calling). Returns the
    stream's statistics; the data went to ``sink``.
    """
    if not duration > 0:
        raise ValueError(f"duration {duration!r} s must be > 0")
    n_blocks = max(1, math.ceil(duration * device.sample_rate / stream_piece(device) - 1e-9))
    with BlockStream(
        device, drive, sink=sink, safety=safety, record_drive=record_drive, on_block=on_block
    ) as stream:
        for _ in range(n_blocks):
            stream.read()
        return stream.finish()


class BlockCollector:
    """A sink that keeps blocks in memory: ``.data`` is ``(n_channels, n_samples)``."""

    def __init__(self) -> None:
        self.blocks: list[np.ndarray] = []

    def append(self, block: np.ndarray) -> None:
        self.blocks.append(np.array(block, dtype=float, copy=True))

    @property
    def data(self) -> np.ndarray:
        return np.concatenate(self.blocks, axis=1) if self.blocks else np.zeros((0, 0))
