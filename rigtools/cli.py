"""The ``rig`` command line.

Each sub-command lives in its own module under :mod:`rigtools.commands` and exposes
``register(subparsers)``; modules are discovered, so adding a command never touches this file.
Discovery does not import them: the command list of ``rig --help`` is read from their source
(the ``help=`` of ``add_parser`` in ``register``, else the first docstring line), and only the
module of the command being run is imported. ``rig --help``, ``rig CMD --help`` and argument
errors therefore stay fast as long as command modules keep heavy imports inside functions.

Errors a user can cause (:class:`rigtools.errors.UserError`) end in one line on stderr and a
non-zero exit status; programming errors still raise.

Exit statuses: the one table :data:`rigtools.errors.EXIT_STATUSES` (``rig --help`` prints it).
On every signal the drive ramps to zero and a recording being written ends with status
``aborted`` and the signal in its ``abort_reason``.
"""

from __future__ import annotations

# Keep the top of this module to the standard library and rigtools.errors/runtime: `rig` imports
# it before anything can handle Ctrl-C.
import argparse
import ast
import errno
import importlib
import os
import pkgutil
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

from rigtools import errors
from rigtools.errors import UserError

DESCRIPTION = """\
Shrouded-blade vibro-impact rig toolkit.

Acquire on the NI rig or on the simulated rig, store runs as HDF5, simulate the same experiment
with the FE model, and compare. Every command uses the calibrated default rig unless --rig FILE
is given. Units are SI; lengths and other quantities may be given as strings like "0.5 mm".
"""

EPILOG = f"""\
exit status:
{errors.exit_status_table()}
  On a signal the drive ramps to zero and a recording ends with status "aborted", the signal
  named in its abort_reason; everything recorded before is kept.

examples:
  rig devices
  rig simulate --gap "0.5 mm" --force "15 N" --fe "60 Hz" --out sim.h5
  rig acquire dwell --backend sim --fe "60 Hz" --force "15 N" --gap "0.5 mm" --out run.h5
  rig info run.h5
  rig COMMAND --help
"""


class RigArgumentParser(argparse.ArgumentParser):
    """An argparse parser whose errors are one line plus a hint to ``--help`` (exit 2)."""

    def _get_value(self, action, arg_string):
        # an option's ``type=`` may be one of rigtools.options' checks (type=options.seed): its
        # UserError becomes the parser's one-line error, as a ValueError would
        try:
            return super()._get_value(action, arg_string)
        except UserError as exc:
            raise argparse.ArgumentError(None, errors.one_line(exc, None)) from None

    def _parse_optional(self, arg_string):
        # "-90deg", "-90°", "-100,0": a negative value with its unit or a list is the value of the
        # option before it (argparse takes it for an unknown option: "expected one argument")
        if (
            len(arg_string) > 1
            and arg_string[0] == "-"
            and (arg_string[1].isdigit() or arg_string[1] == ".")
            and arg_string not in self._option_string_actions
        ):
            return None
        return super()._parse_optional(arg_string)

    def error(self, message: str) -> NoReturn:
        text = errors.one_line(str(message), None)
        self.exit(errors.EXIT_USAGE, f"{self.prog}: error: {text}\n(see '{self.prog} --help')\n")


# -- command discovery without imports ---------------------------------------------------------
def _module_source(name: str) -> str | None:
    from rigtools import commands

    for folder in commands.__path__:
        path = Path(folder) / f"{name}.py"
        if path.is_file():
            try:
                return path.read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError):
                return None
    return None


def _string_value(node: ast.AST | None, names: dict[str, str]) -> str | None:
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.Name):
        return names.get(node.id)
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
        left, right = _string_value(node.left, names), _string_value(node.right, names)
        return left + right if left is not None and right is not None else None
    return None


def command_summaries(module: str, source: str | None) -> list[tuple[str, str]]:
    """``(command name, one-line help)`` pairs a command module registers, read from its source.

    Looks for ``add_parser("NAME", help=...)`` calls inside ``register`` (help as a string
    literal or a module-level string constant); falls back to the module name and the first line
    of the module docstring. Never imports the module.
    """
    found: list[tuple[str, str]] = []
    doc = ""
    if source is not None:
        try:
            tree = ast.parse(source)
        except SyntaxError:
            tree = None
        if tree is not None:
            first = (ast.get_docstring(tree) or "").strip().splitlines()[0:1]
            doc = first[0] if first else ""
            names: dict[str, str] = {}
            for stmt in tree.body:
                if (
                    isinstance(stmt, ast.Assign)
                    and len(stmt.targets) == 1
                    and isinstance(stmt.targets[0], ast.Name)
                ):
                    value = _string_value(stmt.value, names)
                    if value is not None:
                        names[stmt.targets[0].id] = value
            for stmt in tree.body:
                if isinstance(stmt, ast.FunctionDef) and stmt.name == "register":
                    for node in ast.walk(stmt):
                        if (
                            isinstance(node, ast.Call)
                            and isinstance(node.func, ast.Attribute)
                            and node.func.attr == "add_parser"
                            and node.args
                        ):
                            name = _string_value(node.args[0], names)
                            if name is None:
                                continue
                            helps = [k.value for k in node.keywords if k.arg == "help"]
                            text = _string_value(helps[0], names) if helps else None
                            found.append((name, text if text is not None else doc))
    if not found:
        found.append((module, doc))
    return [(name, " ".join(text.split()) if text else "") for name, text in found]


def discover_commands() -> dict[str, str]:
    """Command name -> module name of every ``rigtools.commands`` module, without importing it."""
    from rigtools import commands

    table: dict[str, str] = {}
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        for name, _ in command_summaries(info.name, _module_source(info.name)):
            table.setdefault(name, info.name)
    return table


def _chosen_command(argv: Sequence[str], known: dict[str, str]) -> str | None:
    """The sub-command named on the command line (first non-option word), if it is known."""
    for arg in argv:
        if arg == "--":
            return None
        if not arg.startswith("-"):
            return arg if arg in known else None
    return None


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The ``rig`` parser. Only the module of the command named in ``argv`` is imported and
    registers its full parser; the others appear in the command list with their help line.
    ``argv=None`` imports and registers every command (for documentation and tests)."""
    parser = RigArgumentParser(
        prog="rig",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=_version())
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=RigArgumentParser)
    parser.rig_commands = sub  # type: ignore[attr-defined]
    from rigtools import commands

    modules = sorted(m.name for m in pkgutil.iter_modules(commands.__path__) if not m.name.startswith("_"))
    table = discover_commands()
    chosen = _chosen_command(argv, table) if argv is not None else None
    for module_name in modules:
        if argv is None or (chosen is not None and table[chosen] == module_name):
            module = importlib.import_module(f"rigtools.commands.{module_name}")
            if hasattr(module, "register"):
                module.register(sub)
            continue
        for name, text in command_summaries(module_name, _module_source(module_name)):
            sub.add_parser(name, help=text, add_help=False)
    return parser


def _version() -> str:
    from rigtools import __version__

    return f"rig {__version__}"


# -- running a command -------------------------------------------------------------------------
def _say(line: str) -> None:
    try:
        print(line, file=sys.stderr, flush=True)
    except (OSError, ValueError):  # stderr gone (closed terminal): the exit status still tells
        pass


def _driver_error_code(exc: BaseException) -> int | None:
    """3 for drivers.DriverUnavailable, 4 for another drivers.DriverError, 2 for a
    rigtools.sim.params.SimulationInputError (physics parameters a user gave, or a run they made diverge),
    None otherwise. Those modules are only consulted if something already imported them."""
    contracts = sys.modules.get("rigtools.drivers.contracts")
    if contracts is not None:
        if isinstance(exc, contracts.DriverUnavailable):
            return errors.EXIT_HARDWARE
        if isinstance(exc, contracts.DriverError):
            return errors.EXIT_FAULT
    params = sys.modules.get("rigtools.sim.params")
    if params is not None and isinstance(exc, params.SimulationInputError):
        return errors.EXIT_USAGE
    return None


#: errno of a path a user named (exit 2) and of a full or failing output (exit 4)
_PATH_ERRNOS = frozenset(
    getattr(errno, n, -1) for n in ("ENAMETOOLONG", "ENOENT", "ENOTDIR", "EISDIR", "ELOOP", "EACCES", "EROFS")
)
_WRITE_ERRNOS = frozenset(getattr(errno, n, -1) for n in ("ENOSPC", "EFBIG", "EDQUOT", "EIO"))


def _os_error_code(exc: OSError) -> int | None:
    """2 for an OSError about a path the user named, 4 for a full disk or failing output (stdout on
    a full device), None for anything else (a programming error: raised)."""
    if exc.errno in _WRITE_ERRNOS:
        return errors.EXIT_FAULT
    if exc.errno in _PATH_ERRNOS and exc.filename is not None:
        return errors.EXIT_USAGE
    return None


def _run(argv: list[str]) -> int:
    command = "rig"
    try:
        from rigtools import runtime

        runtime.last_stop = None  # this run's stop requests only
        runtime.configure_process()  # before any command module can load numpy
        try:
            parser = build_parser(argv)
        except ImportError as exc:  # a command module's top-level import of a missing package
            chosen = _chosen_command(argv, discover_commands())
            _say(f"rig {chosen or ''}: error: cannot load this command: {exc}".replace("  ", " "))
            return errors.EXIT_HARDWARE
        try:
            args, extra = parser.parse_known_args(argv)
            if extra:  # say it as the sub-command's error, not the top level's
                sub = getattr(parser, "rig_commands", None)
                owner = sub.choices.get(getattr(args, "command", None) or "", parser) if sub else parser
                owner.error(f"unrecognized arguments: {' '.join(extra)}")
        except SystemExit as exc:  # argument errors (one line, exit 2), --help, --version
            if exc.code in (0, None):
                raise  # --help/--version end as argparse ends them: SystemExit(0)
            return exc.code if isinstance(exc.code, int) else errors.EXIT_USAGE
        if not getattr(args, "func", None):
            parser.print_help()
            return errors.EXIT_USAGE
        command = f"rig {args.command}"
        if not getattr(args, "skip_damaged", False):  # the reader's default: a command that opens
            return _unless_stopped(command, int(args.func(args) or 0))  # no recording: no reader loaded
        from rigtools.recording.reader import reading_damaged

        with reading_damaged():
            return _unless_stopped(command, int(args.func(args) or 0))
    except UserError as exc:
        _say(f"{command}: error: {errors.one_line(exc, None)}")
        return exc.exit_code
    except OSError as exc:
        code = _os_error_code(exc)
        if code is None:
            raise
        where = f"{exc.filename}: " if exc.filename else "cannot write the output: "
        _say(f"{command}: error: {where}{exc.strerror or errors.one_line(exc, None)}")
        return code
    except KeyboardInterrupt as exc:
        text = str(exc) if isinstance(exc, errors.Interrupted) else "interrupted (Ctrl-C)"
        _say(f"{command}: {text}")
        return getattr(exc, "exit_code", errors.EXIT_SIGINT)
    except Exception as exc:
        stop = getattr(sys.modules.get("rigtools.runtime"), "last_stop", None)
        if stop is not None:  # a library wrapped the signal's exception in its own (pydantic)
            _say(f"{command}: {stop}")
            return stop.exit_code
        code = _driver_error_code(exc)
        if code is None:
            raise
        # A DriverError is a hardware fault that stopped the run; the driver ramped the drive to 0.
        _say(f"{command}: error: {errors.one_line(exc, None)}")
        return code


def _unless_stopped(command: str, code: int) -> int:
    """``code``, unless a stop signal came and a library swallowed its exception (a compiler's
    callback, a broad ``except``) so that the command ended as if none had: then the signal's
    line and status (128 + n), as a scheduler expects of a signalled job."""
    stop = getattr(sys.modules.get("rigtools.runtime"), "last_stop", None)
    if code == 0 and stop is not None:
        _say(f"{command}: {stop}")
        return int(stop.exit_code)
    return code


def main(argv: list[str] | None = None) -> int:
    """Run ``rig`` with ``argv`` (default ``sys.argv[1:]``); returns the exit status.

    ``--help`` and ``--version`` raise ``SystemExit(0)`` after printing, as argparse does;
    argument errors return 2 after one line and a hint.

    SIGINT, SIGTERM and SIGHUP are turned into :class:`rigtools.errors.Interrupted` for the
    whole run (start-up included) and the previous handlers restored after; stdout and stderr
    print any character; a closed stdout pipe ends quietly with status 141.
    """
    try:
        from rigtools.runtime import configure_console, handle_stop_signals, silence_stdout

        argv = list(sys.argv[1:] if argv is None else argv)
        if sys.stdout is None:  # started with stdout closed (rig modal >&-): print into nothing
            sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - lives as long as the process
        configure_console()
        try:
            with handle_stop_signals(ignore_after_stop=True), errors.command_line():
                code = _run(argv)
                sys.stdout.flush()
            return code
        except BrokenPipeError:
            silence_stdout()
            return errors.EXIT_SIGPIPE
        except OSError as exc:  # stdout on a full device: the flush after the command failed
            if exc.errno not in _WRITE_ERRNOS:
                raise
            silence_stdout()
            _say(f"rig: error: cannot write the output: {exc.strerror}")
            return errors.EXIT_FAULT
        except SystemExit as exc:
            # rich handles a closed stdout itself: stdout to devnull, then SystemExit(1)
            if isinstance(exc.__context__, BrokenPipeError):
                silence_stdout()
                return errors.EXIT_SIGPIPE
            if exc.code in (0, None):
                try:
                    sys.stdout.flush()
                except BrokenPipeError:
                    silence_stdout()
                    return errors.EXIT_SIGPIPE
            raise
    except KeyboardInterrupt as exc:  # before the handlers were installed, or after _run
        text = str(exc) if isinstance(exc, errors.Interrupted) else "interrupted (Ctrl-C)"
        _say(f"rig: {text}")
        return getattr(exc, "exit_code", errors.EXIT_SIGINT)


if __name__ == "__main__":
    sys.exit(main())
