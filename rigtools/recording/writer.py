"""Streaming writer for recordings (schema v1), crash-safe through HDF5 SWMR.

HDF5's single-writer/multiple-reader (SWMR) mode lets readers follow a file while it grows and
keeps the file readable if the writer dies, but a file in SWMR-write mode cannot get new groups,
datasets or attributes. The writer therefore works in phases:

1. structure (plain write mode): the file, or a new point's group, datasets and attributes, are
   created and flushed;
2. streaming (SWMR mode): blocks are appended to the point's datasets; the file is flushed at
   least every ``flush_interval`` seconds of wall time (checked on every append), and on
   :meth:`PointWriter.end`;
3. at the end of a point and of the run the file is closed and reopened in plain write mode for
   a few milliseconds to set end-of-point parameters and the final ``status``, then left in SWMR
   mode again until the next point.

So the file rests in SWMR mode whenever no structure is being added. A killed writer leaves a
file that HDF5 opens in SWMR-read mode (``h5py.File(path, "r", swmr=True)``;
:func:`rigtools.recording.open_recording` does this by itself) with everything up to the last
flush intact. The writer opens files without HDF5 file locking so that a reader holding the file
open never blocks the reopen between points; it refuses to replace an existing file unless
``overwrite=True``.

Two writers never share a file: the writer holds an OS lock on ``.<name>.lock`` beside the
recording for its whole life (:mod:`.lock`), taken before the file is created or truncated; a
second writer is refused with :class:`RecordingError`, ``overwrite=True`` included.

Write errors (disk full, quota, file too large) end in :class:`RecordingWriteError`. HDF5 does
not recover from a failed write (closing such a file can crash the process), so the writer keeps
it from meeting one: before each append and each structural change it makes sure the file has
enough space reserved beyond HDF5's end (``posix_fallocate``; ``ftruncate`` where that does not
exist), plus a final reserve for ending the run. When the reservation fails, HDF5 has not failed
yet: the writer marks the file ``aborted`` with the error inside the final reserve, closes it
normally (HDF5 trims the file to its real end) and raises. Should a write error still reach HDF5
(e.g. a copy-on-write file system), the writer drops the file without closing it in this
process; what was flushed before stays readable.

Files use the HDF5 1.10 object format (``libver=("v110", "v110")``), which SWMR needs; HDF5 1.10
or newer reads them (h5dump 1.10+, MATLAB R2021b+).

Compressed channels (the default) keep HDF5's standard shuffle + deflate filters in the file, but
HDF5 would run them on the caller's thread, one chunk after another. The writer instead
shuffles and deflates full chunks itself on a small thread pool (zlib releases the GIL) and
stores the finished bytes with ``write_direct_chunk``; any HDF5 reader decompresses them with
its own filters. Only the partial last chunk of a channel goes through HDF5's own write, at each
flush and at the end of a point; the full chunk written later replaces it.
"""

from __future__ import annotations

import contextlib
import errno as errno_codes
import json
import math
import os
import re
import time
import warnings
import zlib
from collections import deque
from collections.abc import Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Any

import h5py
import numpy as np

import rigtools
from rigtools.errors import one_line, option
from rigtools.json_values import json_default
from rigtools.recording.lock import LockBusy, WriterLock, lock_path
from rigtools.recording.schema import (
    POINTS_GROUP,
    SCHEMA_NAME,
    SCHEMA_VERSION,
    STATUS_ABORTED,
    STATUS_COMPLETE,
    STATUS_RECORDING,
    ChannelSpec,
    RecordingError,
    RecordingWriteError,
    parameter_value,
    point_name,
    utc_now,
)

if TYPE_CHECKING:
    from typing import Self

LIBVER = ("v110", "v110")
DEFAULT_CHUNK_SAMPLES = 16384  # 128 KiB of float64 per chunk: ~0.3 s at 51.2 kS/s
COMPRESSIONS = ("gzip", "none")
DEFLATE_THREADS = 2
MAX_PENDING_CHUNKS = 8  # full chunks (all channels) queued before append waits
RESERVE_STEP = 16 << 20  # grow the reserved space beyond HDF5's end in 16 MiB steps
BASE_RESERVE = 1 << 20  # kept free beyond HDF5's end for metadata and the final status
_HDF5_ERRNO = re.compile(r"errno = (\d+), error message = '([^']*)'")

# h5py files that met a write error: never closed in this process (HDF5 may crash closing them).
_ABANDONED: list[Any] = []


def _os_error_text(exc: BaseException) -> str:
    """The operating-system error inside an exception, e.g. ``"[Errno 28] No space left on device"``."""
    number = getattr(exc, "errno", None)
    if isinstance(number, int) and number:
        return f"[Errno {number}] {os.strerror(number)}"
    match = _HDF5_ERRNO.search(str(exc))
    if match:
        return f"[Errno {match.group(1)}] {match.group(2)}"
    return one_line(exc, 200, typed=True)


def _preallocate(fd: int, offset: int, length: int) -> None:
    """Reserve ``length`` bytes of disk at ``offset`` (the file grows), or raise OSError."""
    if hasattr(os, "posix_fallocate"):
        try:
            os.posix_fallocate(fd, offset, length)
            return
        except OSError as exc:
            if exc.errno not in (
                errno_codes.EOPNOTSUPP,
                errno_codes.EINVAL,
                getattr(errno_codes, "ENOTSUP", errno_codes.EOPNOTSUPP),
            ):
                raise
    os.ftruncate(fd, offset + length)


def _rig_text(rig: Any) -> str:
    if isinstance(rig, str):
        return rig
    if hasattr(rig, "to_json"):
        return rig.to_json()
    if isinstance(rig, Mapping):
        return json.dumps(rig, indent=1, default=json_default, allow_nan=False)
    raise TypeError("rig must be TOML or JSON text (or an object with to_json())")


def _shuffle_deflate(chunk: np.ndarray, level: int) -> bytes:
    """One full float64 chunk as HDF5's shuffle + deflate filters store it.

    Shuffle with an 8-byte element is the chunk's bytes transposed from (n, 8) to (8, n);
    deflate stores a zlib stream. Runs on a worker thread (zlib releases the GIL).
    """
    shuffled = chunk.astype("<f8", copy=False).view(np.uint8).reshape(-1, 8).T.tobytes()
    return zlib.compress(shuffled, level)


class _DeflatedChunks:
    """Full chunks of a point's channels compressed off the caller's thread, written directly.

    Samples collect in ``tail`` (one chunk per channel); a full tail is handed to the thread pool
    and its compressed bytes are written with ``write_direct_chunk`` in order, as they become
    ready, at most ``MAX_PENDING_CHUNKS`` behind. :meth:`sync` writes everything appended,
    the partial tail through HDF5's own (filtered) write.
    """

    def __init__(self, datasets: list[h5py.Dataset], chunk: int, level: int, pool: ThreadPoolExecutor):
        self._datasets = datasets
        self._chunk = chunk
        self._level = level
        self._pool = pool
        self._tail = np.empty((len(datasets), chunk))
        self._tail_start = 0  # sample index of tail[:, 0]; a multiple of chunk
        self._tail_n = 0  # samples in the tail
        self._pending: deque[tuple[int, list[Future]]] = deque()

    def add(self, data: np.ndarray) -> None:
        pos, n = 0, data.shape[1]
        while pos < n:
            take = min(self._chunk - self._tail_n, n - pos)
            self._tail[:, self._tail_n : self._tail_n + take] = data[:, pos : pos + take]
            self._tail_n += take
            pos += take
            if self._tail_n == self._chunk:
                futures = [self._pool.submit(_shuffle_deflate, row, self._level) for row in self._tail]
                self._pending.append((self._tail_start, futures))
                self._tail = np.empty_like(self._tail)
                self._tail_start += self._chunk
                self._tail_n = 0
        self._write_ready(wait=False)

    def _write_ready(self, wait: bool) -> None:
        """Write compressed chunks from the head of the queue: the finished ones, or all if ``wait``."""
        while self._pending:
            offset, futures = self._pending[0]
            if not (wait or len(self._pending) > MAX_PENDING_CHUNKS or all(f.done() for f in futures)):
                return
            self._pending.popleft()
            for dataset, future in zip(self._datasets, futures, strict=True):
                dataset.id.write_direct_chunk((offset,), future.result(), filter_mask=0)

    def sync(self) -> None:
        """Write every sample appended so far into the file (before an HDF5 flush)."""
        self._write_ready(wait=True)
        if self._tail_n:
            memspace = h5py.h5s.create_simple((self._tail_n,))
            for dataset, row in zip(self._datasets, self._tail, strict=True):
                filespace = dataset.id.get_space()
                filespace.select_hyperslab((self._tail_start,), (self._tail_n,))
                dataset.id.write(memspace, filespace, np.ascontiguousarray(row[: self._tail_n]))


class PointWriter:
    """One steady-state point being recorded; made by :meth:`RecordingWriter.begin_point`.

    Attributes
    ----------
    index : int
        Point number (group ``/points/{index:04d}``).
    channels : tuple of ChannelSpec
        Channel order of the blocks given to :meth:`append`.
    n_samples : int
        Samples per channel appended so far.
    flushed_samples : int
        Samples per channel known to be on disk (as of the last flush).
    """

    def __init__(
        self,
        writer: RecordingWriter,
        index: int,
        channels: tuple[ChannelSpec, ...],
        datasets: list[h5py.Dataset],
        deflated: _DeflatedChunks | None = None,
    ):
        self._writer = writer
        self.index = index
        self.name = point_name(index)
        self.channels = channels
        self._datasets = datasets
        self._deflated = deflated
        self._pending: dict[str, Any] = {}
        self.n_samples = 0
        self.flushed_samples = 0
        self.ended = False

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if not self.ended and exc_type is None:
            self.end()

    def append(self, block: np.ndarray | Sequence) -> None:
        """Append a block of samples.

        Parameters
        ----------
        block : array_like, shape (n_channels, n_samples)
            Samples in the order of :attr:`channels`, any number of samples (a whole simulated
            run at once is fine). A 1-D array is accepted when the point has one channel.
        """
        if self.ended:
            raise RuntimeError(f"point {self.name} has ended; begin a new point")
        data = np.asarray(block, dtype=np.float64)
        if data.ndim == 1 and len(self.channels) == 1:
            data = data[np.newaxis, :]
        if data.ndim != 2 or data.shape[0] != len(self.channels):
            raise ValueError(
                f"block of shape {data.shape}: expected ({len(self.channels)}, n_samples)"
                f" for channels {[c.name for c in self.channels]}"
            )
        n = data.shape[1]
        if n == 0:
            return
        writer = self._writer
        writer._check_open()
        writer._ensure_space(data.nbytes, "appending samples")
        start, stop = self.n_samples, self.n_samples + n
        with writer._hdf5("appending samples"):
            for dataset in self._datasets:
                dataset.resize((stop,))
            if self._deflated is not None:
                self._deflated.add(data)
            else:
                memspace = h5py.h5s.create_simple((n,))
                for dataset, row in zip(self._datasets, data, strict=True):
                    filespace = dataset.id.get_space()
                    filespace.select_hyperslab((start,), (n,))
                    dataset.id.write(memspace, filespace, np.ascontiguousarray(row))
        self.n_samples = stop
        writer._unflushed += data.nbytes
        writer._maybe_flush()

    def set_attrs(self, **params: Any) -> None:
        """Set point parameters known only at the end (``settled=True``, ``force_amplitude_measured=14.8``).

        They are written when the point ends (SWMR mode allows no new attributes while
        streaming). If the writer is killed before :meth:`end` they are lost and the point reads
        as incomplete (``end_time`` empty, :attr:`rigtools.recording.Point.complete` False).
        """
        if self.ended:
            raise RuntimeError(f"point {self.name} has ended")
        for key, value in params.items():
            self._pending[key] = parameter_value(key, value)

    def end(self) -> None:
        """Flush the samples, write pending parameters and the end time; the point is then closed."""
        if self.ended:
            return
        self._writer._end_point(self)

    def _sync(self) -> None:
        if self._deflated is not None:
            self._deflated.sync()


class RecordingWriter:
    """Write one recording (schema v1), streaming blocks point by point.

    Parameters
    ----------
    path : str or Path
        File to create. Its directory must exist.
    backend : str
        ``"nidaqmx"``, ``"simulated"``, ``"fem"`` or the name of an import source.
    rig : str
        The full rig description, TOML or JSON text (a ``RigConfig`` is turned into JSON).
    experiment : dict, optional
        JSON-able description of the experiment (procedure, sweep, operator, notes...).
    overwrite : bool
        Replace an existing file. Without it an existing file raises :class:`RecordingError`.
    compression : {"gzip", "none"}
        ``"gzip"`` (default): HDF5's shuffle + deflate filters, which every HDF5 build has.
        ``"none"``: chunked but uncompressed, the fastest (see ``benchmarks/bench_recording_writer.py``).
    compression_level : int
        Deflate level 1..9 (default 1: fastest; higher levels gain little on sensor noise).
    chunk_samples : int
        Samples per HDF5 chunk of each channel.
    flush_interval : float
        Flush to disk when at least this many seconds passed since the last flush (checked on
        every append; default 0.5 s, so data older than about 0.5 s plus one block is on disk).
    lock : WriterLock, optional
        The lock of ``path``, already held by the caller (who took it before changing files
        there, e.g. ``rig acquire study --resume``): the writer adopts it and releases it on close.

    Examples
    --------
    One point of 0.1 s of a 15 N force at 60 Hz, streamed in five blocks, then read back:

    >>> import numpy as np
    >>> from rigtools.config import load_rig
    >>> from rigtools.recording import ChannelSpec, RecordingWriter, open_recording
    >>> rate = 51200.0
    >>> force = 15.0 * np.sin(2 * np.pi * 60.0 * np.arange(5120) / rate)
    >>> with RecordingWriter("run.h5", backend="simulated", rig=load_rig(),
    ...                      experiment={"procedure": "dwell"}, overwrite=True) as rec:
    ...     point = rec.begin_point(params={"fe": 60.0, "force_amplitude": 15.0, "gap": 5e-4},
    ...                             channels=[ChannelSpec("force", "N", "force", rate)])
    ...     for block in np.split(force, 5):
    ...         point.append(block)
    ...     point.set_attrs(settled=True)
    ...     point.end()
    >>> with open_recording("run.h5") as run:
    ...     print(run.status, run.points[0].n_samples, run.points[0].params["settled"])
    complete 5120 True
    """

    def __init__(
        self,
        path: str | os.PathLike,
        backend: str,
        rig: Any,
        experiment: Mapping[str, Any] | None = None,
        *,
        overwrite: bool = False,
        compression: str = "gzip",
        compression_level: int = 1,
        chunk_samples: int = DEFAULT_CHUNK_SAMPLES,
        flush_interval: float = 0.5,
        lock: WriterLock | None = None,
    ):
        if not isinstance(backend, str) or not backend.strip():
            raise ValueError("backend must be non-empty text, e.g. 'simulated'")
        if compression not in COMPRESSIONS:
            raise ValueError(f"compression {compression!r}: use one of {COMPRESSIONS}")
        if not 1 <= int(compression_level) <= 9:
            raise ValueError(f"compression_level {compression_level}: use 1..9")
        if int(chunk_samples) < 1:
            raise ValueError("chunk_samples must be >= 1")
        if not (math.isfinite(flush_interval) and flush_interval >= 0):
            raise ValueError("flush_interval must be >= 0 s")
        rig_text = _rig_text(rig)
        experiment_text = json.dumps(dict(experiment or {}), default=json_default, allow_nan=False)
        self.path = Path(path)
        self.backend = backend
        self.status = STATUS_RECORDING
        self._compression = compression
        self._level = int(compression_level)
        self._chunk = int(chunk_samples)
        self._flush_interval = float(flush_interval)
        self._point: PointWriter | None = None
        self._n_points = 0
        self._closed = False
        self._pool: ThreadPoolExecutor | None = None
        self._fd: int | None = None
        self._final_reserve = BASE_RESERVE
        self._unflushed = 0  # bytes appended since the last flush (HDF5 may cache them)
        adopted = lock is not None and lock.held and lock.path == lock_path(self.path)
        self._lock = lock if lock is not None and adopted else WriterLock(self.path)
        self._lock.writing = True

        if not self.path.parent.is_dir():
            raise RecordingError(f"cannot create {self.path}: directory {self.path.parent} does not exist")
        if self.path.is_dir():
            raise RecordingError(f"cannot create {self.path}: it is a directory")
        try:
            if not adopted:
                self._lock.acquire()  # before anything creates or truncates the file
        except LockBusy as busy:
            raise RecordingError(
                f"{self.path} is being written by another run ({busy.holder}); two runs cannot write one file"
            ) from None
        except OSError as exc:
            raise RecordingError(
                f"cannot create {self.path}: cannot create its lock file "
                f"{self._lock.path.name} ({_os_error_text(exc)})"
            ) from None
        try:
            self._create(overwrite, backend, rig_text, experiment_text)
        except BaseException:
            if self._fd is not None:
                os.close(self._fd)
                self._fd = None
                with contextlib.suppress(OSError):
                    self.path.unlink()  # a half-made file we created: not a recording
            self._lock.release()
            raise

    def _create(self, overwrite: bool, backend: str, rig_text: str, experiment_text: str) -> None:
        if self.path.exists() and not overwrite:
            raise RecordingError(f"{self.path} exists; give {option('overwrite', True)} to replace it")
        try:
            self._file = h5py.File(self.path, "w" if overwrite else "w-", libver=LIBVER, locking=False)
        except (FileExistsError, OSError) as exc:
            number = getattr(exc, "errno", None) or 0
            if number in (
                errno_codes.ENOSPC,
                errno_codes.EFBIG,
                getattr(errno_codes, "EDQUOT", -1),
                errno_codes.EIO,
            ):
                raise RecordingWriteError(f"cannot create {self.path}: {_os_error_text(exc)}") from None
            raise RecordingError(f"cannot create {self.path}: {exc}") from None
        try:
            self._fd = os.open(self.path, os.O_RDWR)
            self._ensure_space(0, "creating the file", fail_clean=False)
        except BaseException:
            self._file.close()
            raise
        attrs = self._file.attrs
        attrs["schema"] = SCHEMA_NAME
        attrs["schema_version"] = np.int64(SCHEMA_VERSION)
        attrs["created"] = utc_now()
        attrs["software_version"] = rigtools.__version__
        attrs["backend"] = backend
        attrs["status"] = STATUS_RECORDING
        attrs["abort_reason"] = ""
        attrs["ended"] = ""
        attrs["rig"] = rig_text
        attrs["experiment"] = experiment_text
        self._file.create_group(POINTS_GROUP, track_order=True)
        with self._hdf5("creating the file"):
            self._start_swmr()

    # -- context manager ---------------------------------------------------------------------
    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc is None:
            self.close()
        else:
            try:
                self.abort(one_line(exc, typed=True))
            except Exception as secondary:  # noqa: BLE001 - warned: never hide the original exception
                warnings.warn(
                    f"could not mark {self.path} as aborted: {one_line(secondary, typed=True)}",
                    RuntimeWarning,
                    stacklevel=2,
                )

    # -- points ------------------------------------------------------------------------------
    @property
    def n_points(self) -> int:
        """Number of points begun so far."""
        return self._n_points

    def begin_point(
        self, params: Mapping[str, Any] | None = None, channels: Sequence[ChannelSpec] = ()
    ) -> PointWriter:
        """Start point ``/points/NNNN`` with its parameters and channels; returns its writer.

        Parameters
        ----------
        params : dict
            Point parameters, SI: ``fe`` (Hz), ``force_amplitude`` (N), ``gap`` (m), ... Values
            are text, numbers, bools or 1-D numeric lists.
        channels : sequence of ChannelSpec
            The channels in block order; unique names, one common sample rate.
        """
        self._check_open()
        if self._point is not None and not self._point.ended:
            raise RuntimeError(f"point {self._point.name} is still open; call its end() first")
        channels = tuple(channels)
        if not channels:
            raise ValueError("a point needs at least one ChannelSpec")
        for spec in channels:
            if not isinstance(spec, ChannelSpec):
                raise TypeError(f"channels must be ChannelSpec objects, got {type(spec).__name__}")
        names = [c.name for c in channels]
        if len(set(names)) != len(names):
            raise ValueError(f"channel names repeat: {names}")
        rates = {float(c.sample_rate) for c in channels}
        if len(rates) != 1:
            raise ValueError(f"all channels of a point share one sample rate, got {sorted(rates)}")
        values = {key: parameter_value(key, value) for key, value in dict(params or {}).items()}

        index = self._n_points
        # the partial last chunk of every channel is rewritten at each flush
        self._final_reserve = max(self._final_reserve, BASE_RESERVE + 2 * len(channels) * self._chunk * 8)
        what = f"adding point {point_name(index)}"
        self._reopen_plain(what)
        self._ensure_space(65536 + 16384 * len(channels), what)
        with self._hdf5(what):
            group = self._file[POINTS_GROUP].create_group(point_name(index), track_order=True)
            group.attrs["start_time"] = utc_now()
            group.attrs["end_time"] = ""
            for key, value in values.items():
                group.attrs[key] = value
            filters: dict[str, Any] = {}
            if self._compression == "gzip":
                filters = {"compression": "gzip", "compression_opts": self._level, "shuffle": True}
            datasets = []
            for spec in channels:
                dataset = group.create_dataset(
                    spec.name,
                    shape=(0,),
                    maxshape=(None,),
                    dtype="<f8",
                    chunks=(self._chunk,),
                    fillvalue=np.nan,
                    **filters,
                )
                for key, value in spec.attrs().items():
                    dataset.attrs[key] = value
                datasets.append(dataset)
            self._start_swmr()
        deflated = None
        if self._compression == "gzip":
            if self._pool is None:
                self._pool = ThreadPoolExecutor(DEFLATE_THREADS, thread_name_prefix="rigtools-deflate")
            deflated = _DeflatedChunks(datasets, self._chunk, self._level, self._pool)
        self._n_points += 1
        self._point = PointWriter(self, index, channels, datasets, deflated)
        return self._point

    def _end_point(self, point: PointWriter) -> None:
        self._check_open()
        what = f"ending point {point.name}"
        self._ensure_space(0, what)
        with self._hdf5(what):
            point._sync()
            self._file.flush()
        self._unflushed = 0
        point.flushed_samples = point.n_samples
        self._reopen_plain(what)
        self._ensure_space(65536, what)
        with self._hdf5(what):
            group = self._file[POINTS_GROUP][point.name]
            for key, value in point._pending.items():
                group.attrs[key] = value
            if point._pending:
                self._file.flush()  # parameters on disk before end_time marks the point ended
            group.attrs["end_time"] = utc_now()
            self._start_swmr()
        point.ended = True
        point._datasets = []

    # -- flushing ------------------------------------------------------------------------------
    def flush(self) -> None:
        """Write everything appended so far to disk (HDF5 flush; survives a killed process)."""
        self._check_open()
        self._ensure_space(0, "flushing")
        with self._hdf5("flushing"):
            if self._point is not None and not self._point.ended:
                self._point._sync()
            self._file.flush()
        self._last_flush = time.monotonic()
        self._unflushed = 0
        if self._point is not None:
            self._point.flushed_samples = self._point.n_samples

    def _maybe_flush(self) -> None:
        if time.monotonic() - self._last_flush >= self._flush_interval:
            self.flush()

    # -- ending --------------------------------------------------------------------------------
    def close(self) -> None:
        """End the open point (if any), mark the file ``complete`` and close it."""
        if self._closed:
            return
        if self._point is not None and not self._point.ended:
            self._point.end()
        self._finish(STATUS_COMPLETE, "")

    def abort(self, reason: str) -> None:
        """Keep what was written, mark the file ``aborted`` with a one-line ``reason``, close it."""
        if self._closed:
            return
        reason = " ".join(str(reason).split()) or "aborted"
        try:
            if self._point is not None and not self._point.ended:
                self._point.end()
        finally:
            self._finish(STATUS_ABORTED, reason)

    def _finish(self, status: str, reason: str) -> None:
        if self._closed:
            return
        try:
            self._reopen_plain("ending the run")
            with self._hdf5("ending the run"):
                self._file.attrs["status"] = status
                self._file.attrs["abort_reason"] = reason
                self._file.attrs["ended"] = utc_now()
        finally:
            if not self._closed:
                self._closed = True
                self.status = status
                try:
                    self._file.close()  # HDF5 trims the reserved space here
                finally:
                    self._release()

    def _release(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)
            self._pool = None
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        self._lock.release()

    # -- write errors ----------------------------------------------------------------------------
    @contextlib.contextmanager
    def _hdf5(self, what: str):
        """Turn an OS write error raised inside HDF5 into :class:`RecordingWriteError`."""
        try:
            yield
        except (OSError, RuntimeError) as exc:
            if self._closed:
                raise
            self._write_failed(exc, what, hdf5_failed=True)

    def _ensure_space(self, nbytes: int, what: str, fail_clean: bool = True) -> None:
        """Reserve disk beyond HDF5's end for ``nbytes`` more plus the final reserve."""
        if self._fd is None:
            return
        try:
            size = os.fstat(self._fd).st_size
            end = max(self._file.id.get_filesize(), 0)
            need = end + self._unflushed + int(nbytes) + self._final_reserve
            if size < need:
                try:
                    _preallocate(self._fd, size, max(need - size, RESERVE_STEP))
                except OSError:  # not a whole step left: take just what is needed
                    _preallocate(self._fd, size, need - size)
        except OSError as exc:
            if not fail_clean:
                raise RecordingWriteError(
                    f"cannot write {self.path} ({what}): {_os_error_text(exc)}"
                ) from None
            self._write_failed(exc, what, hdf5_failed=False)

    def _write_failed(self, exc: BaseException, what: str, hdf5_failed: bool) -> None:
        """End the run after a write error and raise :class:`RecordingWriteError`."""
        message = (
            f"cannot write {self.path} ({what}): {_os_error_text(exc)}; everything flushed before is kept"
        )
        point = self._point
        if point is not None:
            point._datasets = []
            point._deflated = None
        if hdf5_failed:
            # HDF5 does not recover from a failed write and may crash closing the file: drop it.
            _ABANDONED.append(self._file)
            self._closed = True
            self.status = STATUS_RECORDING
            self._release()
        else:
            try:
                self._finish(STATUS_ABORTED, f"RecordingWriteError: {message}")
            except (OSError, RuntimeError, RecordingError):
                pass
            message += " (marked aborted)" if self.status == STATUS_ABORTED else ""
        raise RecordingWriteError(message) from None

    # -- file modes ----------------------------------------------------------------------------
    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError(f"recording {self.path} is closed")

    def _start_swmr(self) -> None:
        self._file.flush()
        self._file.swmr_mode = True
        self._last_flush = time.monotonic()

    def _reopen_plain(self, what: str) -> None:
        """Close the SWMR-mode file and reopen it for structural changes (new objects/attributes)."""
        if not self._file.swmr_mode:
            return
        with self._hdf5(what):
            self._file.close()
            self._file = h5py.File(self.path, "r+", libver=LIBVER, locking=False)
