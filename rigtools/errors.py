"""Errors a user can cause, and the exit statuses of ``rig``. The CLI turns them into one line."""

from __future__ import annotations

import functools
import re
import signal as _signal
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from typing import ParamSpec, TypeVar

_P = ParamSpec("_P")
_R = TypeVar("_R")

from rigtools.drivers import errors as _driver_errors

#: The one rule of an error's one line (:func:`rigtools.drivers.errors.one_line`): it lives where
#: the drivers, which import nothing of the orchestration, can use it too.
one_line = _driver_errors.one_line

#: Exit statuses of ``rig`` (also in ``rig --help``).
EXIT_OK = 0
EXIT_PROBLEMS = 1  # a check found problems
EXIT_USAGE = 2  # bad input: arguments, rig file, recording file
EXIT_HARDWARE = 3  # hardware or its driver not available
EXIT_FAULT = 4  # a hardware fault, safety abort or write error stopped the run
EXIT_NOT_REACHED = 5  # the force target cannot be reached within the rig's limits (status failed)
EXIT_STOPPED = 6  # stopped from the monitor's page (rig acquire --monitor --allow-stop; status aborted)
EXIT_SIGHUP = 128 + 1  # 129: terminal closed (SIGHUP)
EXIT_SIGINT = 128 + 2  # 130: Ctrl-C (SIGINT)
EXIT_SIGPIPE = 128 + 13  # 141: the reader of stdout went away (`rig ... | head`)
EXIT_SIGTERM = 128 + 15  # 143: terminated (SIGTERM: kill, timeout, a job scheduler)

_KEPT = "drive ramped to zero, recording kept as aborted"
#: How each signal's exit status is named (``rig`` answers 130, 143 and 129 by signal).
SIGNAL_NAMES: dict[int, str] = {
    EXIT_SIGINT: "Ctrl-C (SIGINT)",
    EXIT_SIGTERM: "SIGTERM (kill, timeout, a job scheduler)",
    EXIT_SIGHUP: "SIGHUP (terminal closed)",
}
#: The one table of exit statuses: ``rig --help``, every command's help (:func:`exit_status_help`)
#: and the README show these words (a test holds the README to it).
EXIT_STATUSES: dict[int, str] = {
    EXIT_OK: "success",
    EXIT_PROBLEMS: "a check found problems",
    EXIT_USAGE: "bad input: arguments, rig file, recording file (one line naming it)",
    EXIT_HARDWARE: "hardware or its driver not available (use --backend sim)",
    EXIT_FAULT: "a hardware fault, safety abort or write error stopped the run (status failed, file kept)",
    EXIT_NOT_REACHED: "the force target cannot be reached within the rig's limits (status failed, file kept)",
    EXIT_STOPPED: f"stopped from the monitor's page (--monitor --allow-stop; {_KEPT})",
    EXIT_SIGHUP: f"{SIGNAL_NAMES[EXIT_SIGHUP]}; a run: {_KEPT}",
    EXIT_SIGINT: f"{SIGNAL_NAMES[EXIT_SIGINT]}; a run: {_KEPT}",
    EXIT_SIGPIPE: "stdout closed by its reader (rig ... piped into head)",
    EXIT_SIGTERM: f"{SIGNAL_NAMES[EXIT_SIGTERM]}; a run: {_KEPT}",
}
#: The statuses of a stop by a signal, which every command answers.
SIGNAL_STATUSES = (EXIT_SIGINT, EXIT_SIGTERM, EXIT_SIGHUP)


def exit_status_table(indent: str = "  ") -> str:
    """:data:`EXIT_STATUSES` as the lines of ``rig --help`` (``  130  Ctrl-C, SIGINT (...)``)."""
    return "\n".join(f"{indent}{code:<4} {text}" for code, text in EXIT_STATUSES.items())


def exit_status_help(
    *codes: int, notes: dict[int, str] | None = None, run: bool = False, width: int = 96
) -> str:
    """A command's ``Exit status:`` paragraph: ``codes`` (then 130, 143, 129, which every command
    answers) in the words of :data:`EXIT_STATUSES`, or in a command's own words ``notes[code]``
    (what "success" or "bad input" means for it); ``run``: the command drives the rig (a signal
    ramps the drive to zero and keeps the recording as aborted), else a signal is only named.

    Examples
    --------
    >>> text = exit_status_help(0, 2, notes={0: "written"}, width=1000)
    >>> text.split("; ")[:3]
    ['Exit status: 0 written', '2 bad input: arguments, rig file, recording file (one line naming it)', \
'130 Ctrl-C (SIGINT)']
    """
    import textwrap

    notes = notes or {}
    shown = list(dict.fromkeys([*codes, *SIGNAL_STATUSES]))
    words = {**EXIT_STATUSES, **({} if run else SIGNAL_NAMES), **notes}
    # a no-break space keeps each status with its first word when the paragraph is wrapped
    parts = [f"{c}\u00a0{words[c]}" for c in shown]
    text = textwrap.fill("Exit status: " + "; ".join(parts) + ".", width=width, break_on_hyphens=False)
    return text.replace("\u00a0", " ")


# Errors advise in the caller's language: `rig`'s entry point (rigtools.cli.main) runs the command
# inside command_line(); everything else (a script, a notebook, the tests) is a script. A plain
# flag, not a context variable: the advice may be written in a worker thread of the command.
_command_line = False


@contextmanager
def command_line() -> Iterator[None]:
    """Within it, errors advise in ``rig``'s words (``--backend sim``); outside, in a script's
    (``backend="sim"``). ``rig``'s entry point runs every command inside it."""
    global _command_line
    before, _command_line = _command_line, True
    try:
        yield
    finally:
        _command_line = before


def on_command_line() -> bool:
    """True while ``rig`` runs a command (:func:`command_line`), False in a script."""
    return _command_line


def option(name: str, value: object = None, *, flag: str | None = None) -> str:
    """How the caller gives option ``name``, for an error's advice: ``--name VALUE`` on the
    command line, ``name=VALUE`` in a script.

    Parameters
    ----------
    name
        The keyword of the Python function (``"backend"``, ``"record_periods"``).
    value
        The value advised; ``True``: a switch (``--overwrite`` / ``overwrite=True``); ``None``:
        the name alone (``--rig`` / ``rig``).
    flag
        The command line's option when it is not ``--`` and the name with ``-`` for ``_``
        (``"--periods"`` for ``record_periods``).

    Examples
    --------
    >>> from rigtools.errors import option, command_line
    >>> option("backend", "sim"), option("overwrite", True), option("frf", "FRF.h5")
    ('backend="sim"', 'overwrite=True', 'frf="FRF.h5"')
    >>> with command_line():
    ...     option("backend", "sim"), option("gap", "0.5 mm"), option("record_periods", 10, flag="--periods")
    ('--backend sim', '--gap "0.5 mm"', '--periods 10')
    """
    if _command_line:
        cli = flag or "--" + name.replace("_", "-")
        if value is None or value is True:
            return cli
        text = str(value)
        return f'{cli} "{text}"' if " " in text else f"{cli} {text}"
    if value is None:
        return name
    return f"{name}={value!r}".replace("'", '"') if isinstance(value, str) else f"{name}={value!r}"


# Advice the drivers write in rig's words (they cannot import this module): a script's words.
_SCRIPT_WORDS = {"--backend sim": 'backend="sim"', "--backend nidaq": 'backend="nidaq"'}
#: Options of the readers and importers by their keyword in the Python doors (analyze_recording,
#: import_tdms/lvm/uff): what a message written in rig's words names in a script's.
SCRIPT_KEYWORDS = {
    "--kind": "kind",
    "--method": "method",
    "--band": "options.band",
    "--channels": "channels",
    "--fe": "fe",
    "--map": "mapping",
    "--units": "units",
    "--channel": "channels",
    "--group": "groups",
    "--sample-rate": "sample_rate",
    "--reference": "reference",
}
_FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*(?![\w-])")


def in_callers_words(text: str, keywords: Mapping[str, str] | None = None) -> str:
    """``text`` with the command line's advice (``use --backend sim``, ``give --units X=UNIT``)
    in a script's words (``use backend="sim"``, ``give units X=UNIT``) when the caller is a
    script; unchanged on the command line. ``keywords``: one door's own options by its keyword
    (``{"--force": "forces"}``), before :data:`SCRIPT_KEYWORDS`."""
    if _command_line:
        return text
    for cli, script in _SCRIPT_WORDS.items():
        text = text.replace(cli, script)
    words = {**SCRIPT_KEYWORDS, **(keywords or {})}
    return _FLAG.sub(lambda m: words.get(m.group(0), m.group(0)), text)


def in_script_words(function: Callable[_P, _R]) -> Callable[_P, _R]:
    """A Python door whose :class:`UserError` advice is in the caller's words
    (``in_callers_words``): ``units`` and ``mapping=`` in a script, ``--units`` and ``--map``
    under ``rig``."""

    @functools.wraps(function)
    def door(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        try:
            return function(*args, **kwargs)
        except UserError as exc:
            reword(exc)
            raise

    return door


def reword(error: BaseException, keywords: Mapping[str, str] | None = None) -> BaseException:
    """``error`` with its one-argument message in the caller's words (:func:`in_callers_words`,
    with the door's ``keywords``), for the doors of a script to re-raise."""
    if len(error.args) == 1 and isinstance(error.args[0], str):
        error.args = (in_callers_words(error.args[0], keywords),)
    return error


class UserError(Exception):
    """Bad input from the user (config, command line, file). Exit status 2 by default.

    Its text is one line naming what is wrong; the CLI prints it without a traceback.

    Examples
    --------
    >>> import rigtools
    >>> try:
    ...     rigtools.dwell("60 Hz", "15 Hz", "never-written.h5", backend="sim")
    ... except rigtools.UserError as exc:
    ...     print(exc)
    force = '15 Hz': '15 Hz' is a frequency, expected a force
    """

    exit_code = EXIT_USAGE


class ConfigError(UserError):
    """A rig file that does not validate."""


class FaultError(UserError):
    """A fault, a safety abort or a write error stopped the work (exit status 4, :data:`EXIT_FAULT`).
    Every error that ends ``rig`` with status 4 is one of these (or a driver fault)."""

    exit_code = EXIT_FAULT


class TargetNotReached(FaultError):
    """The force target cannot be reached within the rig's limits (max drive, a channel's
    warning level): the recording is kept with status ``failed`` and the reason (exit status 5,
    :data:`EXIT_NOT_REACHED`)."""

    exit_code = EXIT_NOT_REACHED


class HardwareUnavailable(UserError):
    """Hardware or its driver is not present on this machine."""

    exit_code = EXIT_HARDWARE


_SIGNAL_TEXT = {
    "SIGINT": "interrupted (Ctrl-C)",
    "SIGTERM": "terminated (kill, timeout or a job scheduler)",
    "SIGHUP": "hung up (terminal closed)",
}


class Interrupted(KeyboardInterrupt):
    """A stop request by a signal (SIGINT, SIGTERM, SIGHUP), raised in the main thread.

    A :class:`KeyboardInterrupt`, so every path that handles Ctrl-C (drive ramped to zero,
    recording marked ``aborted``, everything finished kept) handles SIGTERM and SIGHUP alike.
    ``str(exc)`` is the one line for the user and a recording's ``abort_reason``, naming the
    signal; :attr:`exit_code` is 128 + the signal number.

    Parameters
    ----------
    signum
        The signal number.
    """

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        try:
            self.signal_name = _signal.Signals(self.signum).name
        except ValueError:
            self.signal_name = f"signal {self.signum}"
        self.exit_code = 128 + self.signum
        text = _SIGNAL_TEXT.get(self.signal_name, f"stopped by {self.signal_name}")
        super().__init__(f"{self.signal_name}: {text}")

    @property
    def reason(self) -> str:
        """The one line for a recording's ``abort_reason`` and the user."""
        return str(self)
