"""What a command shows on stderr while work runs: a spinner with the elapsed time, a bar of
simulated time. Nothing is shown when stderr is not a terminal or the output is ``--json``."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from typing import Any, Self


def _bar(middle: str | None, *, transient: bool = True, disable: bool = False, bold: bool = False) -> Any:
    """A rich ``Progress`` on stderr: description, [bar and ``middle`` text | a spinner], elapsed
    time. ``middle="MofN"`` shows ``done/total``."""
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        ProgressColumn,
        SpinnerColumn,
        TextColumn,
        TimeElapsedColumn,
    )

    description = TextColumn("[bold]{task.description}" if bold else "{task.description}")
    columns: list[ProgressColumn | str]
    if middle is None:
        columns = [SpinnerColumn(), description]
    else:
        columns = [description, BarColumn(), MofNCompleteColumn() if middle == "MofN" else TextColumn(middle)]
    return Progress(
        *columns, TimeElapsedColumn(), console=Console(stderr=True), transient=transient, disable=disable
    )


@contextmanager
def working(text: str, quiet: bool = False) -> Iterator[None]:
    """A spinner with the elapsed time on stderr while the block runs (nothing if ``quiet`` or
    stderr is not a terminal)."""
    if quiet or not sys.stderr.isatty():
        yield
        return
    with _bar(None) as bar:
        bar.add_task(text, total=None)
        yield


def status(quiet: bool = False) -> Callable[[str], AbstractContextManager[None]]:
    """``status(quiet)(text)``: :func:`working` with ``quiet`` bound, for library functions that
    take a ``status`` callback."""
    return lambda text: working(text, quiet)


@contextmanager
def simulated_time_bar(
    text: str, at_most: float, quiet: bool = False
) -> Iterator[Callable[[float, float], None] | None]:
    """A progress bar of simulated time (settling, at most --max-settle, then the record) on
    stderr; yields the ``progress(simulated_s, at_most_s)`` callback (None if quiet / not a tty)."""
    if quiet or not sys.stderr.isatty():
        yield None
        return
    with _bar("{task.completed:.3g}/{task.total:.3g} s") as bar:
        task = bar.add_task(f"settling {text}", total=at_most)
        yield lambda done, total: bar.update(task, completed=done, total=total)


class ProcedureProgress:
    """A bar of a lab procedure's points on stderr, fed by its progress events
    (:class:`rigtools.procedures.base.ProgressEvent`); off when ``enabled`` is false."""

    def __init__(self, name: str, enabled: bool = True) -> None:
        self.enabled = enabled and sys.stderr.isatty()
        self.name = name

    def __enter__(self) -> Self:
        if self.enabled:
            self.bar = _bar("{task.completed}/{task.total} points")
            self.bar.__enter__()
            self.task = self.bar.add_task(self.name, total=1)
        return self

    def event(self, e: Any) -> None:
        """Show one progress event."""
        if not self.enabled:
            return
        text = f"point {e.point}/{e.n_points} {e.kind}"
        if e.kind == "control" and e.control_error is not None:
            text += f" update {e.update}: error {e.control_error * 100:+.2f} % ({e.text})"
        elif e.text:
            text += f": {e.text}"
        done = e.point if e.kind == "point_done" else e.point - 1
        self.bar.update(self.task, total=e.n_points, completed=max(0, done), description=text)

    def __exit__(self, *exc: object) -> None:
        if self.enabled:
            self.bar.__exit__(*exc)


class StudyProgress:
    """Bars of a model study on stderr: the points done (with the next point's label) and the
    simulated settling time of the point running. Off when ``enabled`` is false: then
    :attr:`on_point` and :attr:`settling` are ``None``."""

    def __init__(
        self, title: str, planned: list[Any], label: Callable[[Any], str], enabled: bool = True
    ) -> None:
        self.title, self.planned, self.label, self.enabled = title, planned, label, enabled
        self.on_point: Callable[[Any, dict], None] | None = None
        self.settling: Callable[[float, float], None] | None = None

    def __enter__(self) -> Self:
        if not self.enabled:
            return self
        self.bar = _bar("MofN", transient=False, bold=True)
        self.bar.__enter__()
        points = self.bar.add_task(f"{self.title}: {self.label(self.planned[0])}", total=len(self.planned))
        settle = self.bar.add_task("  settling (simulated s)", total=1.0)

        def on_point(p: Any, summary: dict) -> None:
            nxt = self.planned[p.index + 1] if p.index + 1 < len(self.planned) else None
            text = f"{self.title}: " + (self.label(nxt) if nxt else "done")
            self.bar.update(points, completed=p.index + 1, description=text)

        self.on_point = on_point
        self.settling = lambda done, total: self.bar.update(settle, completed=done, total=total)
        return self

    def __exit__(self, *exc: object) -> None:
        if self.enabled:
            self.bar.__exit__(*exc)


@contextmanager
def counted(text: str, quiet: bool = False, prefix: str = "") -> Iterator[Callable[[int, int, str], None]]:
    """A bar of counted work (``done / total``) on stderr; yields ``update(done, total, text)``,
    which shows ``prefix + text`` as the description (does nothing if quiet / not a tty)."""
    with _bar("MofN", disable=quiet or not sys.stderr.isatty()) as bar:
        task = bar.add_task(text, total=None)
        yield lambda done, total, what: bar.update(
            task, completed=done, total=total, description=prefix + what
        )
