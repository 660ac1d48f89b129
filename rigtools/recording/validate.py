"""Validation of recordings against schema v1: what ``rig check`` reports.

:func:`find_problems` inspects an open HDF5 file (attributes, names, shapes; no sample data) and
returns :class:`Problem` lines. Problems marked ``fatal`` stop :func:`~rigtools.recording.open_recording`
(wrong schema, newer version, missing required attributes) in every case; the other errors
(inconsistent lengths or rates, a gap in the point numbering, NaN samples, ...) stop it too unless
it is asked to ``skip_damaged`` (the reader contract: a file ``rig check`` rejects is refused by
every reader; only a ``rig`` attribute that does not validate is ``model_only``).
:func:`check_recording` opens a path, runs the inspection and, optionally, reads every sample.
"""

from __future__ import annotations

import json
import math
import os
import time
import tomllib
from dataclasses import asdict, dataclass, field
from numbers import Real
from typing import Any, ClassVar

import h5py
import numpy as np

import rigtools
from rigtools.config import parse_rig
from rigtools.controlled_point import ControlledPoint
from rigtools.errors import UserError, one_line, option
from rigtools.recording.lock import writer_alive
from rigtools.recording.opener import LIVE_RETRY_S, PAST_END, named, open_h5
from rigtools.recording.schema import (
    CHANNEL_ATTRS,
    CHANNEL_UNITS,
    CONTROLLED_PROCEDURES,
    DIRECTION_MAX,
    END_FINISHED,
    END_STATUSES,
    MAX_SAMPLE_RATE,
    MEASURED_CHANNEL_ATTRS,
    NUMERIC_POINT_PARAMS,
    OPTIONAL_ROOT_ATTRS,
    POINT_ATTRS,
    POINTS_GROUP,
    ROOT_ATTRS,
    SCHEMA_NAME,
    SCHEMA_VERSION,
    SINE_PROCEDURES,
    STATUS_ABORTED,
    STATUS_COMPLETE,
    STATUS_RECORDING,
    STATUSES,
    RecordingError,
    parse_utc,
    point_index,
    python_value,
)
from rigtools.vocabulary import MODEL_BACKENDS, channel_name_legal

ERROR = "error"
#: The largest sample magnitude a reader takes: a square of 1e154 overflows float64; nothing the rig
#: or its model measures in SI units comes near (the shaker's 1000 N, accelerations ~1e5 m/s^2).
MAX_SAMPLE_MAGNITUDE = 1e150
NOTE = "note"
NEWER_PREFIX = "schema_version "  # start of the one message that means "file is newer"


@dataclass(frozen=True)
class Problem:
    """One finding: ``where`` (HDF5 path), ``message``, ``severity`` ("error"/"note"), ``fatal``."""

    where: str
    message: str
    severity: str = ERROR
    fatal: bool = False
    #: An error only to the readers that build the model from the file (its ``rig`` attribute):
    #: the others read the data with it as a note (the samples are intact).
    model_only: bool = False

    def line(self) -> str:
        return f"{self.where}: {self.message}"


def _is_text(value: Any) -> bool:
    return isinstance(value, (str, bytes))


def _is_number(value: Any) -> bool:
    return isinstance(value, (Real, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def _scalar(value: Any) -> Any:
    if isinstance(value, np.ndarray) and value.shape == ():
        return value[()]
    return value


class Unreadable:
    """Stands for an attribute HDF5 cannot read (e.g. a type h5py does not map)."""

    def __init__(self, reason: str):
        self.reason = reason


class AttrCache(dict):
    """Attributes of HDF5 objects by object name, each read once (validation and reader share it)."""

    def of(self, obj: h5py.HLObject) -> dict[str, Any]:
        key = obj.name
        if key not in self:
            values: dict[str, Any] = {}
            for name in obj.attrs:
                try:
                    values[name] = _scalar(obj.attrs[name])
                except (OSError, TypeError, ValueError, KeyError) as exc:
                    values[name] = Unreadable(one_line(exc, None))
            self[key] = values
        return self[key]


def _check_attr(
    attrs: dict[str, Any], name: str, kind: str, where: str, out: list[Problem], required: bool = True
) -> Any:
    """Append a problem if attribute ``name`` is missing or not of ``kind``; return its value."""
    if name not in attrs:
        if required:
            out.append(Problem(where, f"missing attribute '{name}'", fatal=True))
        return None
    value = attrs[name]
    if isinstance(value, Unreadable):
        out.append(Problem(where, f"attribute '{name}' cannot be read ({value.reason})", fatal=True))
        return None
    ok = {
        "text": _is_text,
        "int": lambda v: isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)),
        "float": _is_number,
    }[kind](value)
    if not ok:
        out.append(Problem(where, f"attribute '{name}' = {python_value(value)!r} is not {kind}", fatal=True))
        return None
    return python_value(value)


#: rigtools' other HDF5 files, named when one is given where a recording is expected (the schema
#: names of rigtools.branches_file.BRANCHES_SCHEMA and rigtools.frf_set.SCHEMA).
OTHER_RIGTOOLS_FILES = {
    "rigtools-branches": "a branches file of rig continuation (rig report --branches draws it)",
    "rigtools.frfset": "an FRF set of rig import uff (rig info, rig check and rig analyze read it)",
}


def find_problems(f: h5py.File, cache: AttrCache | None = None) -> list[Problem]:
    """Everything wrong with an open file as a schema v1 recording (metadata only).

    The first problems are the fatal ones about the root (wrong schema, newer version), so
    their message is what a reader reports. ``cache`` keeps the attributes read.
    """
    cache = AttrCache() if cache is None else cache
    out: list[Problem] = []
    attrs = cache.of(f)
    schema = _check_attr(attrs, "schema", "text", "/", [])
    if schema is None:
        return [
            Problem(
                "/",
                f"not a rigtools recording: no text attribute 'schema' (expected '{SCHEMA_NAME}')",
                fatal=True,
            )
        ]
    if schema != SCHEMA_NAME:
        what = OTHER_RIGTOOLS_FILES.get(schema)
        return [
            Problem(
                "/",
                f"not a rigtools recording: schema is '{schema}' (expected '{SCHEMA_NAME}')"
                + (f": {what}" if what else ""),
                fatal=True,
            )
        ]
    version = _check_attr(attrs, "schema_version", "int", "/", out)
    if version is None:
        return out
    if version > SCHEMA_VERSION:
        return [
            Problem(
                "/",
                f"{NEWER_PREFIX}{version} is newer than this rigtools "
                f"{rigtools.__version__} reads (up to {SCHEMA_VERSION}); upgrade rigtools",
                fatal=True,
            )
        ]
    if version < 1:
        return [Problem("/", f"schema_version {version} is not a valid version", fatal=True)]

    root = {
        name: _check_attr(attrs, name, kind, "/", out)
        for name, (kind, _) in ROOT_ATTRS.items()
        if name not in ("schema", "schema_version")
    }
    status = root.get("status")
    sine = controlled = False
    if status is not None and status not in STATUSES:
        out.append(Problem("/", f"status '{status}' is not one of {', '.join(STATUSES)}", fatal=True))
    if status == STATUS_ABORTED and not root.get("abort_reason"):
        out.append(Problem("/", "status is 'aborted' but abort_reason is empty"))
    out.extend(_end_status_problems(attrs, status, root.get("abort_reason")))
    for key in ("created", "ended"):
        text = root.get(key)
        if text:
            try:
                parse_utc(text)
            except ValueError:
                out.append(Problem("/", f"{key} = {text!r} is not ISO 8601 UTC time"))
    if status == STATUS_COMPLETE and root.get("ended") == "":
        out.append(Problem("/", "status is 'complete' but 'ended' is empty"))
    if root.get("backend") == "":
        out.append(Problem("/", "backend is empty"))
    if root.get("rig") is not None:
        out.extend(rig_problems(root["rig"]))
    if root.get("experiment") is not None:
        try:
            experiment = json.loads(root["experiment"])
        except ValueError:
            experiment = None
        if not isinstance(experiment, dict):
            out.append(Problem("/", "attribute 'experiment' is not a JSON object", fatal=True))
        else:
            sine = experiment.get("procedure") in SINE_PROCEDURES or root.get("backend") in MODEL_BACKENDS
            controlled = experiment.get("procedure") in CONTROLLED_PROCEDURES

    if POINTS_GROUP not in f:
        out.append(Problem("/", f"missing group '/{POINTS_GROUP}'", fatal=True))
        return out
    points = f[POINTS_GROUP]
    if not isinstance(points, h5py.Group):
        out.append(Problem(f"/{POINTS_GROUP}", "is not a group", fatal=True))
        return out
    indices = []
    for name in points:
        idx = point_index(name)
        if idx is None:
            out.append(
                Problem(
                    f"/{POINTS_GROUP}/{name}", "unexpected object (point groups are named 0000, 0001, ...)"
                )
            )
            continue
        indices.append(idx)
        try:
            group = points[name]
        except (OSError, RuntimeError, KeyError, ValueError) as exc:
            # a writer killed (or busy) while creating this point left its structure unreadable
            why = f"point group cannot be read ({one_line(exc, None)})"
            out.append(Problem(f"/{POINTS_GROUP}/{name}", why, fatal=True))
            continue
        where = f"/{POINTS_GROUP}/{name}"
        out.extend(_point_problems(group, where, status, cache, sine=sine))
        if controlled and isinstance(group, h5py.Group):
            out.extend(_controlled_problems(cache.of(group), where))
    indices.sort()
    if indices != list(range(len(indices))):
        out.append(
            Problem(
                f"/{POINTS_GROUP}", f"points are not numbered 0..{len(indices) - 1} without gaps: {indices}"
            )
        )
    if status not in (None, STATUS_COMPLETE):
        out.append(
            Problem(
                "/",
                f"incomplete: status is '{status}'"
                + (
                    " (the writer was killed or is still running)"
                    if status == "recording"
                    else f": {root.get('abort_reason')}"
                ),
                severity=NOTE,
            )
        )
    return out


def _end_status_problems(
    attrs: dict[str, Any], status: str | None, abort_reason: str | None
) -> list[Problem]:
    """The optional ``end_status`` / ``end_reason`` of a procedure: their types, the word, and
    agreement with ``status`` and ``abort_reason``."""
    out: list[Problem] = []
    end = {
        name: _check_attr(attrs, name, kind, "/", out, required=False)
        for name, (kind, _) in OPTIONAL_ROOT_ATTRS.items()
    }
    word = end.get("end_status")
    if word is None:
        return out
    if word not in END_STATUSES:
        out.append(Problem("/", f"end_status '{word}' is not one of {', '.join(END_STATUSES)}"))
        return out
    if status == STATUS_COMPLETE and word != END_FINISHED:
        out.append(Problem("/", f"end_status is '{word}' but status is 'complete'"))
    elif status == STATUS_ABORTED:
        if word == END_FINISHED:
            out.append(Problem("/", "end_status is 'finished' but status is 'aborted'"))
        elif abort_reason and not abort_reason.startswith(f"{word}: "):
            out.append(
                Problem(
                    "/",
                    f"end_status is '{word}' but abort_reason does not start "
                    f"with '{word}: ' ({abort_reason!r})",
                )
            )
    if word != END_FINISHED and end.get("end_reason") == "":
        out.append(Problem("/", f"end_status is '{word}' but end_reason is empty"))
    return out


def rig_problems(text: str) -> list[Problem]:
    """The ``rig`` attribute must be a rig description (JSON or TOML) that validates: readers
    that simulate or compare build the FE model from it."""
    try:
        data = json.loads(text)
    except ValueError:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError:
            return [Problem("/", "attribute 'rig' is neither JSON nor TOML", model_only=True)]
    if not isinstance(data, dict):
        return [
            Problem(
                "/", f"attribute 'rig' is not a rig description (a {type(data).__name__})", model_only=True
            )
        ]
    if not data:  # a writer without a rig description (tests, other software): nothing claimed
        return [
            Problem(
                "/", "attribute 'rig' is empty: readers that build the model need --rig FILE", severity=NOTE
            )
        ]
    try:
        parse_rig(data, source="rig attribute")
    except UserError as exc:
        # an error, not fatal: readers that need no model (info, analyze, export) read the data;
        # those that build the model from it (compare --simulate, update) refuse, naming --rig
        return [
            Problem(
                "/",
                f"attribute 'rig' does not validate: {one_line(exc, 300)}; those readers that build the model need --rig FILE",
                model_only=True,
            )
        ]
    return []


def _parameter_problems(attrs: dict[str, Any], where: str, rate: float | None) -> list[Problem]:
    """The point parameters readers compute with (:data:`NUMERIC_POINT_PARAMS`): numbers, finite,
    in range; ``fe`` below the Nyquist frequency of the point's channels."""
    out: list[Problem] = []
    for key, (low, strict) in NUMERIC_POINT_PARAMS.items():
        if key not in attrs or isinstance(attrs[key], Unreadable):
            continue
        value = _scalar(attrs[key])
        if not _is_number(value):
            shown = python_value(value) if not isinstance(value, np.ndarray) else value.tolist()
            out.append(Problem(where, f"parameter '{key}' = {shown!r} is not a number", fatal=True))
            continue
        number = float(value)
        if not math.isfinite(number) or (number <= low if strict else number < low):
            rule = "finite" if low == -math.inf else f"finite and {'>' if strict else '>='} {low:g}"
            out.append(Problem(where, f"parameter '{key}' = {number!r} is not {rule}", fatal=True))
            continue
        if key == "fe" and rate is not None and number >= rate / 2:
            out.append(
                Problem(
                    where,
                    f"parameter 'fe' = {number:g} Hz is not below the Nyquist frequency "
                    f"({rate / 2:g} Hz at {rate:g} samples/s)",
                    fatal=True,
                )
            )
    return out


#: the fields every point of a controlled test carries (``rig report`` reads them)
CONTROLLED_FIELDS = tuple(ControlledPoint.__dataclass_fields__)


def _controlled_problems(attrs: dict[str, Any], where: str) -> list[Problem]:
    """A controlled test's point (:class:`~rigtools.controlled_point.ControlledPoint`): its fields
    numbers (``converged`` a bool, ``iterations`` a whole number >= 0), all of them or none (a
    point cut short before its result carries none). Notes, not errors: the samples are intact
    and every reader takes them, but ``rig report`` leaves such a point out of its figure."""
    out: list[Problem] = []
    missing = [key for key in CONTROLLED_FIELDS if key not in attrs]
    if 0 < len(missing) < len(CONTROLLED_FIELDS):
        out.append(
            Problem(
                where,
                f"a controlled point without {', '.join(missing)}: rig report leaves it out",
                severity=NOTE,
            )
        )
    for key in CONTROLLED_FIELDS:
        if key not in attrs or isinstance(attrs[key], Unreadable):
            continue
        value = _scalar(attrs[key])
        if key == "converged":
            ok = isinstance(value, (bool, np.bool_)) or (_is_number(value) and float(value) in (0.0, 1.0))
            rule = "a bool"
        elif key == "iterations":
            ok = _is_number(value) and math.isfinite(float(value)) and float(value) == int(value) >= 0
            rule = "a whole number >= 0"
        else:
            ok = _is_number(value)
            rule = "a number"
        if not ok:
            shown = value.tolist() if isinstance(value, np.ndarray) else python_value(value)
            why = f"controlled-point field '{key}' = {shown!r} is not {rule}: rig report leaves the point out"
            out.append(Problem(where, why, severity=NOTE))
    return out


def _point_problems(
    group: Any, where: str, status: str | None, cache: AttrCache, *, sine: bool = False
) -> list[Problem]:
    """A point's problems; ``sine``: the file's points are sine runs, so each needs ``fe > 0``
    (every reader computes their harmonics at it)."""
    out: list[Problem] = []
    if not isinstance(group, h5py.Group):
        return [Problem(where, "is not a group", fatal=True)]
    attrs = cache.of(group)
    fe = _scalar(attrs.get("fe", 0.0)) if not isinstance(attrs.get("fe"), Unreadable) else None
    if sine and fe is not None and _is_number(fe) and float(fe) == 0.0:
        why = "has no parameter 'fe'" if "fe" not in attrs else "has fe = 0"
        out.append(
            Problem(
                where, f"a sine point that {why}: its excitation frequency is unknown (readers leave it out)"
            )
        )
    for name, (kind, _) in POINT_ATTRS.items():
        text = _check_attr(attrs, name, kind, where, out)
        if text:
            try:
                parse_utc(text)
            except ValueError:
                out.append(Problem(where, f"{name} = {text!r} is not ISO 8601 UTC time"))
    if attrs.get("end_time") in ("", b"") and status == STATUS_COMPLETE:
        out.append(Problem(where, "the point never ended (end_time is empty) in a complete file"))
    for key, value in attrs.items():
        if key in POINT_ATTRS:
            continue
        if isinstance(value, Unreadable):
            out.append(Problem(where, f"parameter '{key}' cannot be read ({value.reason})"))
            continue
        if not (
            isinstance(value, (str, bytes, np.generic, int, float))
            or (isinstance(value, np.ndarray) and value.dtype.kind in "biufSUO" and value.ndim <= 1)
        ):
            out.append(Problem(where, f"parameter '{key}' is not text, a number or a bool"))
    lengths: dict[str, int] = {}
    rates: dict[str, float] = {}
    if len(group) == 0:
        out.append(Problem(where, "point has no channels"))
    for name in group:
        dataset = group[name]
        cwhere = f"{where}/{name}"
        if not isinstance(dataset, h5py.Dataset):
            out.append(Problem(cwhere, "is not a dataset (channels are 1-D datasets)", fatal=True))
            continue
        if dataset.ndim != 1 or dataset.dtype.kind != "f":
            out.append(
                Problem(
                    cwhere,
                    f"is not a 1-D floating-point dataset (shape {dataset.shape}, dtype {dataset.dtype})",
                    fatal=True,
                )
            )
            continue
        if not channel_name_legal(name):
            out.append(
                Problem(
                    cwhere, "illegal channel name (letters, digits, _ . - only; no leading dot)", fatal=True
                )
            )
        lengths[name] = dataset.shape[0]
        dattrs = cache.of(dataset)
        values = {
            key: _check_attr(dattrs, key, kind, cwhere, out) for key, (kind, _) in CHANNEL_ATTRS.items()
        }
        rate = values.get("sample_rate")
        if rate is not None:
            if not (math.isfinite(rate) and 0 < rate <= MAX_SAMPLE_RATE):
                out.append(
                    Problem(
                        cwhere,
                        f"sample_rate {rate!r} is not a positive number of Hz up to {MAX_SAMPLE_RATE:g}",
                        fatal=True,
                    )
                )
            else:
                rates[name] = float(rate)
        units = values.get("units")
        if units is not None and units not in CHANNEL_UNITS:
            out.append(
                Problem(
                    cwhere,
                    f"units {units!r} are not one of the SI units {', '.join(CHANNEL_UNITS)}",
                    fatal=True,
                )
            )
        t0 = values.get("t0")
        if t0 is not None and not math.isfinite(t0):
            out.append(Problem(cwhere, f"t0 {t0!r} is not finite", fatal=True))
        measured = {
            key: _check_attr(dattrs, key, kind, cwhere, out, required=False)
            for key, (kind, _) in MEASURED_CHANNEL_ATTRS.items()
        }
        if measured["direction"] is not None and abs(measured["direction"]) > DIRECTION_MAX:
            out.append(
                Problem(cwhere, f"direction {measured['direction']} is not a UFF direction code (-6..6)")
            )
        if "sensitivity" in dattrs and "sensitivity_units" not in dattrs:
            out.append(Problem(cwhere, "has 'sensitivity' but no 'sensitivity_units'"))
    empty = [k for k, v in lengths.items() if v == 0]
    if empty and status == STATUS_COMPLETE:
        out.append(Problem(where, f"channel(s) {', '.join(empty)} hold no samples (readers leave it out)"))
    if len(set(lengths.values())) > 1:
        detail = ", ".join(f"{k}={v}" for k, v in lengths.items())
        if status == STATUS_COMPLETE:
            out.append(Problem(where, f"channels differ in length: {detail}"))
        else:
            out.append(
                Problem(
                    where, f"channels differ in length (writer stopped mid-block): {detail}", severity=NOTE
                )
            )
    if len(set(rates.values())) > 1:
        detail = ", ".join(f"{k}={v:g} Hz" for k, v in rates.items())
        out.append(Problem(where, f"channels differ in sample_rate: {detail}"))
    out.extend(_parameter_problems(attrs, where, min(rates.values()) if rates else None))
    return out


@dataclass
class CheckResult:
    """Outcome of :func:`check_recording`; ``valid`` is True when no problem has severity error."""

    path: str
    problems: list[Problem] = field(default_factory=list)
    status: str | None = None
    n_points: int = 0
    n_channels: int = 0
    opened_as: str = ""
    writer: str | None = None

    @property
    def valid(self) -> bool:
        return not any(p.severity == ERROR for p in self.problems)

    def to_dict(self) -> dict[str, Any]:
        return {
            "path": self.path,
            "valid": self.valid,
            "status": self.status,
            "points": self.n_points,
            "channels": self.n_channels,
            "opened_as": self.opened_as,
            "writer": self.writer,
            "problems": [asdict(p) for p in self.problems],
        }


@dataclass
class FileCheck:
    """Outcome of the check of one of rigtools' own HDF5 files that are not recordings (a branches
    file, an FRF set): its problems, ``valid`` when none is an error. A kind of file subclasses
    it with its :attr:`KIND` (as ``rig check --json`` names it), :attr:`WHAT` (as a message does)
    and its counts (:attr:`COUNTS`: field -> key in :meth:`to_dict`)."""

    KIND: ClassVar[str] = ""
    WHAT: ClassVar[str] = ""
    COUNTS: ClassVar[dict[str, str]] = {}

    path: str
    problems: list[Problem] = field(default_factory=list)

    @property
    def valid(self) -> bool:
        """True when no problem has severity error."""
        return not any(p.severity == ERROR for p in self.problems)

    def error(self, where: str, message: str) -> None:
        """Add an error at ``where`` (an HDF5 path)."""
        self.problems.append(Problem(where, message))

    def refuse_damaged(self) -> None:
        """Raise a one-line :class:`~rigtools.errors.UserError` naming the first error, if any:
        a reader relies on exactly what the check verifies (``rig check`` lists them all)."""
        errors = [p for p in self.problems if p.severity == ERROR]
        if errors:
            more = f" and {len(errors) - 1} more" if len(errors) > 1 else ""
            raise UserError(
                f"{self.path}: a damaged {self.WHAT}: {errors[0].line()}{more} "
                f"(rig check {self.path} lists them)"
            )

    def to_dict(self) -> dict[str, Any]:
        """``rig check --json`` of the file."""
        return {
            "path": self.path,
            "kind": self.KIND,
            "valid": self.valid,
            **{key: getattr(self, name) for name, key in self.COUNTS.items()},
            "problems": [asdict(p) for p in self.problems],
        }


def check_recording(path: str | os.PathLike, read_data: bool = True) -> CheckResult:
    """Validate a file: schema, version, attributes, channel lengths and rates, and (with
    ``read_data``) that every sample can be read.

    A file being written (its writer holds the lock) is checked as it is: the open point's
    unflushed tail is only noted, and a check that meets the file between two of the writer's
    states (it closes and reopens the file between points) is repeated.

    Raises
    ------
    RecordingError
        If the file cannot be opened as HDF5 at all (missing, truncated, not HDF5), or it has a
        newer ``schema_version`` than this rigtools reads (it cannot be checked; exit 2).
    """
    named(path)
    deadline = time.monotonic() + LIVE_RETRY_S
    while True:
        writer = writer_alive(path)
        try:
            result = _check_once(path, read_data)
            past_end = writer is None and any(PAST_END.search(p.message) for p in result.problems)
        except RecordingError as exc:
            past_end = writer is None and bool(PAST_END.search(str(exc)))
            if not past_end and (writer is None or time.monotonic() > deadline):  # as open_recording
                raise
            if not past_end:
                time.sleep(0.05)
                continue
        if past_end:
            # a killed writer's objects past the recorded end: checked as the readers read it
            result = _check_once(path, read_data, extend_eoa=True)
            result.problems.append(
                Problem(
                    "/",
                    "the writer stopped before recording the file's end (objects past it): read "
                    "with the end at the file's size (h5clear --increment FILE fixes the file)",
                    severity=NOTE,
                )
            )
        if writer is not None and not result.valid and time.monotonic() <= deadline:
            time.sleep(0.05)
            continue
        break
    result.writer = writer
    if result.status == "recording":
        result.problems = [p for p in result.problems if not p.message.startswith("incomplete:")]
        result.problems.append(
            Problem(
                "/",
                "incomplete: status is 'recording': "
                + (
                    f"being written now ({writer}); showing what is there"
                    if writer
                    else "the writer stopped without closing the file (killed, crashed or a write error)"
                ),
                severity=NOTE,
            )
        )
    return result


def _check_once(path: str | os.PathLike, read_data: bool, extend_eoa: bool = False) -> CheckResult:
    f, opened_as = open_h5(path, extend_eoa=extend_eoa)
    try:
        return _check_file(f, path, opened_as, read_data)
    except (OSError, RuntimeError, KeyError, ValueError) as exc:
        raise RecordingError(f"{path}: damaged HDF5 structure ({one_line(exc, None)})") from None
    finally:
        f.close()


def sample_problems(f: h5py.File, skip: frozenset[str] = frozenset()) -> list[Problem]:
    """``_data_problems`` of every point group of ``f`` (not those named in ``skip``): the
    samples ``rig check`` reads (unreadable, NaN or infinite)."""
    out: list[Problem] = []
    points = f.get(POINTS_GROUP)
    if not isinstance(points, h5py.Group):
        return out
    for name in points:
        if point_index(name) is None or name in skip:
            continue
        group = points[name]
        if isinstance(group, h5py.Group):
            ended = group.attrs.get("end_time", b"") not in ("", b"")
            out.extend(_data_problems(group, f"/{POINTS_GROUP}/{name}", ended))
    return out


def _as_cut_off(problem: Problem) -> Problem:
    """A problem of a point an unfinished writer cut off: noted (every reader leaves the point
    out and keeps the others; nothing else recorded is lost)."""
    why = f"{problem.message} (cut off by the writer that stopped: readers leave the point out)"
    return Problem(problem.where, why, severity=NOTE)


def damaged_line(path: str | os.PathLike, damaged: list[Problem], listed: int) -> str:
    """The one line that refuses a recording ``rig check`` rejects (non-fatal errors): the file,
    its first damage, how many problems check lists (``listed``), and the way out in the
    caller's words."""
    first = damaged[0]
    where = "" if first.where == "/" else f"{first.where}: "
    count = f"{listed} problem{'s' * (listed != 1)}"
    way_out = option("skip_damaged", True)
    return (
        f"{path} is damaged: {where}{first.message} "
        f"(rig check {path} lists {count}; {way_out} reads the rest)"
    )


def point_of(where: str) -> str | None:
    """The point group name of a problem's location (``/points/0003/force`` -> ``0003``)."""
    parts = where.strip("/").split("/")
    return parts[1] if len(parts) >= 2 and parts[0] == POINTS_GROUP.strip("/") else None


def cut_off_points(f: h5py.File, fatal: list) -> frozenset[str]:
    """Points whose fatal problems an unfinished writer explains (status still "recording").

    A writer killed mid-write (or one changing a point while it is read) can leave that point's
    structure unreadable; the file's other points are intact and are kept."""
    try:
        unfinished = f.attrs.get("status") == STATUS_RECORDING
    except (OSError, RuntimeError, KeyError):
        return frozenset()
    if not unfinished:
        return frozenset()
    return frozenset(n for n in (point_of(p.where) for p in fatal) if n is not None)


def _check_file(f: h5py.File, path: str | os.PathLike, opened_as: str, read_data: bool) -> CheckResult:
    result = CheckResult(str(path), opened_as=opened_as)
    try:
        try:
            result.problems = find_problems(f)
        except (OSError, RuntimeError, KeyError, ValueError) as exc:
            raise RecordingError(f"{path}: damaged HDF5 structure ({one_line(exc, None)})") from None
        if result.problems and result.problems[0].message.startswith(NEWER_PREFIX):
            raise RecordingError(f"{path}: {result.problems[0].message}; this rigtools cannot check it")
        cut_off = cut_off_points(f, [p for p in result.problems if p.fatal])
        result.problems = [_as_cut_off(p) if point_of(p.where) in cut_off else p for p in result.problems]
        if opened_as == "flags-cleared":
            result.problems.append(
                Problem(
                    "/",
                    "the writer was killed while adding structure "
                    "(HDF5 consistency flags set; h5clear -s clears "
                    "them for other tools)",
                    severity=NOTE,
                )
            )
        if "status" in f.attrs:
            result.status = python_value(_scalar(f.attrs["status"]))
        points = f.get(POINTS_GROUP)
        if isinstance(points, h5py.Group):
            names = [n for n in points if point_index(n) is not None]
            result.n_points = len(names)
            channels: set[str] = set()
            for name in names:
                group = points[name]
                if isinstance(group, h5py.Group):
                    channels.update(group)
            result.n_channels = len(channels)
            if read_data:
                result.problems.extend(sample_problems(f, skip=cut_off))
    finally:
        f.close()
    return result


def _data_problems(group: h5py.Group, where: str, ended: bool = True, block: int = 1 << 20) -> list[Problem]:
    """Unreadable and non-finite samples of a point's channels.

    In a point its writer ended, every sample was written: a NaN or infinite sample is an error
    (a simulation that blew up, a damaged file). In a point that never ended (being written,
    writer killed, write error) the non-finite tail is the part not flushed (HDF5 fills it with
    NaN) and is only noted; non-finite samples before that tail are still errors.
    """
    out = []
    for name in group:
        dataset = group[name]
        if not isinstance(dataset, h5py.Dataset) or dataset.ndim != 1:
            continue
        n_bad = 0
        n_huge = 0  # finite samples whose square overflows: every spectrum and fit would be inf
        last_good = -1  # index of the last finite sample
        start = 0
        try:
            for start in range(0, dataset.shape[0], block):
                values = dataset[start : start + block]
                if values.dtype.kind == "f":
                    finite = np.isfinite(values)
                    n_bad += int(finite.size - np.count_nonzero(finite))
                    n_huge += int(np.count_nonzero(np.abs(values[finite]) > MAX_SAMPLE_MAGNITUDE))
                    if finite.any():
                        last_good = start + int(np.flatnonzero(finite)[-1])
                else:
                    last_good = start + values.size - 1
        except (OSError, ValueError, RuntimeError) as exc:
            out.append(
                Problem(
                    f"{where}/{name}",
                    f"samples cannot be read from index {start} ({one_line(exc, None)})",
                )
            )
            continue
        tail = dataset.shape[0] - 1 - last_good if not ended else 0
        inner = n_bad - tail
        if inner:
            out.append(
                Problem(
                    f"{where}/{name}",
                    f"{inner} sample{'s' * (inner != 1)} "
                    "NaN or infinite" + ("" if ended else " before the unflushed tail"),
                )
            )
        if n_huge:
            out.append(
                Problem(
                    f"{where}/{name}",
                    f"{n_huge} sample{'s' * (n_huge != 1)} beyond +-{MAX_SAMPLE_MAGNITUDE:g}: "
                    "no measured or modelled quantity in SI units reaches that (a damaged file?); "
                    "its squares overflow every spectrum and fit",
                )
            )
        if tail:
            out.append(
                Problem(
                    f"{where}/{name}",
                    f"last {tail} samples are NaN: not flushed when the writer stopped (point incomplete)",
                    severity=NOTE,
                )
            )
    return out
