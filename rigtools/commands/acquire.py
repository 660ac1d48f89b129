"""``rig acquire dwell|sweep|study|frf|tap``: lab procedures on the rig (NI-DAQmx) or the simulated rig.

Parse, call :mod:`rigtools.procedures`, print. Top-level imports stay light (``rig --help``).
"""

from __future__ import annotations

import argparse
import json
import re
import sys

from rigtools.errors import UserError
from rigtools.options import check_out, gap, quantity, seed

HELP = "lab procedures on the rig: force-controlled dwell, stepped sine, study, FRF test, tap test"
COMMON_EPILOG = """\
Backends: --backend nidaq (default) drives the NI-DAQmx rig of the rig file's [daq]; --backend sim
runs the simulated rig (the FE model of [test_article] through the [shaker] model), as fast as
it can (--pace: in real time; --seed: sensor noise; --fault KIND@TIME[:CHANNEL] injects a fault:
input-overflow, amplifier-timeout, sensor-overload, nan-samples, TIME from the start).

Force control: the force sensor's fundamental (least squares over whole periods) is held at
--force F0 within 0.5 % by adjusting the drive amplitude (secant steps, at most --max-updates
after the first ramp, never planned past 80 % of a [safety] warning level), then the response
settles (every input's fundamental steady within 1 %) and --periods whole periods are recorded.
The drive ramps up and down over [safety] ramp_time; on a stop, Ctrl-C, SIGTERM or SIGHUP it
ramps to zero over abort_ramp_time while still recording (status aborted), on a fault or safety
abort at once (status failed); everything recorded is kept. Each point holds the whole stream
of that point (control, settling, record window: record_start / record_samples), the drive as
written, and parameters fe, force_amplitude (target), force_amplitude_measured, gap,
drive_amplitude, control_updates, settled, harmonics k = 1..K of every channel (amplitude and
phase relative to the force fundamental).

Quantities take units ("60 Hz", "15 N", "0.5 mm", "2 s"); a plain number is SI.
Exit status: 0 finished, 2 bad input, 3 NI-DAQmx not available (use --backend sim), 4 a fault,
safety abort or write error ended the run (status failed, file kept), 130 Ctrl-C or a signal
(status aborted, file kept).
"""
EPILOGS = {
    "dwell": """examples:
  rig acquire dwell --backend sim --fe 60 --force "15 N" --gap "0.5 mm" --out d.h5
  rig acquire dwell --backend sim --fe 60 --force "15 N" --gap "0.5 mm" --out d.h5 --json
  rig acquire dwell --rig lab.toml --fe 60 --force "15 N" --out dwell.h5

--json prints {"file", "status", "backend", "fe", "force_amplitude", "force_amplitude_measured",
"gap", "drive_amplitude", "control_updates", "settled", "warnings",
"channels": {name: {"units", "peak", "harmonics": [{"k", "amplitude", "phase"}, ...]}}}.
""",
    "sweep": """examples:
  rig acquire sweep --backend sim --frequencies "340 Hz:380 Hz:2 Hz" --force "2 N" --gap "5 mm" --out s.h5
  rig acquire sweep --backend sim --frequencies "55 Hz:80 Hz:1 Hz" --force "15 N" --gap "0.7 mm" --direction both --out j.h5

Jumps: neighbouring steps whose response fundamental differs by more than --jump-threshold
(relative), reported per direction with the frequencies between which they happen.
""",
    "study": """examples:
  rig acquire study gap --backend sim --values "0.3 mm:0.9 mm:0.2 mm" --force "15 N" --fe 60 --out s.h5 --yes
  rig acquire study gap --backend sim --values "0.3 mm:0.9 mm:0.2 mm" --force "15 N" --fe 60 --out s.h5 --resume
  rig acquire study force --backend sim --values "5 N,10 N,15 N" --gap "0.7 mm" --fe 60 --out f.h5

The plan (values, order, up/down) is the model study's (rigtools.sim.studies.StudyPlan). On the NI rig
the gap is set by hand: the drive ramps to zero and the command waits for the operator (Enter;
--yes: do not wait). --resume continues an interrupted study in --out from its last complete
point (a point cut off is dropped and run again; none is repeated or lost).
""",
    "frf": """examples:
  rig acquire frf --backend sim --signal chirp --band "20 Hz:500 Hz" --level "0.3 V" --frame "0.5 s" --averages 10 --out f.h5
  rig acquire frf --backend sim --signal burst --band "20 Hz:2 kHz" --level "0.3 V" --out b.h5

Recorded raw (drive and inputs); the command prints H1 (response/force) peaks in the band and
their coherence over the averaged frames as a quick check. --level is the chirp's peak or the
burst's rms, V.
""",
    "tap": """examples:
  rig acquire tap --backend sim --blade passive --position "85 mm" --hits 5 --gap "5 mm" --out t.h5
  rig acquire tap --rig lab.toml --blade passive --position "85 mm" --hits 5 --out tap.h5

An impact-hammer test of one blade (the passive blade has no shaker). The hammer's force is its
own [daq.channels] entry (kind = "force", IEPE; --hammer-channel, default "hammer"); the
response is the blade's shroud accelerometer (--response). A software trigger on the hammer
force (--trigger, default "5 N") starts a frame of --frame (default "2 s", resolution 1/frame),
--pretrigger (default "10 ms") of it from before the hit; one recording point per hit, recorded
raw; a double hit or a response that has not decayed by the frame's end is recorded, marked
rejected and not counted. The shaker's drive stays at 0 V. Tap where modes 1-3 all move: the
shroud sits near a node of the passive blade's third flexural mode; ~85 mm from the root (of
155 mm) moves all three. On the NI rig the command waits up to --timeout for each accepted
hit; the simulated rig hits a half-sine of --pulse (default "0.5 ms") and --hit-force (default
"20 N") peak every frame + 0.5 s. Prints the modes identified from H1 (response / hammer) over the
accepted hits (rectangular window per frame) up to --f-max.
""",
}
FAULT_PATTERN = re.compile(r"^\s*([A-Za-z_-]+)\s*@\s*([^:]+?)\s*(?::\s*([\w.-]+))?\s*$")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "acquire",
        help=HELP,
        description=HELP + ".",
        epilog=COMMON_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = p.add_subparsers(dest="procedure", metavar="PROCEDURE", required=True)
    for name, text in (
        ("dwell", "force-controlled sine dwell at one frequency"),
        ("sweep", "force-controlled stepped sine up/down with harmonics and jumps"),
        ("study", "force-controlled gap / force / frequency study (the paper's form)"),
        ("frf", "burst random or periodic chirp FRF test, recorded raw"),
        ("tap", "impact-hammer (tap) test of a blade, one frame per hit, recorded raw"),
    ):
        q = sub.add_parser(
            name,
            help=text,
            description=text + ".",
            epilog=EPILOGS[name] + "\n" + COMMON_EPILOG,
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        if name == "study":
            q.add_argument("kind", choices=("gap", "force", "frequency"), help="swept parameter")
            q.add_argument("--values", required=True, help='"a,b,c" or "start:stop:step", with units')
            q.add_argument("--direction", choices=("up", "down", "both"), default="up")
            q.add_argument("--yes", action="store_true", help="do not wait for the operator to set the gap")
            q.add_argument("--resume", action="store_true", help="continue an interrupted study in --out")
        if name in ("dwell", "study"):
            q.add_argument("--fe", required=(name == "dwell"), help='excitation frequency, e.g. "60 Hz"')
        if name not in ("frf", "tap"):
            q.add_argument("--force", required=(name != "study"), help='force amplitude F0, e.g. "15 N"')
            q.add_argument("--periods", type=int, default=None, help="whole periods recorded per point")
            q.add_argument("--max-updates", type=int, default=10, help="force-control updates (default 10)")
        if name == "sweep":
            q.add_argument(
                "--frequencies", required=True, help='"start:stop:step" or "a,b,c", e.g. "340 Hz:380 Hz:2 Hz"'
            )
            q.add_argument("--direction", choices=("up", "down", "both"), default="up")
            q.add_argument(
                "--jump-threshold",
                type=float,
                default=0.3,
                help="relative change of the response between neighbouring steps called a jump (default 0.3)",
            )
        if name == "frf":
            q.add_argument("--signal", choices=("chirp", "burst"), default="chirp")
            q.add_argument("--band", required=True, help='"low:high", e.g. "20 Hz:500 Hz"')
            q.add_argument("--level", required=True, help='chirp peak or burst rms, e.g. "0.3 V"')
            q.add_argument("--frame", default="1 s", help='frame length (resolution 1/frame), default "1 s"')
            q.add_argument("--averages", type=int, default=10)
        if name == "tap":
            q.add_argument("--blade", choices=("passive", "active"), default="passive")
            q.add_argument("--position", required=True, help='hit position from the root, e.g. "85 mm"')
            q.add_argument("--hits", type=int, default=5, help="accepted hits averaged (default 5)")
            q.add_argument("--frame", default="2 s", help='frame per hit, default "2 s"')
            q.add_argument("--pretrigger", default="10 ms", help='kept before the trigger, default "10 ms"')
            q.add_argument(
                "--trigger", default="5 N", help='trigger level on the hammer force, default "5 N"'
            )
            q.add_argument("--hammer-channel", default="hammer", help="the hammer's [daq.channels] entry")
            q.add_argument(
                "--response", default=None, help="response channel (default: the blade's accelerometer)"
            )
            q.add_argument(
                "--timeout", default="60 s", help='longest wait for the next accepted hit, default "60 s"'
            )
            q.add_argument(
                "--hit-force", default="20 N", help='simulated rig: peak hammer force, default "20 N"'
            )
            q.add_argument(
                "--pulse", default="0.5 ms", help='simulated rig: hammer pulse length, default "0.5 ms"'
            )
            q.add_argument("--f-max", default="2 kHz", help='highest frequency identified, default "2 kHz"')
        q.add_argument(
            "--gap", default=None, help='shroud gap, e.g. "0.5 mm" (default: as set / the rig file)'
        )
        q.add_argument(
            "--backend",
            choices=("nidaq", "sim"),
            default="nidaq",
            help="nidaq: the NI-DAQmx rig (default); sim: the simulated rig",
        )
        q.add_argument("--rig", metavar="FILE", help="rig file (TOML); default: the calibrated default rig")
        q.add_argument("--out", required=True, metavar="FILE", help="HDF5 recording to write")
        q.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
        q.add_argument("--json", action="store_true", help="print the results as JSON")
        q.add_argument("--pace", action="store_true", help="simulated rig: real time")
        q.add_argument("--seed", type=seed, default=None, help="simulated rig: noise seed")
        q.add_argument(
            "--fault",
            action="append",
            default=[],
            metavar="KIND@TIME[:CHANNEL]",
            help="simulated rig: inject a fault (repeatable)",
        )
        q.set_defaults(func=run)


# ------------------------------------------------------------------------------ inputs


def parse_faults(texts: list[str], backend: str) -> list:
    if not texts:
        return []
    if backend != "sim":
        raise UserError("--fault injects faults into the simulated rig only; add --backend sim")
    from rigtools.drivers.contracts import ConfigurationError
    from rigtools.drivers.simulated import FAULT_KINDS, Fault

    faults = []
    for text in texts:
        match = FAULT_PATTERN.match(text)
        if not match:
            raise UserError(f"--fault = {text!r}: write KIND@TIME[:CHANNEL], e.g. 'input-overflow@1.5:force'")
        kind, at, channel = match.groups()
        t = quantity(at, "time", "--fault")
        if t < 0:
            raise UserError(f"--fault = {text!r}: the time must be >= 0 s")
        try:
            faults.append(Fault(kind, at_time=t, channel=channel))
        except ConfigurationError:
            raise UserError(
                f"--fault = {text!r}: unknown kind {kind!r} (known: "
                f"{', '.join(k.replace('_', '-') for k in FAULT_KINDS)})"
            ) from None
    return faults


def grid(text: str, kind: str, option: str) -> list[float]:
    """``"a,b,c"`` or ``"start:stop:step"`` with units, of a ``kind`` of study (gap, force,
    frequency), parsed and checked as ``rig study`` does."""
    from rigtools.commands.study import parse_values

    try:
        return parse_values(text, kind)
    except UserError as exc:
        raise UserError(str(exc).replace("--values", option)) from None


def _gap(args) -> float | None:
    return None if args.gap is None else gap(args.gap)


def _control(args) -> dict:
    if not 1 <= args.max_updates <= 100:
        raise UserError(f"--max-updates = {args.max_updates}: use 1..100")
    return {"max_updates": args.max_updates}


# ------------------------------------------------------------------------------ running


def run(args: argparse.Namespace) -> int:
    from rigtools.config import load_rig

    resume = getattr(args, "resume", False)
    out = check_out(args) if not resume else _resume_out(args)
    cfg = load_rig(args.rig)
    faults = parse_faults(args.fault, args.backend)
    kwargs = dict(
        backend=args.backend, overwrite=args.overwrite, pace=args.pace, faults=faults, seed=args.seed
    )
    proc = build(args, cfg, out, kwargs)
    from rigtools.procedures.base import Status

    try:
        with Display(args) as display:
            proc._progress = display.event
            result = proc.run()
    except KeyboardInterrupt as exc:
        _exit_interrupted(proc, getattr(exc, "exit_code", 130))
    doc = report(args, proc, result)
    if args.json:
        print(json.dumps(doc))
    else:
        print_summary(args, doc)
    return 0 if result.status is Status.FINISHED else 130


def _exit_interrupted(proc, code: int) -> None:
    """Ctrl-C or a signal: the drive is at zero and the recording closed with status aborted.
    Say so in one line and leave at once (exit ``code``: 130 Ctrl-C, 143 SIGTERM, 129 SIGHUP):
    the interpreter's own teardown of the
    numeric libraries takes about a second on a loaded machine, and nothing is left to do."""
    import os

    reason = proc.result.reason if proc.result is not None else "interrupted"
    print(
        f"rig acquire: interrupted ({reason}); drive ramped to zero; {proc.out} kept with status aborted",
        file=sys.stderr,
    )
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def _resume_out(args):
    from pathlib import Path

    out = Path(args.out)
    if not out.exists() and not out.with_name(out.name + ".resume-source").exists():
        raise UserError(f"--resume: {args.out!r} does not exist; run without --resume to start the study")
    return out


def build(args, cfg, out, kwargs):
    from rigtools import procedures as P

    proc_name = args.procedure
    if proc_name == "dwell":
        params = {
            "fe": quantity(args.fe, "frequency", "--fe"),
            "force": quantity(args.force, "force", "--force"),
            "gap": _gap(args),
            "control": _control(args),
        }
        if args.periods is not None:
            params["record_periods"] = args.periods
        return P.SineDwell(cfg, params, out, **kwargs)
    if proc_name == "sweep":
        params = {
            "frequencies": grid(args.frequencies, "frequency", "--frequencies"),
            "force": quantity(args.force, "force", "--force"),
            "gap": _gap(args),
            "direction": args.direction,
            "jump_threshold": args.jump_threshold,
            "control": _control(args),
        }
        if args.periods is not None:
            params["record_periods"] = args.periods
        return P.SteppedSine(cfg, params, out, **kwargs)
    if proc_name == "study":
        values = grid(args.values, args.kind, "--values")
        params = {
            "kind": args.kind,
            "values": values,
            "direction": args.direction,
            "fe": None if args.fe is None else quantity(args.fe, "frequency", "--fe"),
            "force": None if args.force is None else quantity(args.force, "force", "--force"),
            "gap": _gap(args),
            "control": _control(args),
        }
        if args.periods is not None:
            params["record_periods"] = args.periods
        if args.resume:
            kwargs = {**kwargs, "overwrite": False}
        return P.RigStudy(cfg, params, out, resume=args.resume, confirm_gap=_confirm(args), **kwargs)
    if proc_name == "tap":
        from rigtools.procedures.tap import TapTest

        if not 1 <= args.hits <= 1000:
            raise UserError(f"--hits = {args.hits}: use 1..1000")
        params = {
            "blade": args.blade,
            "position": quantity(args.position, "length", "--position"),
            "hits": args.hits,
            "frame": quantity(args.frame, "time", "--frame"),
            "pretrigger": quantity(args.pretrigger, "time", "--pretrigger"),
            "trigger": quantity(args.trigger, "force", "--trigger"),
            "gap": _gap(args),
            "hammer_channel": args.hammer_channel,
            "response": args.response,
            "timeout": quantity(args.timeout, "time", "--timeout"),
            "hit_force": quantity(args.hit_force, "force", "--hit-force"),
            "pulse": quantity(args.pulse, "time", "--pulse"),
        }
        quantity(args.f_max, "frequency", "--f-max")
        return TapTest(cfg, params, out, **kwargs)
    from rigtools.procedures.frf import FrfTest

    band = [quantity(t, "frequency", "--band") for t in args.band.split(":")]
    if len(band) != 2:
        raise UserError(f"--band = {args.band!r}: write low:high, e.g. '20 Hz:500 Hz'")
    params = {
        "signal": args.signal,
        "band": tuple(band),
        "level": quantity(args.level, "voltage", "--level"),
        "frame": quantity(args.frame, "time", "--frame"),
        "averages": args.averages,
        "gap": _gap(args),
        "seed": args.seed,
    }
    return FrfTest(cfg, params, out, **kwargs)


def _confirm(args):
    def confirm(gap: float, index: int) -> None:
        msg = f"point {index + 1}: set the shroud gap to {gap * 1e3:.3f} mm"
        if args.yes:
            print(f"rig acquire: {msg} (--yes: not waiting)", file=sys.stderr)
            return
        try:
            input(f"{msg}, then press Enter (Ctrl-C stops) ")
        except EOFError:
            raise UserError("no operator input (stdin closed); give --yes to run unattended") from None

    return confirm


class Display:
    """Rich progress on stderr (off with --json or when stderr is not a terminal)."""

    def __init__(self, args) -> None:
        self.enabled = not args.json and sys.stderr.isatty()
        self.args = args

    def __enter__(self):
        if self.enabled:
            from rich.console import Console
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            self.bar = Progress(
                TextColumn("{task.description}"),
                BarColumn(),
                TextColumn("{task.completed}/{task.total} points"),
                TimeElapsedColumn(),
                console=Console(stderr=True),
                transient=True,
            )
            self.bar.__enter__()
            self.task = self.bar.add_task(f"{self.args.procedure}", total=1)
        return self

    def event(self, e) -> None:
        if not self.enabled:
            return
        text = f"point {e.point}/{e.n_points} {e.kind}"
        if e.kind == "control" and e.control_error is not None:
            text += f" update {e.update}: error {e.control_error * 100:+.2f} % ({e.text})"
        elif e.text:
            text += f": {e.text}"
        done = e.point if e.kind == "point_done" else e.point - 1
        self.bar.update(self.task, total=e.n_points, completed=max(0, done), description=text)

    def __exit__(self, *exc):
        if self.enabled:
            self.bar.__exit__(*exc)
        return False


def _point_doc(p: dict, units: dict) -> dict:
    keys = (
        "fe",
        "force_amplitude",
        "force_amplitude_measured",
        "gap",
        "drive_amplitude",
        "control_updates",
        "settled",
        "direction",
        "study_value",
    )
    doc = {k: p[k] for k in keys if k in p}
    doc["channels"] = {
        name: {
            "units": units.get(name, ""),
            "peak": p["peaks"][name],
            "harmonics": [
                {"k": i + 1, "amplitude": a, "phase": ph}
                for i, (a, ph) in enumerate(zip(h["amplitude"], h["phase"]))
            ],
        }
        for name, h in p["harmonics"].items()
    }
    return doc


def report(args, proc, result) -> dict:
    doc = {
        "file": str(proc.out),
        "status": result.status.value,
        "reason": result.reason,
        "backend": args.backend,
        "procedure": args.procedure,
    }
    units = {s.name: s.units for s in getattr(proc, "specs", [])}
    if args.procedure == "dwell" and result.points:
        doc.update(_point_doc(result.points[0], units))
        doc["warnings"] = result.points[0]["safety_warnings"]
    elif args.procedure in ("sweep", "study"):
        doc["points"] = [
            {k: v for k, v in _point_doc(p, units).items() if k != "channels"} for p in result.points
        ]
        doc.update(result.summary)
    elif args.procedure == "frf" and result.status.value == "finished":
        from rigtools.procedures.frf import quick_check

        doc["check"] = quick_check(proc.out, proc.params.response)
    elif args.procedure == "tap":
        doc.update(result.summary)
        doc["hits_detail"] = result.points
        if result.status.value == "finished":
            from rigtools.procedures.tap import tap_analysis

            f_max = min(quantity(args.f_max, "frequency", "--f-max"), 0.45 * proc.rate)
            res = tap_analysis(proc.out, proc.response, f_min=5.0, f_max=f_max)
            doc["modes"] = [
                {"frequency_hz": m.frequency_hz, "damping_ratio": m.damping_ratio}
                for m in res.modes[proc.response].modes
            ]
    return doc


def print_summary(args, doc: dict) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console()
    if args.procedure == "dwell" and "fe" in doc:
        table = Table(
            title=f"sine dwell {doc['fe']:g} Hz, F0 {doc['force_amplitude']:g} N ({doc['backend']})"
        )
        for col in ("channel", "units", "1×fe", "largest k×fe, k ≥ 2", "peak"):
            table.add_column(col)
        for name, ch in doc["channels"].items():
            h = ch["harmonics"]
            top = max(h[1:], key=lambda r: r["amplitude"]) if len(h) > 1 else None
            table.add_row(
                name,
                ch["units"],
                f"{h[0]['amplitude']:.4g}",
                f"{top['amplitude']:.4g} (k = {top['k']})" if top else "-",
                f"{ch['peak']:.4g}",
            )
        console.print(table)
        console.print(
            f"force {doc['force_amplitude_measured']:.4g} N (target {doc['force_amplitude']:g} N) at "
            f"{doc['drive_amplitude']:.4g} V after {doc['control_updates']} updates; settled: "
            f"{'yes' if doc['settled'] else 'NO'}; wrote {doc['file']} ({doc['status']})"
        )
    elif args.procedure in ("sweep", "study"):
        table = Table(title=f"{args.procedure} ({doc['backend']}, {len(doc['points'])} points)")
        for col in ("fe Hz", "dir", "F0 N", "F1 N", "gap mm", "drive V", "updates", "settled"):
            table.add_column(col)
        for p in doc["points"]:
            table.add_row(
                f"{p['fe']:g}",
                p.get("direction", ""),
                f"{p['force_amplitude']:g}",
                f"{p['force_amplitude_measured']:.4g}",
                f"{p['gap'] * 1e3:.3g}",
                f"{p['drive_amplitude']:.3g}",
                str(p["control_updates"]),
                "yes" if p["settled"] else "NO",
            )
        console.print(table)
        for d, jumps in doc.get("jumps", {}).items():
            for j in jumps:
                console.print(
                    f"jump {d}: {j['from_hz']:g} -> {j['to_hz']:g} Hz ({j['kind']}, {j['change'] * 100:.0f} %)"
                )
        if "peak_hz" in doc:
            console.print(f"response peak per newton at {doc['peak_hz']:.4g} Hz")
        console.print(f"wrote {doc['file']} ({doc['status']})")
    elif args.procedure == "tap":
        console.print(
            f"{doc.get('accepted', 0)} of {doc.get('hits', 0)} hits accepted on "
            f"{doc.get('response', '')} / {doc.get('hammer', '')}"
        )
        for h in doc.get("hits_detail", []):
            if not h["accepted"]:
                console.print(f"hit {h['hit']} rejected: {h['reject_reason']}")
        if doc.get("modes"):
            table = Table(title="modes from H1 (response / hammer force)")
            for col in ("frequency Hz", "damping %"):
                table.add_column(col)
            for m in doc["modes"]:
                table.add_row(f"{m['frequency_hz']:.2f}", f"{m['damping_ratio'] * 100:.2f}")
            console.print(table)
        console.print(f"wrote {doc['file']} ({doc['status']})")
    elif args.procedure == "frf":
        chk = doc.get("check")
        if chk:
            table = Table(
                title=f"H1 {chk['response']}/{chk['force']}: {chk['averages']} averages, "
                f"{chk['resolution_hz']:g} Hz resolution"
            )
            for col in ("peak Hz", "|H1|", "coherence"):
                table.add_column(col)
            for pk in chk["peaks"]:
                table.add_row(f"{pk['frequency_hz']:g}", f"{pk['h1']:.4g}", f"{pk['coherence']:.4f}")
            console.print(table)
        console.print(f"wrote {doc['file']} ({doc['status']})")
