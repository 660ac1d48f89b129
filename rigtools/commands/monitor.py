"""``rig monitor FILE``: a live view of a recording in the browser (also of a finished one)."""

from __future__ import annotations

import argparse

from rigtools.errors import exit_status_help

HELP = (
    """\
Serve a page that follows a recording while it is written, and shows a finished one the same
way: time traces of the force and both shroud accelerations over the last periods (min/max
envelopes: no impact disappears), the amplitude spectrum with the k·fe harmonics marked and the
strongest named, the force-control state (target, measured F1, drive, error, updates, settled),
impacts per period, each channel's peak against its safety limit, the points of a study or
stepped sine with a trend plot, and the status (recording, finished, aborted or failed with the
reason). A phase-locked loop (rig acquire pll) adds its phase and lock, a control-based
continuation (rig acquire cbc) its control effort and iterations, both their points growing
(A against fe; the S-curve F1 against A). It only reads the recording (SWMR, 4 looks a second,
new samples only). An ended recording it cannot read (truncated, damaged) is refused in one line.

Served on 127.0.0.1 unless --host is given; any other address needs the random token of the
printed address (every request without it is refused). --allow-stop shows a stop button: the
run (started with rig acquire ... --monitor) ramps the drive to zero and ends aborted, reason
"stopped from the monitor" (rig acquire then says so and exits with status 6). On loopback
--allow-stop lets anyone logged in on this machine stop the run: the address needs no token
there; served beyond loopback only a holder of the printed address (with its token) can.
Ctrl-C ends the monitor, never the run.

FILE may not exist yet (a run about to start): the page waits for it, until Ctrl-C; with
--linger SECONDS (and no --parent) at most SECONDS: a FILE that has not appeared by then is
one line naming it and exit status 2 (a mistyped name ends instead of waiting for ever).

--linger SECONDS: exit that long after the recording ended; with --parent PID (what
rig acquire ... --monitor passes: its own process id) also that long after process PID ended,
however it ended (a kill leaves the recording unfinished), so the monitor never outlives its
run by more than SECONDS.

"""
    + exit_status_help(
        0,
        2,
        notes={
            0: "the recording ended and --linger passed",
            2: "bad input (options, the address cannot be served, FILE not there within --linger)",
        },
    )
    + """

examples:
  rig monitor run.h5
  rig monitor run.h5 --host 0.0.0.0 --port 5006 --allow-stop
  rig acquire dwell --backend sim --pace --fe 60 --force "15 N" --out live.h5 --monitor
"""
)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "monitor",
        help="live view of a recording in the browser (while it is written, or finished)",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "file", metavar="FILE", help="recording (.h5); it may not exist yet (waited for: at most --linger)"
    )
    p.add_argument(
        "--host", default="127.0.0.1", help="address to serve on (default 127.0.0.1; others need the token)"
    )
    p.add_argument("--port", type=int, default=5006, help="TCP port (default 5006; 0: a free one)")
    p.add_argument("--allow-stop", action="store_true", help="show the stop control")
    p.add_argument(
        "--linger",
        default=None,
        metavar="SECONDS",
        help="exit SECONDS after the recording ended, or (no --parent) if FILE has not appeared "
        "after SECONDS (default: run until Ctrl-C)",
    )
    p.add_argument(
        "--parent",
        type=int,
        default=None,
        metavar="PID",
        help="with --linger: the run ended when process PID ended (rig acquire --monitor passes its own)",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import os
    import sys

    from rigtools.errors import EXIT_SIGINT, EXIT_USAGE, UserError
    from rigtools.monitor.follow import unreadable_ended
    from rigtools.monitor.server import run_until_done, serve
    from rigtools.options import duration
    from rigtools.runtime import configure_process

    linger = None if args.linger is None else duration(args.linger, "--linger", allow_zero=True)
    configure_process()  # one BLAS thread: the fits are small, and the run needs the cores
    if args.parent is None:  # a run's own monitor (rig acquire --monitor) waits for its file
        why = unreadable_ended(args.file)
        if why is not None:
            raise UserError(why)
    try:
        served = serve(
            args.file, host=args.host, port=args.port, allow_stop=args.allow_stop, parent=args.parent
        )
    except OSError as exc:
        raise UserError(f"cannot serve on {args.host}:{args.port} ({exc.strerror or exc})") from None
    print(served.url, flush=True)
    absent = not os.path.exists(args.file)
    bound = linger if absent and args.parent is None else None
    what = "waiting for" if absent else "following"
    within = f" (at most {bound:g} s: --linger)" if bound is not None else ""
    print(
        f"rig monitor: {what} {args.file}{within}; Ctrl-C ends the monitor (never the run)",
        file=sys.stderr,
        flush=True,
    )
    code = 0
    try:
        if not run_until_done(served, linger, appear_within=bound):
            code = EXIT_USAGE
            print(
                f"rig monitor: error: {args.file} does not exist, and did not appear within "
                f"--linger {bound:g} s",
                file=sys.stderr,
            )
    except KeyboardInterrupt as exc:
        served.stop()
        code = getattr(exc, "exit_code", EXIT_SIGINT)  # 130 Ctrl-C, 143 SIGTERM: rig --help
    if not served.close():
        # a look at the recording still under way holds h5py's lock: the interpreter's teardown
        # would wait for it for ever; nothing is left to write, so leave now
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    return code
