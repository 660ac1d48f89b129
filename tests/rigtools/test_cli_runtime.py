"""``rig`` as a process: signals, start-up weight, argparse errors, closed pipes, consoles.

Real subprocesses and real signals: a simulated acquisition is stopped by SIGINT, SIGTERM and
SIGHUP and its file must say ``aborted`` with the signal in ``abort_reason``, the drive ramped to
zero in the record and the data before the signal intact.
"""

from __future__ import annotations

import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from rigtools import cli, runtime
from rigtools.errors import EXIT_SIGHUP, EXIT_SIGINT, EXIT_SIGPIPE, EXIT_SIGTERM, Interrupted
from rigtools.recording import ChannelSpec, RecordingWriter

COMMANDS = [
    "acquire",
    "analyze",
    "check",
    "compare",
    "continuation",
    "demo",
    "devices",
    "export",
    "harmonic",
    "import",
    "info",
    "modal",
    "monitor",
    "report",
    "simulate",
    "study",
    "update",
]
HEAVY = ["scipy", "numba", "h5py", "nidaqmx", "pyvisa", "matplotlib"]
LINUX = pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="needs /proc (Linux)")


def _env(**extra: str) -> dict[str, str]:
    env = dict(os.environ)
    env.pop("PYTHONIOENCODING", None)
    env.update(extra)
    return env


def _rig(*args: str, **popen) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", "import sys; from rigtools.cli import main; sys.exit(main())", *args], **popen
    )


def _stderr_ok(text: str, max_lines: int = 2) -> None:
    lines = [line for line in text.splitlines() if line.strip()]
    assert "Traceback" not in text, text
    assert len(lines) <= max_lines, text


def small_recording(path: Path, units: str = "m/s^2") -> Path:
    """A complete two-channel, one-point recording (0.1 s at 10 kHz)."""
    t = np.arange(1000) / 1e4
    with RecordingWriter(path, backend="simulated", rig="{}") as rec:
        point = rec.begin_point(
            {"fe": 60.0},
            [
                ChannelSpec("force", "N", "force", 1e4),
                ChannelSpec("active_shroud_accel", units, "acceleration", 1e4),
            ],
        )
        point.append(np.vstack([15 * np.sin(2 * np.pi * 60 * t), 400 * np.sin(2 * np.pi * 60 * t)]))
        point.end()
    return path


# -- discovery and start-up weight -------------------------------------------------------------
def test_help_lists_every_command_without_importing_it(monkeypatch):
    """The command list read from the sources equals the one the imported modules register."""
    lazy = cli.build_parser(["--help"]).format_help()
    full = cli.build_parser(None).format_help()
    assert lazy == full
    assert sorted(cli.discover_commands()) == COMMANDS
    for word in ("130", "143", "129", "141", "exit status"):
        assert word in lazy


def test_summaries_come_from_constants_and_docstrings():
    source = (
        '"""``rig x``: do x."""\nHELP = "first" + " part"\n'
        'def register(sub):\n    sub.add_parser("x", help=HELP)\n'
        '    sub.add_parser("y", help=f"{HELP}")\n'
    )
    assert cli.command_summaries("x", source) == [("x", "first part"), ("y", "``rig x``: do x.")]
    assert cli.command_summaries("z", None) == [("z", "")]


_PROBE = """
import contextlib, io, json, sys
from rigtools.cli import main
out = []
for argv in json.loads(sys.argv[1]):
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as exc:      # --help
            code = exc.code
    out.append([code, sorted(sys.modules)])
print(json.dumps(out))
"""


def _probe(*argvs: tuple[str, ...], **popen) -> subprocess.Popen:
    """A process running ``main(argv)`` for each argv in turn, printing the exit status and the
    modules loaded after each (cumulative)."""
    return subprocess.Popen(
        [sys.executable, "-c", _PROBE, json.dumps([list(a) for a in argvs])],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
        **popen,
    )


# Command modules that import a heavy package at their top (the coordinator fixes them at merge;
# the tests turn into passes then, and strict xfail makes them say so).
OFFENDERS: dict[str, str] = {}  # command -> why its --help still imports a heavy package


def _probe_cases():
    cases = [
        pytest.param(("--help",), id="rig--help"),
        pytest.param(("no-such-command",), id="rig-bad-command"),
    ]
    for name in COMMANDS:
        marks = [pytest.mark.xfail(strict=True, reason=OFFENDERS[name])] if name in OFFENDERS else []
        cases.append(pytest.param((name, "--help"), id=f"{name}--help", marks=marks))
        cases.append(pytest.param((name, "--no-such-option"), id=f"{name}-bad-option", marks=marks))
    return cases


@pytest.fixture(scope="module")
def probes():
    """Every start-up case, one process per command (its --help, then a bad option) and all
    processes at once: argv -> (code, modules loaded so far)."""
    groups: dict[str, list[tuple[str, ...]]] = {}
    for p in _probe_cases():
        argv = p.values[0]
        groups.setdefault(argv[0], []).append(argv)
    procs = {tuple(argvs): _probe(*argvs) for argvs in groups.values()}
    out = {}
    for argvs, proc in procs.items():
        stdout, stderr = proc.communicate(timeout=180)
        assert proc.returncode == 0, stderr
        for argv, (code, modules) in zip(argvs, json.loads(stdout.strip().splitlines()[-1]), strict=True):
            out[argv] = code, modules
    return out


@pytest.mark.parametrize("argv", _probe_cases())
def test_help_and_argument_errors_do_not_import_heavy_packages(probes, argv):
    code, modules = probes[argv]
    assert code == (0 if argv[-1] == "--help" else 2)
    heavy = sorted({m.split(".")[0] for m in modules} & set(HEAVY))
    assert heavy == [], f"rig {' '.join(argv)} imported {heavy}"


def test_rig_info_does_not_import_scipy_signal(tmp_path):
    path = small_recording(tmp_path / "run.h5")
    stdout, _stderr = _probe(("info", str(path))).communicate(timeout=120)
    [[code, modules]] = json.loads(stdout.strip().splitlines()[-1])
    assert code == 0
    assert "scipy.signal" not in modules
    assert "matplotlib" not in modules


# -- argparse errors -------------------------------------------------------------------------
@pytest.mark.parametrize(
    "argv, prog",
    [
        (["--no-such-option"], "rig"),
        (["no-such-command"], "rig"),
        *[([name, "--no-such-option"], f"rig {name}") for name in COMMANDS],
        (["simulate", "--gap"], "rig simulate"),  # an option without its value
        (["acquire", "dwell", "--backend", "sim"], "rig acquire dwell"),  # required options missing
        (["info"], "rig info"),  # required positional missing
    ],
)
def test_argparse_errors_are_one_line_and_a_hint(capsys, argv, prog):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    _stderr_ok(err)
    lines = err.strip().splitlines()
    assert lines[0].startswith(f"{prog}: error: ")
    assert lines[1] == f"(see '{prog} --help')"


@pytest.mark.parametrize(
    "value, message",
    [
        # read as -90 deg: the run is then refused by --fe-start above the rig's band (no run starts)
        ("-90deg", "--fe-start = '1 MHz'"),
        ("-90°", "--fe-start = '1 MHz'"),
        ("-90deg,-100 deg", "--fe-start = '1 MHz'"),
        ("-90", "give an angle with its unit"),  # the value reaches --phase's own check
    ],
)
def test_a_negative_value_with_its_unit_is_the_options_value(tmp_path, capsys, value, message):
    """``--phase -90deg`` (no space, no quotes) is the value of --phase, never taken for an unknown
    option (argparse's misleading "argument --phase: expected one argument")."""
    argv = ["acquire", "pll", "--backend", "sim", "--force", "1 N", "--out", str(tmp_path / "x.h5")]
    code = cli.main([*argv, "--phase", value, "--fe-start", "1 MHz"])
    err = capsys.readouterr().err
    _stderr_ok(err)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err


def test_no_command_prints_help_and_exits_2(capsys):
    assert cli.main([]) == 2
    assert "COMMAND" in capsys.readouterr().out


# -- signals ---------------------------------------------------------------------------------
def test_interrupted_names_its_signal_and_exit_code():
    exc = Interrupted(signal.SIGTERM)
    assert isinstance(exc, KeyboardInterrupt)
    assert exc.exit_code == 143 == EXIT_SIGTERM
    assert str(exc).startswith("SIGTERM: ")
    assert Interrupted(signal.SIGINT).exit_code == EXIT_SIGINT == 130
    assert Interrupted(signal.SIGHUP).exit_code == EXIT_SIGHUP == 129


def test_a_stop_a_library_swallowed_still_ends_the_command_with_its_status(monkeypatch, capsys):
    """A stop signal whose exception a library swallowed entirely (seen once in CI: SIGHUP while
    ``rig simulate`` compiled its kernels on a fresh install, and the command ran on to exit 0):
    the command's 0 becomes the signal's status, with its one line; a command that ended with
    another status keeps it."""
    from rigtools.commands import info as info_command

    def swallowed(args) -> int:
        runtime.last_stop = Interrupted(signal.SIGHUP)  # the handler ran, its exception lost
        return 0

    monkeypatch.setattr(info_command, "run", swallowed)
    assert cli.main(["info", "x.h5"]) == EXIT_SIGHUP
    assert capsys.readouterr().err.strip() == "rig info: SIGHUP: hung up (terminal closed)"

    def failed(args) -> int:
        runtime.last_stop = Interrupted(signal.SIGHUP)
        return 3

    monkeypatch.setattr(info_command, "run", failed)
    assert cli.main(["info", "x.h5"]) == 3


def test_handler_raises_once_ignores_repeats_and_restores():
    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(Interrupted) as info, runtime.handle_stop_signals():
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1)  # the handler raises here
        finally:
            os.kill(os.getpid(), signal.SIGTERM)  # a repeat during clean-up: ignored
            time.sleep(0.05)
    assert info.value.signal_name == "SIGTERM"
    assert signal.getsignal(signal.SIGTERM) == before


def test_a_stop_inside_a_c_librarys_callback_is_not_lost(capsys):
    """A signal handled while a C library runs a Python callback (numba's compiler notifying its
    object cache, through ctypes, while ``rig simulate`` loads its kernels): the library swallows
    the exception ("Exception ignored on calling ctypes callback function") and the command ran
    on to exit 0. The stop is raised again once back in Python code, and nothing is printed."""
    import ctypes

    def callback() -> int:
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):  # the handler runs here, inside the callback
            pass
        return 0

    call = ctypes.CFUNCTYPE(ctypes.c_int)(callback)
    before = sys.unraisablehook
    with pytest.raises(Interrupted) as info, runtime.handle_stop_signals():
        call()
        time.sleep(10)  # raised here, back in Python code (the sleep is interrupted)
    assert info.value.signal_name == "SIGTERM"
    assert capsys.readouterr().err == ""
    assert sys.unraisablehook is before


def _wait_for(predicate, timeout: float = 60.0) -> None:
    end = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > end:
            raise AssertionError("timed out waiting for the subprocess")
        time.sleep(0.05)


def _signal_when(proc: subprocess.Popen, ready, sig: int, settle: float = 0.0) -> str:
    """Send ``sig`` to ``proc`` once ``ready()`` (or once it ended), ``settle`` s later; its stderr
    (killed if still running after)."""
    try:
        _wait_for(lambda: proc.poll() is not None or ready())
        time.sleep(settle)
        proc.send_signal(sig)
        _, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    return stderr


def _file_has_samples(path: Path, n: int) -> bool:
    try:
        with h5py.File(path, "r", swmr=True, locking=False) as f:
            return "points/0000/force" in f and f["points/0000/force"].shape[0] >= n
    except (OSError, KeyError):
        return False


SIGNAL_CASES = [(signal.SIGINT, 130), (signal.SIGTERM, 143), (signal.SIGHUP, 129)]


@pytest.fixture(scope="module")
def stopped_acquisitions(tmp_path_factory):
    """Three paced 30 s simulated acquisitions run at once; each gets its signal once 0.1 s of
    data is in its file. signal -> (exit status, stderr, file)."""
    tmp = tmp_path_factory.mktemp("signals")
    runs = {}
    for sig, _ in SIGNAL_CASES:
        out = tmp / f"{signal.Signals(sig).name}.h5"
        runs[sig] = (
            out,
            _rig(
                "acquire",
                "dwell",
                "--backend",
                "sim",
                "--pace",
                "--fe",
                "60 Hz",
                "--force",
                "5 N",
                "--gap",
                "5 mm",
                "--periods",
                "1800",
                "--out",
                str(out),
                "--json",
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                env=_env(),
            ),
        )
    results = {}
    try:
        pending = dict(runs)
        end = time.monotonic() + 120
        while pending and time.monotonic() < end:
            for sig, (out, proc) in list(pending.items()):
                if proc.poll() is not None or _file_has_samples(out, 5120):
                    time.sleep(0.2)
                    proc.send_signal(sig)
                    del pending[sig]
            time.sleep(0.05)
        for sig, (out, proc) in runs.items():
            _, stderr = proc.communicate(timeout=60)
            results[sig] = proc.returncode, stderr, out
    finally:
        for _, proc in runs.values():
            if proc.poll() is None:
                proc.kill()
    return results


@pytest.mark.parametrize("sig, code", SIGNAL_CASES)
def test_signal_during_simulated_acquisition_aborts_cleanly(stopped_acquisitions, sig, code):
    returncode, stderr, out = stopped_acquisitions[sig]
    name = signal.Signals(sig).name
    assert returncode == code, stderr
    _stderr_ok(stderr)
    assert name in stderr
    with h5py.File(out, "r") as f:
        assert f.attrs["status"] == "aborted"
        assert name in f.attrs["abort_reason"]
        force = f["points/0000/force"][:]
        drive = f["points/0000/drive"][:]
    assert force.size >= 5120 and np.all(np.isfinite(force))
    peak = np.max(np.abs(drive))
    assert peak > 0.05  # the dwell was running
    tail = np.abs(drive[-20:])  # ... and ramped to zero
    assert tail[-1] < 0.01 * peak and np.all(np.diff(tail) <= 0)


@LINUX
def test_sigterm_during_simulation(tmp_path):
    # a long record keeps the run going well past the signal (the model is fast: a default run
    # can end before the signal and die in the interpreter's teardown)
    proc = _rig(
        "simulate",
        "--max-settle",
        "600",
        "--duration",
        "60 s",
        "--out",
        str(tmp_path / "sim.h5"),
        "--json",
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
    )
    maps = Path(f"/proc/{proc.pid}/maps")
    stderr = _signal_when(proc, lambda: "numba" in maps.read_text(), signal.SIGTERM, settle=1.0)
    assert proc.returncode == EXIT_SIGTERM, stderr
    _stderr_ok(stderr)
    assert "SIGTERM" in stderr


@LINUX
def test_ctrl_c_during_start_up_is_one_line(tmp_path):
    """While command modules import (numpy mapped, the command not yet running)."""
    proc = _rig(
        "simulate",
        "--out",
        str(tmp_path / "sim.h5"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
    )
    maps = Path(f"/proc/{proc.pid}/maps")
    stderr = _signal_when(proc, lambda: "numpy" in maps.read_text(), signal.SIGINT)
    assert proc.returncode == EXIT_SIGINT, stderr
    _stderr_ok(stderr, max_lines=2)  # a first-run "compiling the kernels" line may precede
    assert "interrupted" in stderr


@LINUX
def test_ctrl_c_while_loading_the_rig_file_is_one_line(tmp_path):
    """The rig file is a FIFO nobody writes: `rig` blocks loading it until Ctrl-C."""
    fifo = tmp_path / "rig.toml"
    os.mkfifo(fifo)
    proc = _rig(
        "simulate",
        "--rig",
        str(fifo),
        "--out",
        str(tmp_path / "sim.h5"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
    )

    writer: list[int] = []

    def reader_waiting() -> bool:  # a non-blocking open for writing succeeds once rig reads
        try:
            writer.append(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
            return True
        except OSError:
            return False

    try:  # 0.2 s after a writer could open it, rig is blocked reading the (empty, open) FIFO
        stderr = _signal_when(proc, reader_waiting, signal.SIGINT, settle=0.2)
    finally:
        for fd in writer:
            os.close(fd)
    assert proc.returncode == EXIT_SIGINT, stderr
    _stderr_ok(stderr, max_lines=1)
    assert stderr.startswith("rig simulate: SIGINT: interrupted")


# -- closed pipe, consoles -------------------------------------------------------------------
@pytest.mark.parametrize(
    "args", [("--help",), ("info", "--json", "FILE"), ("info", "FILE"), ("check", "FILE")]
)
def test_closed_stdout_ends_quietly(tmp_path, args):
    path = small_recording(tmp_path / "run.h5")
    read, write = os.pipe()
    os.close(read)  # the reader is gone before rig writes anything
    try:
        proc = _rig(
            *[str(path) if a == "FILE" else a for a in args],
            stdout=write,
            stderr=subprocess.PIPE,
            text=True,
            env=_env(),
        )
    finally:
        os.close(write)
    _, stderr = proc.communicate(timeout=120)
    # argparse itself ignores a failed write of --help (exit 0); everything else says 141
    assert proc.returncode in ((0, EXIT_SIGPIPE) if args == ("--help",) else (EXIT_SIGPIPE,))
    assert stderr == ""


@pytest.mark.parametrize("encoding", ["ascii", "cp1252"])
def test_console_that_cannot_print_the_text(tmp_path, encoding):
    """A recording named with a character the console lacks ("≥"; units are SI words since rig
    check refuses others, so the name carries the non-ASCII text)."""
    path = small_recording(tmp_path / "run ≥ 0.5 mm.h5")
    proc = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from rigtools.cli import main; sys.exit(main())",
            "info",
            str(path),
        ],
        capture_output=True,
        env=_env(PYTHONIOENCODING=encoding),
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert b"Traceback" not in proc.stderr
    text = proc.stdout.decode(encoding)
    flat = " ".join(text.split())  # the console wraps at its width after the (temporary) path
    assert ">= 0.5 mm" in flat  # "≥" spelled in ASCII, the rest intact


@pytest.mark.parametrize("command", ["info", "analyze"])
def test_plain_c_locale_prints_units_in_ascii(tmp_path, command):
    """LANG=C without UTF-8 mode: stdout is ASCII with errors=surrogateescape (not "strict"), which
    the console set-up once left alone, so "m/s²" ended in a UnicodeEncodeError traceback."""
    path = small_recording(tmp_path / "run.h5")
    env = _env(LANG="C", LC_ALL="C", PYTHONCOERCECLOCALE="0", PYTHONUTF8="0")
    proc = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from rigtools.cli import main; sys.exit(main())",
            command,
            str(path),
        ],
        capture_output=True,
        env=env,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert b"Traceback" not in proc.stderr
    text = proc.stdout.decode("ascii")  # nothing but ASCII reached the console
    assert "m/s^2" in text


def test_configure_console_escapes_what_the_encoding_lacks():
    raw = io.BytesIO()
    stream = io.TextIOWrapper(raw, encoding="ascii", errors="strict")
    runtime.configure_console(stream)
    stream.write("a = 3 m/s² \u2603\n")
    stream.flush()
    assert raw.getvalue() == b"a = 3 m/s^2 \\u2603\n"  # a known unit spelled, the rest escaped


# -- process settings --------------------------------------------------------------------------
def test_configure_process_sets_blas_threads_even_after_numpy_loaded():
    env = _env()
    for var in runtime.BLAS_THREAD_VARS:
        env.pop(var, None)
    code = (
        "import numpy, scipy.linalg, json, os\n"
        "from threadpoolctl import threadpool_info\n"
        "from rigtools.runtime import configure_process\n"
        "s = configure_process()\n"
        "print(json.dumps([s.blas_threads, s.blas_limited_live, os.environ['OPENBLAS_NUM_THREADS'],"
        " sorted({i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas'})]))"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120, check=False
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == [1, True, "1", [1]]


def test_importing_the_cli_changes_no_environment():
    env = _env()
    for var in runtime.BLAS_THREAD_VARS:
        env.pop(var, None)
    code = (
        "import os, rigtools.cli; "
        "print(any(v in os.environ for v in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS')))"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=60, check=False
    )
    assert proc.stdout.strip() == "False"


def test_read_only_install_caches_kernels_per_user(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setattr(runtime, "_writable_dir", lambda path: False)
    assert runtime.numba_cache_dir() == tmp_path / "shrouded-blade-rig" / "numba"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    assert runtime.numba_cache_dir() == tmp_path / "mine"


def test_first_run_says_it_compiles_the_kernels_then_not(tmp_path):
    """A fresh numba cache: the line once; then the kernels are cached and nothing is said."""
    code = (
        "import contextlib, io\n"
        "from rigtools.runtime import ensure_kernels_compiled, kernels_cached\n"
        "first = ensure_kernels_compiled()\n"
        "said = io.StringIO()\n"
        "print(first, kernels_cached(), ensure_kernels_compiled(said), repr(said.getvalue()))"
    )
    env = _env(NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300, check=False
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["True", "True", "False", "''"]
    assert proc.stderr.startswith("compiling the simulation kernels (first run only, ~")
    assert len(proc.stderr.splitlines()) == 1
