"""Running ``rig`` from tests: in-process with captured output, or as a subprocess."""

from __future__ import annotations

import contextlib
import io
import subprocess
import sys

from rigtools.cli import main


def run_cli(argv) -> tuple[int, str, str]:
    """``rig ARGV`` in this process: ``(exit status, stdout, stderr)`` (arguments made text)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


def rig(*args, cwd) -> str:
    """``rig ARGS`` as a subprocess in ``cwd``; asserts success and returns its stdout."""
    proc = subprocess.run(
        [sys.executable, "-m", "rigtools.cli", *map(str, args)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout
