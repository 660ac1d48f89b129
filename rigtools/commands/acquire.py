"""``rig acquire dwell|sweep|study|frf|tap``: lab procedures on the rig (NI-DAQmx) or the simulated rig.

Parse, call :mod:`rigtools.procedures.from_options`, print (:mod:`rigtools.procedures.summary`).
Top-level imports stay light (``rig --help``).
"""

from __future__ import annotations

import argparse
import os
import sys

from rigtools import json_values
from rigtools.errors import EXIT_SIGINT, UserError
from rigtools.monitor.beside import OPTIONS as MONITOR_OPTIONS
from rigtools.monitor.beside import stopped_from_monitor
from rigtools.options import HDF5_SUFFIXES, check_out, seed
from rigtools.procedure_help import COMMON_EPILOG, PROCEDURE_HELP, PROCEDURE_OPTIONS, epilog

# literal here: `rig --help` reads each command's HELP from its source without importing it
HELP = "lab procedures on the rig: force-controlled dwell, stepped sine, study, FRF and tap tests, CBC, PLL"

COMMON_OPTIONS: tuple[tuple[str, dict], ...] = (
    ("--gap", {"default": None, "help": 'shroud gap, e.g. "0.5 mm" (default: as set / the rig file)'}),
    (
        "--backend",
        {
            "choices": ("nidaq", "sim"),
            "default": "nidaq",
            "help": "nidaq: the NI-DAQmx rig (default); sim: the simulated rig",
        },
    ),
    ("--rig", {"metavar": "FILE", "help": "rig file (TOML); default: the calibrated default rig"}),
    ("--out", {"required": True, "metavar": "FILE", "help": "HDF5 recording to write"}),
    ("--overwrite", {"action": "store_true", "help": "replace --out if it exists"}),
    ("--json", {"action": "store_true", "help": "print the results as JSON"}),
    ("--pace", {"action": "store_true", "help": "simulated rig: real time"}),
    ("--seed", {"type": seed, "default": None, "help": "simulated rig: noise seed (default 0: runs repeat)"}),
    (
        "--fault",
        {
            "action": "append",
            "default": [],
            "metavar": "KIND@TIME[:CHANNEL]",
            "help": "simulated rig: inject a fault TIME s from the start (repeatable)",
        },
    ),
)


def register(subparsers: argparse._SubParsersAction) -> None:
    raw = argparse.RawDescriptionHelpFormatter
    p = subparsers.add_parser(
        "acquire", help=HELP, description=HELP + ".", epilog=COMMON_EPILOG, formatter_class=raw
    )
    sub = p.add_subparsers(dest="procedure", metavar="PROCEDURE", required=True)
    for name, text in PROCEDURE_HELP.items():
        q = sub.add_parser(name, help=text, description=text + ".", epilog=epilog(name), formatter_class=raw)
        for procedures, flags, keywords in PROCEDURE_OPTIONS:
            if name in procedures:
                q.add_argument(*flags, **keywords)
        for flag, keywords in COMMON_OPTIONS + MONITOR_OPTIONS:
            q.add_argument(flag, **keywords)
        q.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.config import load_rig
    from rigtools.monitor.beside import monitor_beside
    from rigtools.procedures import from_options as opts
    from rigtools.procedures.base import Status
    from rigtools.progress import ProcedureProgress

    out = _resume_out(args.out) if getattr(args, "resume", False) else check_out(args, suffixes=HDF5_SUFFIXES)
    cfg = load_rig(args.rig)
    faults = opts.parse_faults(args.fault, args.backend)
    run_options = {"backend": args.backend, "overwrite": args.overwrite, "pace": args.pace, "seed": args.seed}
    confirm = _confirm(args.yes) if args.procedure == "study" else None
    proc = opts.build_procedure(
        args.procedure, cfg, out, vars(args), confirm_gap=confirm, faults=faults, **run_options
    )
    if getattr(proc, "note", ""):
        print(f"rig acquire {args.procedure}: {proc.note}", file=sys.stderr)
    try:
        with (
            ProcedureProgress(args.procedure, enabled=not args.json) as display,
            monitor_beside(args, out, proc, display.event) as progress,
            opts.document_if_ended(vars(args), proc, json_values.print_document),
        ):
            proc._progress = progress
            result = proc.run()
    except KeyboardInterrupt as exc:
        _exit_interrupted(proc, getattr(exc, "exit_code", EXIT_SIGINT))
    sys.stderr.write("".join(f"rig acquire {args.procedure}: {x}\n" for x in getattr(proc, "lost", [])))
    f_max = getattr(args, "f_max", "2 kHz")
    with opts.document_if_ended(vars(args), proc, json_values.print_document):  # a stop in the analysis
        doc = opts.result_document(args.procedure, args.backend, proc, result, f_max)
    if args.json:
        json_values.print_document(doc)
    else:
        from rich.console import Console

        from rigtools.procedures.summary import summary_tables

        console = Console()
        for item in summary_tables(doc):
            console.print(item)
    if result.status is Status.FINISHED:
        return 0
    return stopped_from_monitor(result.reason, proc.out) or EXIT_SIGINT


def _exit_interrupted(proc, code: int) -> None:
    """Ctrl-C or a signal: the drive is at zero, the recording closed with status aborted. Say so in one
    line, leave at once (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP): the interpreter's teardown takes a second."""
    reason = proc.result.reason if proc.result is not None else "interrupted"
    print(
        f"rig acquire: interrupted ({reason}); drive ramped to zero; {proc.out} kept with status aborted",
        file=sys.stderr,
    )
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def _resume_out(text: str):
    from pathlib import Path

    from rigtools.write_targets import writable_target

    out = Path(text)
    writable_target(out, f"--out = {text!r}")
    if not out.exists() and not out.with_name(out.name + ".resume-source").exists():
        raise UserError(f"--resume: {text!r} does not exist; run without --resume to start the study")
    return out


def _confirm(yes: bool):
    def confirm(gap: float, index: int) -> None:
        msg = f"point {index + 1}: set the shroud gap to {gap * 1e3:.3f} mm"
        if yes:
            print(f"rig acquire: {msg} (--yes: not waiting)", file=sys.stderr)
            return
        try:
            input(f"{msg}, then press Enter (Ctrl-C stops) ")
        except EOFError:
            raise UserError("no operator input (stdin closed); give --yes to run unattended") from None

    return confirm
