"""The example commands of `rig --help`, of every `rig COMMAND [PROCEDURE] --help` and of
recordings/README.md run as written (on the simulated rig, in a temporary folder; README's tour
is run by test_demo_report.py, and with it README's `rig demo --quick`, which is also the example
of `rig demo --help`: run there once, checked there)."""

import argparse
import contextlib
import json
import os
import re
import shlex
import signal
import subprocess
import sys
import threading
import urllib.parse
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_cli
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter
from test_demo_report import shell_commands

from rigtools.branches import DIMENSION
from rigtools.branches_file import read_branches
from rigtools.cli import build_parser, main
from rigtools.config import default_rig_text
from rigtools.drivers.nidaq import NO_DRIVER_MESSAGE, NOT_SUPPORTED_MESSAGE
from rigtools.options import quantity
from rigtools.recording import check_recording

ROOT = Path(__file__).resolve().parents[2]


def _rig(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``rig ARGS`` in the folder ``cwd``: ``--help`` in a process of its own (argparse exits), a
    command in this process as the command examples below (a process per command cost ~2 s of
    CPU for the imports alone)."""
    if "--help" not in args:
        with contextlib.chdir(cwd):
            code, out, err = run_cli(args)
        return subprocess.CompletedProcess(args, code, out, err)
    return subprocess.run(
        [sys.executable, "-m", "rigtools.cli", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        env={**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])},
    )


def help_examples(text: str) -> list[list[str]]:
    """The command lines under ``examples:`` of a help text, as argument lists after ``rig``."""
    block = text.split("examples:", 1)[1] if "examples:" in text else ""
    out = []
    for line in block.splitlines():
        if not line.startswith("  rig "):
            if out and not line.strip():
                break
            continue
        args = shlex.split(line.split("#", 1)[0])[1:]
        if "COMMAND" not in args:
            out.append(args)
    return out


def test_rig_help_examples_run(tmp_path):
    shown = _rig(["--help"], tmp_path)
    assert shown.returncode == 0
    commands = help_examples(shown.stdout)
    assert len(commands) >= 3 and any(c[:1] == ["acquire"] for c in commands)
    for args in commands:
        done = _rig(args, tmp_path)
        # rig devices exits 3 when no backend can be listed (no NI driver, no VISA library here):
        # its output then names the option that exists, never a removed one
        allowed = (0, 3) if args == ["devices"] else (0,)
        assert done.returncode in allowed, f"rig {shlex.join(args)}: {done.stderr}"
        if args == ["devices"]:
            assert "--simulated" not in done.stdout + done.stderr
            assert "--backend sim" in done.stdout + done.stderr


def test_recordings_readme_commands_run(tmp_path):
    text = (ROOT / "recordings" / "README.md").read_text()
    lines = [line for line in text.splitlines() if line.startswith(".venv/bin/rig ")]
    assert len(lines) == 3
    (tmp_path / "recordings").mkdir()
    for line in lines:
        args = shlex.split(line)[1:]
        done = _rig(args, tmp_path)
        assert done.returncode == 0, f"{line}: {done.stderr}"
    assert re.search(r"complete", _rig(["info", "recordings/first.h5"], tmp_path).stdout)


# -- the examples of every `rig COMMAND --help` ------------------------------------------------
# Run in one folder, producers before readers: an example reads only what an earlier one wrote,
# or the two files a lab brings (its rig file lab.toml, a LabVIEW log log.tdms; see `examples`).
ORDER = (
    "devices",
    "simulate",
    "acquire",
    "update",
    "study",
    "harmonic",
    "modal",
    "continuation",
    "analyze",
    "info",
    "check",
    "monitor",
    "export",
    "import",
    "compare",
    "report",
    "demo",
)
PARSER = build_parser()


def _sub_parsers(parser: argparse.ArgumentParser) -> Iterator[argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in dict.fromkeys(action.choices.values()):  # an alias shares its parser
                yield sub
                yield from _sub_parsers(sub)


def _shell(line: list[str]) -> tuple[list[str], str | None, list[str] | None]:
    """``(rig arguments, file after >, command after |)`` of an example line."""
    for i, word in enumerate(line):
        if word == ">":
            return line[:i], line[i + 1], None
        if word == "|":
            return line[:i], None, line[i + 1 :]
    return line, None, None


def _on_hardware(args: list[str]) -> bool:
    """An example that drives the NI rig: an acquire procedure on --backend nidaq (the default)."""
    namespace = PARSER.parse_args(args)
    return getattr(namespace, "backend", None) == "nidaq"


def _full_demo(args: list[str]) -> bool:
    return args[0] == "demo" and not PARSER.parse_args(args).quick


def _readme_demo(args: list[str]) -> bool:
    """The example is README's ``rig demo --quick`` to the letter: test_demo_report.py runs it
    (exit 0, its recordings, findings, report and branches checked); a demo costs ~40 s of CPU,
    so it is not run a second time here."""
    readme = [shlex.split(c) for c in shell_commands() if " demo " in f"{c} "]
    return args[0] == "demo" and any(Path(c[0]).name == "rig" and c[1:] == args for c in readme)


def _ni_installed() -> bool:
    from nidaqmx.errors import DaqNotFoundError, DaqNotSupportedError
    from nidaqmx.system import System

    try:
        _ = System.local().driver_version
    except (DaqNotFoundError, DaqNotSupportedError):
        return False
    return True  # pragma: no cover - only on a machine with NI-DAQmx


def command_examples() -> list[list[str]]:
    """Every example line of every command's and sub-command's --help, in running order."""
    lines = [line for sub in _sub_parsers(PARSER) for line in help_examples(sub.format_help())]
    return sorted(lines, key=lambda line: (not _on_hardware(_shell(line)[0]), ORDER.index(line[0])))


EXAMPLES = command_examples()


def test_every_command_shows_examples():
    """Each command's --help (or, for acquire, each procedure's) shows examples, and each is
    placed in ORDER (a new command must say where it runs)."""
    commands = {line[0] for line in EXAMPLES}
    assert commands == set(ORDER) and len(EXAMPLES) >= 50
    by_procedure = {line[1] for line in EXAMPLES if line[0] == "acquire"}
    assert by_procedure == {"dwell", "sweep", "study", "frf", "tap", "pll", "cbc"}


def _help(argv: list[str], capsys) -> str:
    with pytest.raises(SystemExit):
        main([*argv, "--help"])
    return capsys.readouterr().out


def test_acquire_help_names_pll_and_cbc_and_their_python_doors(capsys):
    """``rig acquire --help`` names the PLL and CBC; each procedure's help names its front-door
    function (a script writer's way in) and CBC's lists its --json keys beyond the points."""
    head = _help(["acquire"], capsys).splitlines()[2]
    assert "CBC" in head and "PLL" in head
    for procedure, door in (
        ("cbc", "rigtools.control_based_continuation"),
        ("pll", "rigtools.phase_locked_loop"),
    ):
        text = " ".join(_help(["acquire", procedure], capsys).split())
        assert f"In Python: {door}(" in text and f"{door} ({procedure})" in text
        if procedure == "cbc":
            assert '"lost" gives one line per target' in text and '"skipped_amplitudes"' in text


def _monitor(args: list[str], folder: Path) -> tuple[int, str, str]:
    """``rig monitor ...`` serves until Ctrl-C: run it in its own process, load the page at the
    address it prints (through loopback), then press Ctrl-C. Returns (exit status, the page's HTTP
    status, stderr)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    cmd = [sys.executable, "-m", "rigtools.cli", *args]
    server = subprocess.Popen(
        cmd, cwd=folder, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    timer = threading.Timer(60, server.kill)
    timer.start()
    try:
        url = urllib.parse.urlsplit(server.stdout.readline().strip())
        page = url._replace(netloc=f"127.0.0.1:{url.port}").geturl() if url.port else ""
        with urllib.request.urlopen(page, timeout=20) as response:
            status = str(response.status)
        server.send_signal(signal.SIGINT)
        _, err = server.communicate(timeout=30)
    finally:
        timer.cancel()
        server.kill()
    return server.wait(), status, err


class _Runner:
    """Runs the examples in order in one folder, each once, in this process (``> FILE`` writes
    the captured output to FILE): asking for example i runs every earlier one first, so a test
    selected alone still finds the files it reads."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.done: dict[int, tuple[int, str, str]] = {}
        self.ni = _ni_installed()

    def result(self, i: int) -> tuple[int, str, str]:
        for j in range(i + 1):
            args, redirect, _ = _shell(EXAMPLES[j])
            if j in self.done or _full_demo(args) or _readme_demo(args) or (self.ni and _on_hardware(args)):
                continue
            if args[0] == "monitor":
                self.done[j] = _monitor(args, self.folder)
                continue
            with contextlib.chdir(self.folder):
                self.done[j] = run_cli(args)
            if redirect is not None:
                (self.folder / redirect).write_text(self.done[j][1])
        return self.done[i]


@pytest.fixture(scope="module")
def examples(tmp_path_factory) -> _Runner:
    """A folder with what a lab brings: its rig file (the default rig plus the impact hammer's
    channel, which `rig acquire tap` on the NI rig needs) and a two-channel LabVIEW TDMS log."""
    folder = tmp_path_factory.mktemp("examples")
    hammer = (
        '\n[daq.channels.hammer]\nphysical_channel = "Dev1/ai3"\nkind = "force"\n'
        'sensitivity = "2.25 mV/N"\nexcitation_current = "4 mA"\nrange = "2200 N"\n'
    )
    (folder / "lab.toml").write_text(default_rig_text() + hammer)
    rate, rng = 2048.0, np.random.default_rng(1)
    with TdmsWriter(str(folder / "log.tdms")) as writer:
        writer.write_segment(
            [
                RootObject({"name": "log"}),
                GroupObject("Task"),
                *(
                    ChannelObject(
                        "Task",
                        name,
                        rng.standard_normal(8192),
                        properties={"unit_string": unit, "wf_increment": 1 / rate},
                    )
                    for name, unit in (("Dev1/ai0", "N"), ("Dev1/ai1", "g"))
                ),
            ]
        )
    return _Runner(folder)


@pytest.mark.parametrize("index", range(len(EXAMPLES)), ids=[shlex.join(line) for line in EXAMPLES])
def test_command_help_example_runs(examples, index):
    line = EXAMPLES[index]
    args, _, pipe = _shell(line)
    if _full_demo(args):
        pytest.skip(
            "the full demo takes about a minute; `rig demo --quick` runs the same steps in "
            "test_demo_report.py, --out and --json in test_demo_cli.py"
        )
    if args[0] == "demo":  # README's command, run and checked by test_demo_report.py
        assert _readme_demo(args), f"rig {shlex.join(args)} is not README's demo command"
        return
    if _on_hardware(args) and examples.ni:  # pragma: no cover - only on a machine with NI-DAQmx
        pytest.skip("NI-DAQmx is installed here: a test never drives the real shaker")
    code, out, err = examples.result(index)
    folder = examples.folder
    assert "Traceback" not in err, err
    if _on_hardware(args):
        # without NI-DAQmx: the documented refusal, exit 3 in one line, and no file left behind
        assert code == 3 and out == "", err
        assert err.splitlines() in (
            [f"rig acquire: error: {NO_DRIVER_MESSAGE}"],
            [f"rig acquire: error: {NOT_SUPPORTED_MESSAGE}"],
        )
        assert not (folder / PARSER.parse_args(args).out).exists()
        return
    if args[0] == "monitor":  # served the page; Ctrl-C ended it with the documented 130
        assert (code, out) == (130, "200"), err
        return
    if args[0] == "devices" and args[1:] != ["--visa-backend", "simulated"]:
        # exit 3 when nothing can be listed (no NI driver, no VISA library here): each backend's
        # reason is given and the simulated rig offered; the shipped simulated VISA always lists
        assert code in (0, 3), err
        if "--json" in args:
            listed = json.loads(out)
            assert code == 0 or not (listed["nidaqmx"]["available"] or listed["visa"]["available"])
            assert code == 0 or (listed["nidaqmx"]["reason"] and listed["visa"]["reason"])
        else:
            assert code == 0 or "--backend sim" in out
        return
    assert code == 0, f"rig {shlex.join(line)}: {err}"
    if pipe is not None:
        assert pipe == ["python", "-m", "json.tool"]
        shown = subprocess.run(
            [sys.executable, *pipe[1:]], input=out, text=True, capture_output=True, check=False
        )
        assert shown.returncode == 0, shown.stderr
    if "--json" in args:
        doc = json.loads(out)
        assert isinstance(doc, dict)
        if args[:2] == ["acquire", "dwell"]:  # force control settled within its 0.5 % tolerance
            assert doc["status"] == "finished" and doc["settled"]
            assert abs(doc["force_amplitude_measured"] / doc["force_amplitude"] - 1) <= 0.005
    if args[0] == "devices":
        assert "TCPIP0::192.168.1.20::inst0::INSTR" in out
    written = [args[args.index("--out") + 1]] if "--out" in args else []
    if args[0] in ("export", "import"):
        written.append(args[3])
    for name in written:
        path = folder / name
        assert path.exists(), f"rig {shlex.join(line)} did not write {name}"
        if args[0] == "continuation":  # a branches file: the period-1 branch spans --from .. --to
            asked = PARSER.parse_args(args)
            _, branches = read_branches(path)
            span = [quantity(v, DIMENSION[asked.param], "") for v in (asked.start, asked.stop)]
            assert (branches[0].periods, branches[0].status) == (1, "complete")
            np.testing.assert_allclose([branches[0].value[0], branches[0].value[-1]], span, rtol=1e-12)
        elif path.suffix == ".h5":
            checked = check_recording(path, read_data=False)
            assert checked.valid and checked.status == "complete", checked.problems
