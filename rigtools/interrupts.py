"""Stop requests (Ctrl-C, SIGTERM, SIGHUP) turned into one exception, raised only where it is safe.

Long runs (studies, acquisitions) end on a stop request the way they end on Ctrl-C: what is
finished is kept, the recording is marked ``aborted`` with the reason, and the process exits with
a documented status (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP: 128 + the signal number). A signal that
arrives while a point is being written is held until the write is done (:meth:`StopRequests.protected`),
so a stop never leaves half a point behind.

>>> with StopRequests() as stops:                       # doctest: +SKIP
...     for run in runs:
...         with stops.protected():
...             write(run)
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from typing import Iterator

NAMES = {"SIGINT": "interrupted (Ctrl-C)", "SIGTERM": "stopped by SIGTERM", "SIGHUP": "stopped by SIGHUP (terminal closed)"}


class Stopped(KeyboardInterrupt):
    """A stop request. ``reason`` is one line for a recording's ``abort_reason``; ``exit_code``
    is 128 + the signal number."""

    def __init__(self, signum: int):
        self.signum = int(signum)
        self.signame = signal.Signals(signum).name
        self.reason = NAMES.get(self.signame, f"stopped by {self.signame}")
        self.exit_code = 128 + self.signum
        super().__init__(self.reason)


class StopRequests:
    """Context manager: while active (main thread only), SIGINT, SIGTERM and SIGHUP raise
    :class:`Stopped`; a KeyboardInterrupt raised otherwise is left as it is. After the first stop
    further signals are ignored so the abort can finish. Previous handlers are restored on exit."""

    SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))

    def __init__(self) -> None:
        self._old: dict[int, object] = {}
        self._depth = 0
        self._pending: Stopped | None = None
        self.stopped: Stopped | None = None

    def __enter__(self) -> StopRequests:
        if threading.current_thread() is threading.main_thread():
            for sig in self.SIGNALS:
                self._old[sig] = signal.signal(sig, self._handler)
        return self

    def __exit__(self, *exc) -> bool:
        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old.clear()
        return False

    def _handler(self, signum: int, frame) -> None:
        if self.stopped is not None or self._pending is not None:
            return
        stop = Stopped(signum)
        if self._depth:
            self._pending = stop
            return
        self.stopped = stop
        raise stop

    @contextmanager
    def protected(self) -> Iterator[None]:
        """Hold stop requests until the block is done, then raise the first one."""
        self._depth += 1
        try:
            yield
        finally:
            self._depth -= 1
        if not self._depth and self._pending is not None:
            self.stopped, self._pending = self._pending, None
            raise self.stopped
