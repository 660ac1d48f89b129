"""``rig acquire ... --monitor``: a monitor process beside the run.

The monitor runs in its own process (``rig monitor``), so drawing never competes with the
acquisition for the interpreter; it is started in its own session, so a Ctrl-C in the terminal
stops the run and not the view of how it ended. It keeps serving ``--monitor-linger`` (default
:data:`LINGER_S`) after the run ended, then exits; it is given this process's id, so it ends as
well when the run's process ended without closing the recording (killed). The acquiring process publishes its control events and honours the stop
control through :class:`rigtools.monitor.control_files.LiveStatus`.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from rigtools.errors import UserError

#: Seconds the monitor started by ``--monitor`` keeps serving after the run ended.
LINGER_S = 120.0
START_TIMEOUT_S = 60.0

#: ``rig acquire`` options of the monitor: (flag, argparse keywords).
OPTIONS: tuple[tuple[str, dict], ...] = (
    (
        "--monitor",
        {"action": "store_true", "help": "serve a live view of the run in the browser; prints its address"},
    ),
    (
        "--monitor-host",
        {
            "default": None,
            "metavar": "HOST",
            "help": "--monitor: address to serve on (default 127.0.0.1; not loopback: a token is needed)",
        },
    ),
    (
        "--monitor-port",
        {
            "type": int,
            "default": None,
            "metavar": "PORT",
            "help": "--monitor: TCP port (default: a free one)",
        },
    ),
    (
        "--allow-stop",
        {
            "action": "store_true",
            "help": "--monitor: the page may stop the run (drive ramps to zero; exit status 6); on "
            "loopback (the default host) anyone logged in on this machine may press it",
        },
    ),
    (
        "--monitor-linger",
        {
            "default": None,
            "metavar": "SECONDS",
            "help": f"--monitor: the monitor exits this long after the run ended (default {LINGER_S:g} s)",
        },
    ),
)


def refuse_monitor_options_alone(args: Any) -> None:
    """An option of the monitor given without ``--monitor`` would be ignored: one line naming it.

    Raises
    ------
    UserError
        ``--allow-stop``, ``--monitor-linger``, ``--monitor-host`` or ``--monitor-port`` given
        without ``--monitor``.
    """
    if getattr(args, "monitor", False):
        return
    values = {flag: getattr(args, flag[2:].replace("-", "_"), None) for flag, _ in OPTIONS[1:]}
    given = [flag for flag, value in values.items() if value is not None and value is not False]
    if given:
        raise UserError(
            f"{' and '.join(given)} {'needs' if len(given) == 1 else 'need'} --monitor "
            f"(no monitor is started without it, so {'it' if len(given) == 1 else 'they'} would be ignored)"
        )


def start_monitor(
    recording: str | os.PathLike,
    *,
    host: str = "127.0.0.1",
    port: int = 0,
    allow_stop: bool = False,
    linger: float = LINGER_S,
) -> tuple[subprocess.Popen, str]:
    """Start ``rig monitor`` on ``recording`` in its own process; returns it and its address.

    The monitor is told this process's id (``--parent``): it exits ``linger`` s after the
    recording ended or this process ended, whichever it sees first."""
    cmd = [
        sys.executable,
        "-m",
        "rigtools.cli",
        "monitor",
        str(recording),
        "--host",
        host,
        "--port",
        str(port),
    ]
    cmd += ["--linger", str(linger), "--parent", str(os.getpid())] + (["--allow-stop"] if allow_stop else [])
    # the monitor's own messages, kept only to say why it did not start
    with tempfile.TemporaryFile(mode="w+") as log:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=log, text=True, start_new_session=True)
        assert proc.stdout is not None
        deadline = time.monotonic() + START_TIMEOUT_S
        line = ""
        while time.monotonic() < deadline and not line:
            line = proc.stdout.readline().strip()
            if not line and proc.poll() is not None:
                break
        if not line.startswith("http"):
            with contextlib.suppress(Exception):
                proc.kill()
            log.seek(0)
            why = [text for text in log.read().splitlines() if text.strip()]
            raise UserError(f"--monitor: the monitor did not start ({why[-1] if why else 'no message'})")
    proc.stdout.close()
    return proc, line.split()[0]


@contextlib.contextmanager
def monitor_beside(
    args: Any, out: Path, proc: Any, progress: Callable[[Any], None]
) -> Iterator[Callable[[Any], None]]:
    """With ``args.monitor``: start the monitor, print its address, publish the run's control
    events and honour its stop requests; yields the progress callback to give the procedure.
    Without it: refuses the monitor's other options (:func:`refuse_monitor_options_alone`),
    yields ``progress`` and does nothing else."""
    if not getattr(args, "monitor", False):
        refuse_monitor_options_alone(args)
        yield progress
        return
    from rigtools.monitor.control_files import LiveStatus
    from rigtools.options import duration

    given = getattr(args, "monitor_linger", None)
    linger = LINGER_S if given is None else duration(given, "--monitor-linger", allow_zero=True)
    with LiveStatus(out, proc.stop) as live:
        _child, url = start_monitor(
            out,
            host=args.monitor_host or "127.0.0.1",
            port=args.monitor_port or 0,
            allow_stop=args.allow_stop,
            linger=linger,
        )
        print(f"rig acquire: monitor at {url}", file=sys.stderr, flush=True)

        def both(event: Any) -> None:
            progress(event)
            live.event(event)

        yield both


def stopped_from_monitor(reason: str, out: Any) -> int | None:
    """A run ended by the monitor's stop (its reason :data:`.control_files.STOP_REASON`): say so
    in one line on stderr and return exit status 6 (:data:`rigtools.errors.EXIT_STOPPED`);
    another end: None."""
    from rigtools.errors import EXIT_STOPPED
    from rigtools.monitor.control_files import STOP_REASON

    if reason != STOP_REASON:
        return None
    print(
        f"rig acquire: {STOP_REASON}; drive ramped to zero; {out} kept with status aborted", file=sys.stderr
    )
    return EXIT_STOPPED
