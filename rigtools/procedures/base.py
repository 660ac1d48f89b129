"""The procedure life cycle: start-up -> execute -> shut-down, an end status, a stop request.

A :class:`Procedure` (a dwell, a stepped sine, a study, an FRF test) runs on one configured
device and writes one recording. :meth:`Procedure.run`:

1. ``startup``: open and configure the device, open the recording;
2. ``execute``: the procedure's own work, point by point (each point written as it completes);
3. ``shutdown`` in ``finally``: the drive ends at zero (the stream's ramp, or the device's),
   the device is closed, and the recording gets its end status and reason.

End status (:class:`Status`), kept in the file: ``finished`` (file status ``complete``);
``aborted`` -- a stop request from a script (:meth:`Procedure.stop`), Ctrl-C or a signal
(SIGINT, SIGTERM, SIGHUP; any ``KeyboardInterrupt`` subclass) -- and ``failed`` -- a hardware
fault, a safety abort, an error -- both file status ``aborted`` with ``abort_reason``
``"aborted: ..."`` / ``"failed: ..."``. The root attribute ``end_status`` holds the word.

While a procedure runs in the main thread, SIGINT/SIGTERM/SIGHUP become a stop request: the
drive ramps to zero over ``[safety] abort_ramp_time`` while the inputs are still read, so the
record shows the ramp. The handlers stay installed until :meth:`Procedure.shutdown` has brought
the output to zero and closed the device: a second signal meanwhile is held (the ramp runs to
its end), then honoured; a third cuts the ramp short (:attr:`Procedure.hurry_requested`: zeros
are written at once, after the blocks already queued) but never skips the zero. Only once the
device is closed does a further signal interrupt at once.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
from pydantic import ValidationError

from rigtools.errors import FaultError, Interrupted, UserError, one_line
from rigtools.procedures.result import RunResult, Status
from rigtools.quantity_fields import describe_error
from rigtools.recording.lock import LockBusy, WriterLock

__all__ = [
    "Procedure",
    "ProcedureFailed",
    "ProcedureResult",
    "ProgressEvent",
    "RunResult",
    "Status",
    "StopRequested",
]


class StopRequested(BaseException):
    """Raised inside a procedure after a stop request, once the drive has ramped down.

    A ``BaseException`` (like Ctrl-C) so that no ``except Exception`` on the way swallows it.
    """


class ProcedureFailed(FaultError):
    """A procedure ended ``failed`` (exit 4): a fault, a safety abort or an error."""


@dataclass(frozen=True)
class ProgressEvent:
    """What a procedure reports while it runs (the CLI shows it with rich).

    ``kind``: ``"point"`` (point ``point`` of ``n_points`` starts), ``"control"`` (a force
    control update: ``update``, ``control_error`` = measured/target - 1), ``"settling"``,
    ``"recording"``, ``"point_done"``, ``"message"``.
    """

    kind: str
    point: int = 0
    n_points: int = 1
    text: str = ""
    update: int = 0
    control_error: float | None = None
    time: float = 0.0


@dataclass
class ProcedureResult:
    """A procedure's working record while it runs (:attr:`Procedure.result`): the points as
    plain mappings, as the recording's attributes hold them. :meth:`Procedure.run` returns
    the one public result made of it, :class:`rigtools.procedures.RunResult`."""

    status: Status
    reason: str = ""
    file: str | None = None
    points: list[dict] = field(default_factory=list)
    summary: dict = field(default_factory=dict)


def validate(model: type, **values: Any):
    """Build a pydantic parameter model; a bad value is one :class:`UserError` line naming the
    parameter, the value as written and what is allowed (in SI units)."""
    try:
        return model(**values)
    except ValidationError as exc:
        err = exc.errors()[0]
        written: Any = values  # the value as the caller wrote it, before unit conversion
        try:
            for part in err["loc"]:
                written = written[part]
        except (KeyError, IndexError, TypeError):
            written = err.get("input")
        raise UserError(describe_error(model, err, written)) from None


SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))


class Procedure:
    """Base of every procedure. Subclasses implement :meth:`startup`, :meth:`execute` and
    :meth:`shutdown` (``shutdown(status, reason)`` is always called, in ``finally``)."""

    name = "procedure"

    def __init__(self, progress: Callable[[ProgressEvent], None] | None = None) -> None:
        self._progress = progress
        self._stop = threading.Event()
        self.stop_reason = ""
        self.stop_signal: int | None = None  # the signal that asked for the stop, if any
        self.signals_seen = 0  # stop signals received while the drive could be live
        self.result: ProcedureResult | None = None  # the working record; run() returns a RunResult
        self._zeroed = False  # shutdown done: the output is at zero and the device closed

    # -- for scripts ---------------------------------------------------------------------------
    def stop(self, reason: str = "stop requested") -> None:
        """Ask the procedure to stop: the drive ramps to zero, what was recorded is kept, the
        status becomes ``aborted``. Safe to call from another thread or a signal handler."""
        if not self._stop.is_set():
            self.stop_reason = reason
            self._stop.set()

    @property
    def stop_requested(self) -> bool:
        return self._stop.is_set()

    @property
    def hurry_requested(self) -> bool:
        """True after a third stop signal: the abort ramp is cut short (zero written at once)."""
        return self.signals_seen >= 3

    def emit(self, kind: str, **fields: Any) -> None:
        if self._progress is not None:
            self._progress(ProgressEvent(kind, **fields))

    # -- life cycle ------------------------------------------------------------------------------
    def startup(self) -> None:
        """Open and configure the device, open the recording."""

    def execute(self) -> None:
        """The procedure's work."""
        raise NotImplementedError

    def shutdown(self, status: Status, reason: str) -> None:
        """Drive to zero, device closed, recording ended with ``status`` and ``reason``."""

    def run(self) -> RunResult:
        """Run start-up, execute and shut-down; returns the result.

        Returns
        -------
        RunResult
            The same type the front door's functions (:func:`rigtools.dwell`, ...) return.

        Raises
        ------
        KeyboardInterrupt
            After a Ctrl-C or signal (status ``aborted`` recorded first); a stop request from a
            script returns normally with status ``aborted``.
        ProcedureFailed, UserError, DriverError
            When the procedure failed (status ``failed`` recorded first).
        """
        status, reason = Status.FAILED, ""
        error: BaseException | None = None
        previous = self._install_signal_handlers()
        try:
            self.startup()
            self.execute()
            status = Status.FINISHED
        except StopRequested:
            status, reason = Status.ABORTED, self.stop_reason or "stop requested"
            if self.stop_signal is not None:
                error = Interrupted(self.stop_signal)
        except KeyboardInterrupt as exc:
            status, reason, error = Status.ABORTED, (self.stop_reason or _interrupt_text(exc)), exc
        except BaseException as exc:  # noqa: BLE001 - recorded, then re-raised
            status, reason, error = Status.FAILED, one_line(exc), exc
        finally:
            try:
                self.shutdown(status, reason)  # signals held meanwhile: the output reaches zero
            except BaseException as exc:  # noqa: BLE001 - a failed shutdown is recorded, then raised
                if error is None:
                    status, reason, error = Status.FAILED, one_line(exc), exc
            finally:
                self._zeroed = True
                self._restore_signal_handlers(previous)
        result = self.result or ProcedureResult(status)
        result.status, result.reason = status, reason
        self.result = result
        if error is not None:
            raise error
        return RunResult.from_procedure(self.name, result, getattr(self, "out", result.file or ""))

    # -- signals ---------------------------------------------------------------------------------
    def _install_signal_handlers(self) -> dict:
        if threading.current_thread() is not threading.main_thread():
            return {}
        previous = {}

        def handler(signum, frame):
            name = signal.Signals(signum).name
            if self._zeroed:  # output at zero, device closed: nothing left to protect
                raise Interrupted(signum)
            self.signals_seen += 1
            if self._stop.is_set():  # a further signal: held until the output is at zero
                return
            self.stop_signal = signum
            self.stop(f"signal {name}" + (" (Ctrl-C)" if name == "SIGINT" else ""))

        for sig in SIGNALS:
            try:
                previous[sig] = signal.signal(sig, handler)
            except (ValueError, OSError):
                pass
        return previous

    @staticmethod
    def _restore_signal_handlers(previous: dict) -> None:
        for sig, old in previous.items():
            try:
                signal.signal(sig, old)
            except (ValueError, OSError, TypeError):
                pass


def _interrupt_text(exc: BaseException) -> str:
    text = str(exc).strip()
    return f"interrupted: {text}" if text else "interrupted (Ctrl-C)"


def mark_end_status(path: str | Path, status: Status, reason: str) -> None:
    """Set the root attributes ``end_status`` and ``end_reason`` of a closed recording."""
    lock = WriterLock(path)  # a file another run writes now is not ours to change
    try:
        lock.acquire()
    except (LockBusy, OSError):
        return
    try:
        with h5py.File(path, "r+", libver=("v110", "v110"), locking=False) as f:
            f.attrs["end_status"] = status.value
            f.attrs["end_reason"] = reason
            # the writer may have ended the file itself first (a full disk: "RecordingWriteError:
            # ..."): the abort reason starts with the procedure's word, as rig check holds it
            aborted = str(f.attrs.get("abort_reason", ""))
            if f.attrs.get("status") == "aborted" and aborted and not aborted.startswith(f"{status.value}: "):
                f.attrs["abort_reason"] = f"{status.value}: {aborted}"
    except OSError:
        pass
    finally:
        lock.release()
