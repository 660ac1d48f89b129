"""Opening a recording's HDF5 file read-only, also one whose writer is running or was killed:
:func:`open_h5`, and :func:`named`, the check of a path before anything asks the file system.

Below both :mod:`rigtools.recording.reader` (:func:`~rigtools.recording.reader.open_recording`)
and :mod:`rigtools.recording.validate` (:func:`~rigtools.recording.validate.check_recording`),
which each open a file this way.
"""

from __future__ import annotations

import os
import re
import time
from pathlib import Path

import h5py

from rigtools.errors import one_line
from rigtools.recording.lock import writer_alive
from rigtools.recording.schema import RecordingError
from rigtools.recording.superblock import FlagClearedFile, consistency_flags

_H5_REASON = re.compile(r"\((.*)\)\s*$", re.DOTALL)
#: HDF5's words for an object beyond the file's recorded end of allocation (a writer killed between
#: writing an object and recording the new end): read with ``open_h5(..., extend_eoa=True)``
PAST_END = re.compile(r"addr overflow|past end of allocation|exceeds EOA")
_TRUNCATED = re.compile(r"truncated file: eof = (\d+),.*stored_eof = (\d+)")


def hdf5_reason(exc: BaseException) -> str:
    """The reason inside an h5py error's last parentheses (its one line if none)."""
    text = one_line(exc, None)
    match = _H5_REASON.search(text)
    return match.group(1) if match else text


def open_h5(path: str | os.PathLike, wait: bool = True, extend_eoa: bool = False) -> tuple[h5py.File, str]:
    """Open any HDF5 file read-only, also one whose writer is running or was killed.

    ``wait=False`` tries once and does not wait for a live writer that is adding structure
    (a follower that looks again soon: :mod:`rigtools.monitor`).

    Returns
    -------
    file : h5py.File
    opened_as : str
        ``"clean"`` (closed normally), ``"swmr"`` (SWMR writer running or killed) or
        ``"flags-cleared"`` (writer killed outside SWMR mode; see :mod:`.superblock`).

    Raises
    ------
    RecordingError
        One line if the file is missing or is not readable HDF5 (e.g. truncated).

    ``extend_eoa``: open through :class:`~.superblock.FlagClearedFile` with the end of
    allocation read as the file's size (a killed writer's objects past it), never modifying it.
    """
    p = Path(path)
    if not p.exists():
        raise RecordingError(f"{p}: no such file")
    if not p.is_file():
        raise RecordingError(f"{p}: not a file")
    if extend_eoa:
        try:
            return h5py.File(FlagClearedFile(p, extend_eoa=True), "r"), "flags-cleared"
        except OSError as exc:
            raise RecordingError(f"{p}: unreadable HDF5 file ({hdf5_reason(exc)})") from None
    last: OSError | None = None
    # A live writer (it holds the lock) adds structure for a few ms at a time: wait for it longer.
    attempts = (40 if writer_alive(p) else 4) if wait else 1
    for attempt in range(attempts):
        try:
            return h5py.File(p, "r"), "clean"
        except OSError as exc:
            last = exc
        if "unable to lock file" in str(last):
            try:
                return h5py.File(p, "r", locking=False), "clean"
            except OSError as exc:
                last = exc
        # A writer stopped by a write error HDF5 saw leaves the file shorter than HDF5's end of
        # allocation with its SWMR flags set; SWMR-read mode reads what is there. (Not tried on a
        # cleanly closed file cut short: HDF5's SWMR reader can retry forever on one.)
        truncated_open = "truncated file" in str(last) and _flags_set(p)
        if "already open for write" not in str(last) and not truncated_open:
            break
        try:
            return h5py.File(p, "r", swmr=True), "swmr"
        except OSError as exc:
            last = exc
        # A live writer adds a point for a few ms in plain write mode: wait, then assume it died.
        if attempt + 1 < attempts:
            time.sleep(min(0.05 * (attempt + 1), 0.2))
    if "already open for write" in str(last) or "not already open for SWMR" in str(last):
        try:
            if consistency_flags(p):
                return h5py.File(FlagClearedFile(p), "r"), "flags-cleared"
        except OSError as exc:
            last = exc
    if isinstance(last, PermissionError):
        raise RecordingError(f"{p}: permission denied") from None
    reason = hdf5_reason(last) if last else "unknown error"
    if "signature not found" in reason:
        raise RecordingError(f"{p}: not an HDF5 file (no HDF5 signature)") from None
    truncated = _TRUNCATED.search(reason)
    if truncated:
        raise RecordingError(
            f"{p}: truncated HDF5 file ({truncated.group(1)} of {truncated.group(2)} bytes present)"
        ) from None
    raise RecordingError(f"{p}: unreadable HDF5 file ({reason})") from None


def _flags_set(path: Path) -> bool:
    try:
        return bool(consistency_flags(path))
    except OSError:
        return False


LIVE_RETRY_S = 3.0  # how long a reader retries a file its live writer is changing


def named(path: str | os.PathLike) -> None:
    """Refuse in one line a path that cannot name a recording: empty, or a name longer than the
    file system allows (before anything asks the file system about it)."""
    text = os.fspath(path)
    if not str(text).strip():
        raise RecordingError("no file name given: give a recording file, e.g. run.h5")
    name = os.path.basename(os.fsencode(text))
    if len(name) > 255:
        raise RecordingError(f"{str(text)[:60]}...: the file name is longer than file systems allow")
