"""Serving the monitor: one follower for all viewers, the page, the token, the stop control.

:func:`serve` starts a Bokeh server (tornado) with the page at ``/monitor``. One
:class:`Hub` thread looks at the recording every :data:`POLL_S` and keeps the latest snapshot;
every viewer's page reads that snapshot, so several viewers cost one reader.

Access: on the loopback address (default) anyone on this machine may look. Served beyond it
(``host`` not loopback) every request must carry the random token of the printed address
(``?token=...``; the page then keeps it in a same-site cookie for its websocket): without it the
page, the data websocket and so the stop control answer 403. Sessions are signed with a random
key, so a session id cannot be made up either.
"""

from __future__ import annotations

import hmac
import ipaddress
import logging
import os
import secrets
import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rigtools.errors import UserError, one_line
from rigtools.monitor import page
from rigtools.monitor.control_files import request_stop
from rigtools.monitor.follow import Follower, Snapshot

POLL_S = 0.25
#: Seconds the monitor waits, when it ends, for a look at the recording under way to end.
CLOSE_WAIT_S = 10.0
APP_PATH = "/monitor"
TOKEN_COOKIE = "rig_monitor_token"


class Hub:
    """Polls the recording in a thread; :attr:`snapshot` is the latest view (thread-safe read)."""

    def __init__(self, path: str | Path, poll_s: float = POLL_S, parent: int | None = None) -> None:
        self.follower = Follower(path)
        self.poll_s = poll_s
        self.parent = parent
        self.error = ""
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name="monitor-follower", daemon=True)
        self.finished_at: float | None = None  # when the recording (or its run) was first seen ended
        self._viewers: dict[Any, Any] = {}  # document -> its refresh
        self._lock = threading.Lock()

    def subscribe(self, doc: Any, refresh: Any) -> None:
        """Call ``refresh`` on ``doc``'s event loop whenever a new snapshot is made."""
        with self._lock:
            self._viewers[doc] = refresh
        doc.on_session_destroyed(lambda _context: self.unsubscribe(doc))

    def unsubscribe(self, doc: Any) -> None:
        with self._lock:
            self._viewers.pop(doc, None)

    def _push(self) -> None:
        with self._lock:
            viewers = list(self._viewers.items())
        for doc, refresh in viewers:
            # the one Bokeh document call safe from another thread
            doc.add_next_tick_callback(refresh)

    @property
    def snapshot(self) -> Snapshot:
        return self.follower.snapshot

    def start(self) -> None:
        self._thread.start()

    def stop(self, wait: float = 0.0) -> bool:
        """Stop polling; wait at most ``wait`` s for a look under way to end. True once the
        follower thread has ended (it holds h5py's lock while it reads: an interpreter that exits
        under it deadlocks in h5py's teardown, the monitor then outliving its run for ever)."""
        self._done.set()
        if wait > 0 and self._thread.is_alive():
            self._thread.join(wait)
        return not self._thread.is_alive()

    def parent_gone(self) -> bool:
        """True when the process that started the monitor (``parent``) has ended: this process
        is no longer its child, or it no longer exists."""
        if self.parent is None:
            return False
        if os.getppid() != self.parent:
            return True
        try:
            os.kill(self.parent, 0)
        except ProcessLookupError:
            return True
        except PermissionError:
            return False
        return False

    def _run(self) -> None:
        # the analysis modules load now, not on the first look at a run's first samples
        import rigtools.analysis.impacts
        import rigtools.analysis.spectra
        import rigtools.recording_analysis.periodic  # noqa: F401 - imported for the side effect of loading

        while not self._done.is_set():
            start = time.monotonic()
            version = self.follower.snapshot.version
            try:
                s = self.follower.poll()
            except Exception as exc:  # noqa: BLE001 - the view must outlive any one bad look; the error is kept
                self.error = one_line(exc)
            else:
                if s.status not in ("waiting", "recording") and self.finished_at is None:
                    self.finished_at = time.monotonic()
                if s.version != version:
                    self._push()
            if self.finished_at is None and self.parent_gone():
                # the run's process is gone however it ended (a kill leaves the file "recording")
                self.finished_at = time.monotonic()
            self._done.wait(max(0.0, self.poll_s - (time.monotonic() - start)))


def is_loopback(host: str) -> bool:
    """True for ``localhost`` and loopback addresses (no token needed there)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def token_ok(handler: Any, token: str) -> bool:
    """True if the request carries ``token`` (query argument ``token`` or the page's cookie)."""
    given = handler.get_argument("token", None) or handler.get_cookie(TOKEN_COOKIE) or ""
    return hmac.compare_digest(given.encode(), token.encode())


#: What a request without the token is told (the page of the 403 answer says it, not Tornado's bare one).
REFUSED = (
    "This monitor needs the token of its printed address: open the address rig monitor (or rig "
    "acquire ... --monitor) printed, with its ?token=..., in this browser. A monitor served on "
    "127.0.0.1 needs none."
)


def _refuse(handler: Any) -> None:
    """Answer 403 with :data:`REFUSED` as a small page, then end the request."""
    from tornado.web import Finish

    handler.set_status(403)
    handler.set_header("Content-Type", "text/html; charset=utf-8")
    handler.finish(
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>rig monitor: 403</title>"
        f"</head><body style='font-family:sans-serif;margin:2em'><h1>403: no access</h1>"
        f"<p id='refused'>{REFUSED}</p></body></html>"
    )
    raise Finish()


def _auth_provider(token: str):
    from bokeh.server.auth_provider import AuthProvider

    class TokenAuth(AuthProvider):
        """Every request without the token is refused (403, with :data:`REFUSED`)."""

        @property
        def get_user_async(self):
            # called in prepare(), before a websocket is upgraded: refused requests get no further
            async def get_user(handler):
                if not token_ok(handler, token):
                    _refuse(handler)
                if handler.get_argument("token", None) and not hasattr(handler, "ws_connection"):
                    handler.set_cookie(TOKEN_COOKIE, token, httponly=True, samesite="Strict")
                return "viewer"

            return get_user

        @property
        def get_login_url(self):
            return _refuse

    return TokenAuth()


@dataclass
class Served:
    """A running monitor: its address (with the token when there is one) and how to stop it."""

    url: str
    token: str | None
    hub: Hub
    server: Any

    def stop(self) -> None:
        self.hub.stop()
        self.server.stop()
        self.server.io_loop.stop()

    def close(self, wait: float = CLOSE_WAIT_S) -> bool:
        """After serving: stop the follower and wait for it (at most ``wait`` s). True when it
        ended; False: the caller must leave without the interpreter's teardown (``os._exit``)."""
        return self.hub.stop(wait)


def _origins(host: str, port: int) -> list[str]:
    names = {host, "localhost", "127.0.0.1"}
    if host in ("0.0.0.0", "::", ""):
        names |= {socket.gethostname(), socket.getfqdn()}
        try:
            names |= {str(a[4][0]) for a in socket.getaddrinfo(socket.gethostname(), None)}
        except OSError:
            pass
    return sorted(f"{n}:{port}" for n in names if n)


def _free_port(host: str) -> int:
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as probe:
        probe.bind((host, 0))
        return int(probe.getsockname()[1])


class OneLineErrors(logging.Filter):
    """Tornado's "Uncaught exception" of a request the monitor refuses (a bare websocket upgrade
    without bokeh's subprotocol, a peer gone mid-handshake) as one line, without its traceback:
    a stranger's malformed request is not the monitor's error; the server goes on."""

    def filter(self, record: logging.LogRecord) -> bool:
        if record.exc_info and record.exc_info[1] is not None:
            exc = record.exc_info[1]
            request = (
                getattr(record.args[0], "uri", "") if isinstance(record.args, tuple) and record.args else ""
            )
            record.msg = "rig monitor: refused a request%s: %s: %s"
            record.args = (f" for {request}" if request else "", type(exc).__name__, exc)
            record.exc_info = None
            record.exc_text = None
        return True


def serve(
    path: str | Path,
    *,
    host: str = "127.0.0.1",
    port: int = 5006,
    allow_stop: bool = False,
    poll_s: float = POLL_S,
    parent: int | None = None,
) -> Served:
    """Start the monitor of recording ``path`` (call ``served.server.io_loop.start()`` to run).

    Parameters
    ----------
    host
        Address to bind: loopback (default) needs no token; any other needs the printed token.
    port
        TCP port; 0 picks a free one.
    allow_stop
        Show the stop control (it asks the acquiring process to stop, as Ctrl-C does).
    parent
        The process id of the run that started the monitor (``rig acquire ... --monitor``): when
        it has ended, the run has ended, whatever the recording says.
    """
    from bokeh.application import Application
    from bokeh.application.handlers.function import FunctionHandler
    from bokeh.server.server import Server

    if not 0 <= port <= 65535:
        raise UserError(f"--port = {port}: a TCP port is 0 (a free one) to 65535")
    if Path(path).exists() and not Path(path).is_file():
        raise UserError(f"{path}: not a file (a recording, or where one will be written)")
    one_line = OneLineErrors()
    for name in ("tornado.application", "tornado.general", "bokeh.server.views.ws"):
        if not any(isinstance(f, OneLineErrors) for f in logging.getLogger(name).filters):
            logging.getLogger(name).addFilter(one_line)
    hub = Hub(path, poll_s, parent)
    token = None if is_loopback(host) else secrets.token_urlsafe(24)
    recording = Path(path)

    def stop_run() -> str:
        s = hub.snapshot
        if s.status != "recording":
            return f"not stopped: the recording is {s.status}"
        if not s.accepts_stop:
            return "not stopped: this run takes no stop requests (start it with rig acquire ... --monitor)"
        request_stop(recording)
        return "stop requested: the drive ramps to zero, the recording ends aborted"

    def make(doc) -> None:
        hub.subscribe(doc, page.build(doc, lambda: hub.snapshot, stop_run if allow_stop else None))

    extra: dict[str, Any] = {"num_procs": 1}
    if token is not None:
        extra.update(
            auth_provider=_auth_provider(token), secret_key=secrets.token_urlsafe(32), sign_sessions=True
        )
    apps = {APP_PATH: Application(FunctionHandler(make))}
    for attempt in range(5 if not port else 1):
        # a free port may be taken by another process before the server binds it: pick again
        chosen = port or _free_port(host)
        try:
            server = Server(
                apps, address=host, port=chosen, allow_websocket_origin=_origins(host, chosen), **extra
            )
            break
        except OSError:
            if port or attempt == 4:
                raise
    port = chosen
    server.start()
    shown = "127.0.0.1" if host in ("", "0.0.0.0", "::") and token is None else host
    if host in ("0.0.0.0", "::"):
        shown = socket.gethostname()
    url = f"http://{shown}:{port}{APP_PATH}" + (f"?token={token}" if token else "")
    hub.start()
    return Served(url, token, hub, server)


def run_until_done(served: Served, linger: float | None, appear_within: float | None = None) -> bool:
    """Serve until Ctrl-C, or until ``linger`` s after the recording ended or the run's process
    (``parent``) was seen gone (None: until Ctrl-C). With ``appear_within`` (s), also until then
    if the recording does not exist yet: returns False when it never appeared (True otherwise)."""
    from tornado.ioloop import PeriodicCallback

    start = time.monotonic()
    seen = [appear_within is None]  # the recording existed at one look (then no bound applies)
    appeared = [True]

    def check() -> None:
        now = time.monotonic()
        ended = served.hub.finished_at
        if linger is not None and ended is not None and now - ended >= linger:
            served.stop()
        elif not seen[0]:
            seen[0] = served.hub.follower.path.exists()
            if not seen[0] and appear_within is not None and now - start >= appear_within:
                appeared[0] = False
                served.stop()

    watch = PeriodicCallback(check, 500)
    watch.start()
    try:
        served.server.io_loop.start()
    finally:
        watch.stop()
        served.hub.stop()
    return appeared[0]
