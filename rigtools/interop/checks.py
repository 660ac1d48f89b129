"""What every importer checks the same way: numbers written as text, non-finite samples, and the
parsers' own warnings (kept off the user's screen, said as notes instead)."""

from __future__ import annotations

import contextlib
import logging
import math
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from rigtools.errors import UserError, one_line

_T = TypeVar("_T")

CHUNK = 1 << 20  # samples read at a time when scanning a channel


def source_file(source: str | Path, error: type[UserError] = UserError) -> Path:
    """The importers' first check: ``source`` is a file, else one ``error`` line."""
    source = Path(source)
    if not source.is_file():
        raise error(f"{source}: {'not a file' if source.exists() else 'no such file'}")
    return source


def parsed(source: Path, what: str, parse: Callable[[], _T], error: type[UserError] = UserError) -> _T:
    """``parse()`` of ``source``, a file in format ``what`` (``"TDMS"``, ``"UFF"``): the
    parsers raise many types on a foreign or damaged file (ValueError, KeyError, struct.error,
    ...), each becomes one ``error`` line naming the file, the format and the parser's words."""
    try:
        return parse()
    except Exception as exc:  # noqa: BLE001 -- whatever the parser raises: one line
        raise error(
            f"{source}: not a readable {what} file ({type(exc).__name__}: {one_line(exc, 200)})"
        ) from None


def number(value: Any) -> float:
    """``value`` as a float; text with a decimal comma (``"0,0000195312"``) read as such.

    Returns NaN for anything that is not a number, so the caller's range check names it.
    """
    if isinstance(value, str):
        text = value.strip()
        if "," in text and "." not in text:
            text = text.replace(",", ".")
        value = text
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def non_finite_reason(read: Callable[[int, int], np.ndarray], samples: int) -> str | None:
    """Why a channel cannot be imported as it is, or ``None``: NaN or inf among its samples.

    The one policy of every import: such a channel is skipped with this reason (the others are
    imported), since every analysis downstream would carry the NaN into its results.
    ``read(start, n)`` returns samples ``start`` to ``start + n`` of the channel.
    """
    bad, first = 0, -1
    for start in range(0, samples, CHUNK):
        block = np.asarray(read(start, min(CHUNK, samples - start)), dtype=float)
        mask = ~np.isfinite(block)
        count = int(mask.sum())
        if count and first < 0:
            first = start + int(np.argmax(mask))
        bad += count
    if not bad:
        return None
    return (
        f"{bad} non-finite value(s) (NaN or inf) among its {samples} samples, the first at sample {first}: "
        "leave it out (--channel) or repair the file"
    )


@contextlib.contextmanager
def parser_notes(notes: list[str], parser: str, loggers: tuple[str, ...] = ()) -> Iterator[None]:
    """Collect a parser's warnings (``warnings`` and the ``logging`` records of the loggers named
    ``loggers`` or under them, whose own console handlers are set aside meanwhile: npTDMS gives each
    module's logger one) into ``notes`` as ``"<parser>: <message>"`` lines, once each, instead of
    printing them."""
    seen: set[str] = set()

    def add(message: str) -> None:
        line = f"{parser}: {' '.join(message.split())}"
        if line not in seen:
            seen.add(line)
            notes.append(line)

    class _Collect(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            add(record.getMessage())

    handler = _Collect(level=logging.WARNING)
    names = [
        n
        for n in list(logging.root.manager.loggerDict)
        if any(n == p or n.startswith(p + ".") for p in loggers)
    ]
    saved = []
    for name in sorted(set(names) | set(loggers)):
        log = logging.getLogger(name)
        saved.append((log, log.propagate, list(log.handlers)))
        log.handlers = [handler]
        log.propagate = False
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield
        for w in caught:
            add(str(w.message))
    finally:
        for log, propagate, handlers in saved:
            log.handlers = handlers
            log.propagate = propagate
