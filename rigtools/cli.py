"""The ``rig`` command line.

Each sub-command lives in its own module under :mod:`rigtools.commands` and exposes
``register(subparsers)``; modules are discovered, so adding a command never touches this file.
Errors a user can cause (:class:`rigtools.errors.UserError`) end in one line on stderr and a
non-zero exit status; programming errors still raise.

Exit status: 0 success, 1 a check found problems, 2 bad input (rig file, arguments, recording
file), 3 hardware or its driver not available, 4 a hardware fault stopped the run, 130 Ctrl-C.
"""

from __future__ import annotations

import os

# The FE eigen-solves are small dense problems: threaded BLAS only adds overhead. Set before numpy loads.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import importlib
import pkgutil
import sys

from drivers.contracts import DriverError, DriverUnavailable
from rigtools import commands
from rigtools.errors import UserError

DESCRIPTION = """\
Shrouded-blade vibro-impact rig toolkit.

Acquire on the NI rig or on the simulated rig, store runs as HDF5, simulate the same experiment
with the FE model, and compare. Every command uses the calibrated default rig unless --rig FILE
is given. Units are SI; lengths and other quantities may be given as strings like "0.5 mm".
"""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rig", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"rigtools.commands.{info.name}")
        if hasattr(module, "register"):
            module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except UserError as exc:
        print(f"rig {args.command}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except DriverUnavailable as exc:
        print(f"rig {args.command}: error: {exc}", file=sys.stderr)
        return 3
    except DriverError as exc:
        # A hardware fault that stopped the run; the drive was ramped to zero by the driver.
        print(f"rig {args.command}: error: {exc}", file=sys.stderr)
        return 4
    except KeyboardInterrupt:
        print(f"rig {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
