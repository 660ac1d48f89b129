"""A figure drawn by a second Python process that starts while the command still works.

Importing matplotlib costs more than the simulation a ``rig simulate`` plot shows (0.25 s cold,
against 0.17 s of stepping); drawing and encoding the PNG another 0.2 s. A :class:`PlotProcess`
started when the work begins imports the plotting code on the machine's other core; when the
work is done, :meth:`PlotProcess.write` hands it the figure to draw (a picklable callable
returning a :class:`matplotlib.figure.Figure`) and its path, and waits. The plot then adds
about its drawing time to the command's wall time, not its import time (the CPU time is the
same or a little more: the helper is a second interpreter).

If the helper cannot be started, dies, or reports an error, the figure is drawn in this process
as before (an error in the figure code then surfaces here, the one way errors are reported). The
helper runs in its own session, so a Ctrl-C at the terminal reaches only the command, which
ends it; it also ends by itself when the command's end closes its input.

The helper imports the command's own ``rigtools`` (:func:`import_path`). Run as
``python -m rigtools.plot_process`` (the helper's :func:`main`): imports the plotting code, then
reads one pickled ``(callable, path)`` from standard input, writes the figure with
:func:`rigtools.figures.save_figure` and prints ``ok`` (or one line of error) on standard output.
"""

from __future__ import annotations

import importlib
import os
import pickle
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import rigtools


class FigureCall:
    """``module.function(*args, **kwargs)``, a figure to draw, named rather than held: it pickles
    without importing the figure code (the helper imports it).

    Examples
    --------
    >>> call = FigureCall("math", "hypot", 3.0, 4.0)
    >>> call()
    5.0
    """

    def __init__(self, module: str, function: str, *args: Any, **kwargs: Any) -> None:
        self.module, self.function, self.args, self.kwargs = module, function, args, kwargs

    def __call__(self) -> Any:
        return getattr(importlib.import_module(self.module), self.function)(*self.args, **self.kwargs)


TIMEOUT_S = 120.0  # a figure takes seconds; a helper still busy after this is stuck

WARM = ("rigtools.analysis.plots", "rigtools.figures", "matplotlib.backends.backend_agg")


# the helper's import path is set before anything is imported (see import_path)
_START = "import sys; sys.path[:] = sys.argv[1:]; from rigtools.plot_process import main; sys.exit(main())"


def import_path() -> list[str]:
    """The helper's import path: this process's, the folder it imported ``rigtools`` from first
    (a source checkout run as ``python -m rigtools.cli`` from its root, a path a script added),
    without the current folder (a lab folder's own ``numpy.py`` or ``matplotlib.py``, which the
    command itself does not import either when started as ``rig``)."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(rigtools.__file__)))
    here = os.path.realpath(os.getcwd())
    rest = [str(p) for p in sys.path if os.path.realpath(str(p) or ".") != here]
    return [root, *(p for p in rest if p != root)]


class PlotProcess:
    """The helper process for one figure (see the module), started on construction."""

    def __init__(self) -> None:
        self._proc: subprocess.Popen[bytes] | None
        try:
            self._proc = subprocess.Popen(
                [sys.executable, "-P", "-c", _START, *import_path()],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
            )
        except OSError:
            self._proc = None

    def write(self, make_figure: Callable[[], Any], path: Path) -> bool:
        """Have the helper save ``make_figure()`` as PNG to ``path`` (with
        :func:`rigtools.figures.save_figure`) and wait for it. Returns whether it did: ``False``
        if it could not be started, died, could not be sent ``make_figure`` (not picklable) or
        reported an error, or did not answer within :data:`TIMEOUT_S`; the caller then draws the
        figure itself. The helper has ended either way."""
        proc, self._proc = self._proc, None
        if proc is None:
            return False
        try:
            answer, _ = proc.communicate(pickle.dumps((make_figure, str(path))), timeout=TIMEOUT_S)
        except (OSError, pickle.PicklingError, AttributeError, TypeError, subprocess.TimeoutExpired):
            answer = b""  # not picklable (a lambda, a local object), the helper is gone or stuck
        finally:
            _end(proc)
        return answer.strip() == b"ok"

    def close(self) -> None:
        """End the helper if it still runs (the command ended before :meth:`write`)."""
        if self._proc is not None:
            _end(self._proc)
            self._proc = None

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def _end(proc: subprocess.Popen[bytes]) -> None:
    """Close the helper's input and end it: SIGTERM (it removes a half-written PNG), then SIGKILL."""
    if proc.stdin is not None and not proc.stdin.closed:
        try:
            proc.stdin.close()
        except OSError:
            pass
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    if proc.stdout is not None:
        proc.stdout.close()


def main() -> int:
    """The helper's side (see the module)."""
    # SIGTERM from the command: unwind, so save_figure removes its temporary file
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    for name in WARM:
        importlib.import_module(name)
    from rigtools.figures import save_figure  # matplotlib: only in the helper process

    try:
        make_figure, path = pickle.load(sys.stdin.buffer)
    except EOFError:
        return 0  # the command ended without a figure
    try:
        save_figure(make_figure(), Path(path))
    except Exception as exc:  # noqa: BLE001  (reported to the command, which draws it again itself)
        print(f"error: {type(exc).__name__}: {exc}".splitlines()[0], flush=True)
        return 1
    print("ok", flush=True)
    # nothing left to clean up (the PNG is closed and renamed): skip the interpreter's teardown
    # of matplotlib's modules, which the command would otherwise wait for
    os._exit(0)


if __name__ == "__main__":
    sys.exit(main())
