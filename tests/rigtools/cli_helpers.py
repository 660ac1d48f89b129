"""Running ``rig`` from tests: in-process with captured output (``run_cli``; ``rig``: in a given
working folder)."""

from __future__ import annotations

import contextlib
import io

from rigtools.cli import main


def run_cli(argv) -> tuple[int, str, str]:
    """``rig ARGV`` in this process: ``(exit status, stdout, stderr)`` (arguments made text)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


def rig(*args, cwd) -> str:
    """``rig ARGS`` in this process with ``cwd`` as the working folder; asserts success and returns
    its stdout. (It was a subprocess: about 2 s of CPU per run for the imports alone, and nothing
    its callers check needs a process of its own.)"""
    with contextlib.chdir(cwd):
        code, out, err = run_cli(args)
    assert code == 0, err[-2000:]
    return out


def acquire_dwell(*, seed=1, fe="60", force="15 N", gap="0.5 mm", periods=None, pace=False) -> list[str]:
    """``acquire dwell`` on the simulated rig, by default the tests' usual point (15 N at 60 Hz,
    gap 0.5 mm, seed 1); ``--gap`` left out where None (the rig file's), ``--periods`` only where
    given, ``--pace`` (the simulated rig in real time) where asked."""
    argv = ["acquire", "dwell", "--backend", "sim", "--seed", seed, "--fe", fe, "--force", force]
    argv += ["--gap", gap] if gap is not None else []
    argv += ["--pace"] if pace else []
    argv += ["--periods", periods] if periods is not None else []
    return [str(a) for a in argv]


def acquire_frf(signal, *, band, averages, seed, frame="0.5 s", level="0.3 V") -> list[str]:
    """``acquire frf`` on the simulated rig: ``signal`` (``burst``, ``chirp``, ...) over ``band``."""
    argv = ["acquire", "frf", "--backend", "sim", "--seed", seed, "--signal", signal, "--band", band]
    return [str(a) for a in [*argv, "--level", level, "--frame", frame, "--averages", averages]]


def acquire_gap_study(values, *, fe, seed=1, force="15 N", periods=None, pace=False) -> list[str]:
    """``acquire study gap`` on the simulated rig at the gaps ``values`` (``--yes``: no question
    asked); ``--periods`` only where given, ``--pace`` where asked."""
    argv = ["acquire", "study", "gap", "--backend", "sim", "--seed", seed, "--values", values]
    argv += ["--force", force, "--fe", fe]
    argv += ["--periods", periods] if periods is not None else []
    argv += ["--pace"] if pace else []
    return [str(a) for a in [*argv, "--yes"]]
