"""The two small files beside a recording that connect a monitor and the run it watches.

The monitor never writes the recording. With ``rig acquire --monitor`` the acquiring process
writes ``.<name>.live.json`` (its process id, whether it takes stop requests, and the latest
force-control event: point, phase, update, error) and watches ``.<name>.stop``; a monitor started
with the stop control allowed writes that file when the operator presses stop, and the acquiring
process then stops as on Ctrl-C (drive ramped to zero, status ``aborted``, reason
:data:`STOP_REASON`). Both files are written whole and renamed into place, so a reader never sees
half a file.
"""

from __future__ import annotations

import contextlib
import json
import os
import threading
import time
from pathlib import Path
from typing import Any, Self

#: The reason an acquiring process records for a stop sent from the monitor.
STOP_REASON = "stopped from the monitor"
#: How often the acquiring process looks for a stop request, s.
STOP_POLL_S = 0.1


def live_path(recording: str | os.PathLike) -> Path:
    """``run.h5`` -> ``.run.h5.live.json`` (written by the acquiring process)."""
    p = Path(recording)
    return p.with_name(f".{p.name}.live.json")


def stop_path(recording: str | os.PathLike) -> Path:
    """``run.h5`` -> ``.run.h5.stop`` (written by a monitor with the stop control allowed)."""
    p = Path(recording)
    return p.with_name(f".{p.name}.stop")


def _write_whole(path: Path, doc: dict) -> None:
    tmp = path.with_name(path.name + f".{os.getpid()}.tmp")
    tmp.write_text(json.dumps(doc), encoding="utf-8")
    os.replace(tmp, path)


def read_json(path: Path) -> dict[str, Any] | None:
    """The JSON object in ``path``, or None if it is missing or unreadable."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return doc if isinstance(doc, dict) else None


def request_stop(recording: str | os.PathLike, who: str = "") -> Path:
    """Ask the process acquiring ``recording`` to stop (what the monitor's stop button does)."""
    path = stop_path(recording)
    _write_whole(path, {"reason": STOP_REASON, "time": time.time(), "from": who})
    return path


class LiveStatus:
    """The acquiring process's side: publishes its control events, honours stop requests.

    Parameters
    ----------
    recording
        The recording being written.
    stop
        Called with :data:`STOP_REASON` when a stop request appears (``Procedure.stop``).
    """

    def __init__(self, recording: str | os.PathLike, stop) -> None:
        self.recording = Path(recording)
        self._stop = stop
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="monitor-stop-watch", daemon=True)
        self.doc: dict[str, Any] = {"pid": os.getpid(), "accepts_stop": True, "event": None}

    def __enter__(self) -> Self:
        with contextlib.suppress(OSError):
            stop_path(self.recording).unlink()  # a request left from an earlier run is not for this one
        self._publish()
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._done.set()
        self._thread.join(timeout=1.0)
        with contextlib.suppress(OSError):
            live_path(self.recording).unlink()  # the run is over: nothing to publish, no stop taken

    def event(self, e: Any) -> None:
        """A procedure progress event (:class:`rigtools.procedures.base.ProgressEvent`)."""
        event = {
            "kind": e.kind,
            "point": e.point,
            "n_points": e.n_points,
            "update": e.update,
            "control_error": e.control_error,
            "text": e.text,
            "time": time.time(),
        }
        self.doc["event"] = event
        if e.kind == "control":  # the latest force-control update stays shown while the point settles
            self.doc["control"] = event
        self._publish()

    def _publish(self) -> None:
        with contextlib.suppress(OSError):
            _write_whole(live_path(self.recording), self.doc)

    def _watch(self) -> None:
        path = stop_path(self.recording)
        while not self._done.wait(STOP_POLL_S):
            if path.exists():
                doc = read_json(path) or {}
                self._stop(str(doc.get("reason") or STOP_REASON))
                with contextlib.suppress(OSError):
                    path.unlink()
                return
