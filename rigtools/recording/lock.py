"""One writer per recording: an operating-system lock held for the writer's whole life.

The writer opens HDF5 without HDF5's own file locking (so readers never block it) and closes and
reopens the file between points, so neither HDF5's lock nor a lock on the recording's own file
descriptor would last. Instead the writer holds an exclusive lock on a small lock file beside the
recording, ``.<name>.lock`` (``run.h5`` -> ``.run.h5.lock``), taken before anything creates or
truncates the recording and released when the writer closes. The lock is the kernel's
(``flock`` on POSIX, ``msvcrt.locking`` on Windows): it vanishes with the process, SIGKILL
included, so a crashed run never blocks the next one; a leftover lock file is harmless. The lock
file holds the writer's process id, host and start time as one line of text, for messages only.

Readers never take the lock for longer than a probe (:func:`writer_alive`), and the writer
retries a busy lock for :data:`ACQUIRE_WAIT_S` so a probing reader cannot make it fail.

A process may hold the lock before any writer exists, to read the file it is about to continue
(``rig acquire study --resume``): such a lock is taken with ``writing=False`` and, until a
:class:`~rigtools.recording.RecordingWriter` adopts it, :func:`writer_alive` in that process
answers that nobody writes the file (so its readers treat a killed writer's file as one, not as
a live writer's file in the middle of a change).
"""

from __future__ import annotations

import contextlib
import errno
import os
import socket
import sys
import time
from pathlib import Path

from rigtools.recording.schema import utc_now

ACQUIRE_WAIT_S = 0.25

if sys.platform == "win32":  # pragma: no cover - exercised on Windows only
    import msvcrt

    def _try_lock(fd: int, exclusive: bool) -> bool:
        os.lseek(fd, 0, os.SEEK_SET)
        try:
            msvcrt.locking(fd, msvcrt.LK_NBLCK if exclusive else msvcrt.LK_NBRLCK, 1)
        except OSError:
            return False
        return True

    def _unlock(fd: int) -> None:
        os.lseek(fd, 0, os.SEEK_SET)
        try:
            msvcrt.locking(fd, msvcrt.LK_UNLCK, 1)
        except OSError:
            pass
else:
    import fcntl

    def _try_lock(fd: int, exclusive: bool) -> bool:
        try:
            fcntl.flock(fd, (fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH) | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                return False
            raise
        return True

    def _unlock(fd: int) -> None:
        fcntl.flock(fd, fcntl.LOCK_UN)


#: the locks this process holds, by lock file (absolute path)
_HELD_HERE: dict[str, WriterLock] = {}


class LockBusy(Exception):
    """Another live process (or another writer in this process) writes the recording."""

    def __init__(self, holder: str):
        super().__init__(holder)
        self.holder = holder


def lock_path(path: str | os.PathLike) -> Path:
    """The lock file of recording ``path``: ``.<name>.lock`` in the same folder."""
    p = Path(path)
    return p.with_name(f".{p.name}.lock")


def _holder(lock: Path) -> str:
    try:
        text = lock.read_text(encoding="utf-8", errors="replace").strip()
    except OSError:
        return "another process"
    return text.splitlines()[0] if text else "another process"


class WriterLock:
    """The exclusive lock of one recording, held from :meth:`acquire` until :meth:`release`.

    Raises
    ------
    LockBusy
        From :meth:`acquire` when a live writer holds it (``holder`` describes that writer).
    OSError
        If the lock file cannot be created (e.g. a read-only folder).
    """

    def __init__(self, path: str | os.PathLike, *, writing: bool = True):
        self.path = lock_path(path)
        self._fd: int | None = None
        #: False while the holder only reads the recording (no writer has adopted the lock yet)
        self.writing = writing

    def acquire(self) -> None:
        deadline = time.monotonic() + ACQUIRE_WAIT_S
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                locked = _try_lock(fd, exclusive=True)
                # The file may have been unlinked by a releasing writer between open and lock:
                # then we hold a lock nobody else can see; start over on the new file.
                if locked and self._same_file(fd):
                    self._fd = fd
                    self._write_holder(fd)
                    _HELD_HERE[os.path.abspath(self.path)] = self
                    return
            except BaseException:
                os.close(fd)
                raise
            os.close(fd)
            if not locked and time.monotonic() >= deadline:
                raise LockBusy(_holder(self.path))
            time.sleep(0.02 if not locked else 0)

    def _same_file(self, fd: int) -> bool:
        if sys.platform == "win32":  # pragma: no cover - a locked file cannot be deleted there
            return True
        try:
            st = os.stat(self.path)
        except FileNotFoundError:
            return False
        fst = os.fstat(fd)
        return (st.st_dev, st.st_ino) == (fst.st_dev, fst.st_ino)

    def _write_holder(self, fd: int) -> None:
        text = f"pid {os.getpid()} on {socket.gethostname()} since {utc_now()}\n".encode()
        try:
            if sys.platform == "win32":  # pragma: no cover - byte 0 is the locked byte
                return
            os.ftruncate(fd, 0)
            os.pwrite(fd, text, 0)
        except OSError:
            pass  # the text is for messages only; a full disk must not stop the lock

    @property
    def held(self) -> bool:
        return self._fd is not None

    def release(self) -> None:
        """Remove the lock file and drop the lock (idempotent)."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        if _HELD_HERE.get(os.path.abspath(self.path)) is self:
            del _HELD_HERE[os.path.abspath(self.path)]
        if sys.platform != "win32":
            try:
                self.path.unlink()  # while still locked: see acquire()
            except OSError:
                pass
        try:
            _unlock(fd)
        finally:
            os.close(fd)
        if sys.platform == "win32":  # pragma: no cover
            try:
                self.path.unlink()
            except OSError:
                pass

    def __del__(self) -> None:
        with contextlib.suppress(Exception):  # a finaliser must not raise
            self.release()


def writer_alive(path: str | os.PathLike) -> str | None:
    """Who writes recording ``path`` now (e.g. ``"pid 4242 on labpc since ..."``), or None.

    A brief shared-lock probe of the lock file; a missing or unlocked lock file means no writer,
    and so does a lock this process holds with ``writing=False`` (it only reads the file).
    """
    lock = lock_path(path)
    own = _HELD_HERE.get(os.path.abspath(lock))
    if own is not None and own.held and not own.writing:
        return None
    try:
        fd = os.open(lock, os.O_RDONLY if sys.platform != "win32" else os.O_RDWR)
    except OSError:
        return None
    try:
        if _try_lock(fd, exclusive=False):
            _unlock(fd)
            return None
        return _holder(lock)
    except OSError:
        return None
    finally:
        os.close(fd)
