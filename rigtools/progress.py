"""What a command shows on stderr while work runs: a spinner with the elapsed time, a bar of
simulated time. Nothing is shown when stderr is not a terminal or the output is ``--json``."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager


@contextmanager
def working(text: str, quiet: bool = False) -> Iterator[None]:
    """A spinner with the elapsed time on stderr while the block runs (nothing if ``quiet`` or
    stderr is not a terminal)."""
    if quiet or not sys.stderr.isatty():
        yield
        return
    from rich.console import Console
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    with Progress(
        SpinnerColumn(),
        TextColumn("{task.description}"),
        TimeElapsedColumn(),
        console=Console(stderr=True),
        transient=True,
    ) as bar:
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
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed:.3g}/{task.total:.3g} s"),
        TimeElapsedColumn(),
        console=Console(stderr=True),
        transient=True,
    ) as bar:
        task = bar.add_task(f"settling {text}", total=at_most)
        yield lambda done, total: bar.update(task, completed=done, total=total)
