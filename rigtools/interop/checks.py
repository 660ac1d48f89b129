"""What every importer does the same way: its shared keywords and preamble (:func:`importer`,
:func:`import_request`), numbers written as text, non-finite samples, and the parsers' own
warnings (kept off the user's screen, said as notes instead)."""

from __future__ import annotations

import contextlib
import functools
import inspect
import logging
import math
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Required, TypedDict, TypeVar, get_args, get_origin

import numpy as np

from rigtools.errors import UserError, one_line
from rigtools.interop.channels import ForeignChannel
from rigtools.interop.imported import ForeignPoint, write_imported

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


#: The keywords every importer (``import_tdms``, ``import_lvm``, ``import_uff``) takes besides its
#: own, defined once: :func:`importer` adds them to each one's signature (what ``help()``, call
#: tips and the docs show) and their text to its docstring (``%(shared)s``); mypy reads them from
#: the importer's ``**options: Unpack[ImportKeywords]``. (The functional form: under ``from
#: __future__ import annotations`` the class form's ``Required`` is a string the runtime cannot see.)
ImportKeywords = TypedDict(  # noqa: UP013 -- see above
    "ImportKeywords",
    {
        "rig": Required[Any],
        "overwrite": bool,
        "mapping": dict[str, str] | None,
        "units": dict[str, str] | None,
        "channels": list[str] | None,
        "reference": str | None,
    },
    total=False,
)
_DEFAULTS: dict[str, Any] = {"overwrite": False}  # the others: None (rig: none, it is required)
IMPORT_KEYWORDS = tuple(
    inspect.Parameter(
        name,
        inspect.Parameter.KEYWORD_ONLY,
        default=inspect.Parameter.empty if name in ImportKeywords.__required_keys__ else _DEFAULTS.get(name),
        annotation=inspect.formatannotation(get_args(kind)[0] if get_origin(kind) is Required else kind),
    )
    for name, kind in ImportKeywords.__annotations__.items()
)
_KEYWORDS_DOC = """\
rig
    The rig description stored in the recording (a ``RigConfig`` or its JSON text).
overwrite
    Replace ``out`` if it exists.
mapping
    A channel's name in the file (or its path there: TDMS ``group/channel``, UFF ``record7``)
    -> recording channel name (``--map``).
units
    A channel's name in the file (or its path) -> unit (``--units``), for channels without
    units or with wrong ones.
channels
    Only these channels (names or paths); default all.
reference
    The excitation channel (default: the one channel of quantity force)."""

_Importer = TypeVar("_Importer", bound=Callable[..., dict])


def importer(function: _Importer) -> _Importer:
    """An importer taking the :class:`ImportKeywords` in its ``**options``: they are added to its
    signature (a wrong or missing keyword raises Python's own ``TypeError``) and their text put for
    ``%(shared)s`` in its docstring at the marker's indentation, as scipy's docstring templates do."""
    signature = inspect.signature(function)
    *own, _ = signature.parameters.values()
    shown = signature.replace(parameters=[*own, *IMPORT_KEYWORDS])

    @functools.wraps(function)
    def door(*args: Any, **kwargs: Any) -> dict:
        try:
            shown.bind(*args, **kwargs)
        except TypeError as exc:  # as Python says it: "import_lvm() got an unexpected keyword ..."
            raise TypeError(f"{function.__name__}() {exc}") from None
        return function(*args, **kwargs)

    door.__signature__ = shown  # type: ignore[attr-defined]  # what help() and the docs show
    lines: list[str] = []
    for line in (function.__doc__ or "").splitlines():
        if line.strip() == "%(shared)s":
            indent = line[: len(line) - len(line.lstrip())]
            lines.extend(indent + text if text else text for text in _KEYWORDS_DOC.splitlines())
        else:
            lines.append(line)
    door.__doc__ = "\n".join(lines)
    return door  # type: ignore[return-value]  # the same call signature as function's


@dataclass
class ImportRequest:
    """An import's source, its :class:`ImportKeywords` with their defaults filled, and the notes it
    collects (:func:`import_request`)."""

    source: Path
    rig: Any
    overwrite: bool
    mapping: dict[str, str]
    units: dict[str, str]
    channels: list[str]
    reference: str | None
    notes: list[str] = field(default_factory=list)

    def write(
        self,
        out: str | Path,
        backend: str,
        experiment: dict,
        points: Sequence[ForeignPoint],
        every: Sequence[ForeignChannel],
    ) -> dict:
        """:func:`rigtools.interop.imported.write_imported` of the import's ``points``."""
        return write_imported(
            out,
            backend=backend,
            rig=self.rig,
            experiment=experiment,
            points=points,
            every=every,
            reference=self.reference,
            overwrite=self.overwrite,
            notes=self.notes,
        )


def import_request(source: str | Path, options: ImportKeywords) -> ImportRequest:
    """The importers' preamble: ``source`` and the keywords given (``options``), defaults filled
    and the mappings copied (the caller's dicts are never changed)."""
    return ImportRequest(
        source=Path(source),
        rig=options["rig"],
        overwrite=options.get("overwrite", False),
        mapping=dict(options.get("mapping") or {}),
        units=dict(options.get("units") or {}),
        channels=list(options.get("channels") or []),
        reference=options.get("reference"),
    )
