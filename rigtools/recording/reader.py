"""Reading recordings: :func:`open_recording` and the lazy objects it returns.

Samples stay on disk until asked for: a :class:`Channel` behaves like a read-only 1-D numpy array
(``len``, slicing, ``np.asarray(channel)``) and reads only what is sliced. Files whose writer was
killed open too (through HDF5's SWMR-read mode, or with the consistency flags cleared in memory
when the writer died while adding structure) and report ``complete == False``.
"""

from __future__ import annotations

import json
import os
import time
import tomllib
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import TYPE_CHECKING, Any

import h5py
import numpy as np
import numpy.typing as npt

from rigtools.config import RigConfig, parse_rig
from rigtools.options import switch
from rigtools.recording.lock import writer_alive
from rigtools.recording.opener import LIVE_RETRY_S, PAST_END, named, open_h5
from rigtools.recording.opener import hdf5_reason as _reason
from rigtools.recording.schema import (
    POINTS_GROUP,
    STATUS_COMPLETE,
    STATUS_RECORDING,
    RecordingError,
    point_index,
    python_value,
)
from rigtools.recording.validate import (
    ERROR,
    AttrCache,
    Problem,
    Unreadable,
    cut_off_points,
    damaged_line,
    find_problems,
    point_of,
    sample_problems,
)
from rigtools.vocabulary import current_parameters

if TYPE_CHECKING:
    from typing import Self


def open_checked(
    path: str | os.PathLike, schema: str, what: tuple[str, str], newest: int, problems: list[Problem]
) -> tuple[h5py.File, dict[str, Any]]:
    """The check preamble of rigtools' own HDF5 files (branches files, FRF sets): open ``path``
    (``open_h5``: one line if missing, a folder, truncated or not HDF5), refuse another
    ``schema`` or a ``schema_version`` above ``newest``, and add a version that is not an integer
    to ``problems``. ``what``: the file kind with its article and alone (``("an FRF set", "FRF
    set")``). Returns the open file (the caller closes it) and its root attributes."""
    f, _ = open_h5(path, wait=False)
    try:
        attrs = dict(f.attrs)
        if attrs.get("schema") != schema:
            raise RecordingError(f"{path}: not {what[0]} (schema {attrs.get('schema')!r})")
        version = attrs.get("schema_version")
        if not isinstance(version, (int, np.integer)) or isinstance(version, (bool, np.bool_)):
            problems.append(Problem("/", f"schema_version must be an integer, got {version!r}"))
        elif version > newest:
            raise RecordingError(
                f"{path}: {what[1]} schema_version {version} is newer than this rigtools reads "
                f"({newest}): upgrade rigtools"
            )
    except RecordingError:
        f.close()
        raise
    except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:
        f.close()
        raise RecordingError(f"{path}: damaged HDF5 structure ({_reason(exc)})") from None
    return f, attrs


def has_schema(path: str | os.PathLike, schema: str) -> bool:
    """True if ``path`` is an HDF5 file whose root attribute ``schema`` is ``schema`` (which of
    rigtools' own files it is, before :func:`open_checked`); False for anything else."""
    try:
        with h5py.File(path, "r") as f:
            return bool(f.attrs.get("schema") == schema)
    except (OSError, ValueError):
        return False


def _attrs(obj: h5py.HLObject, cache: AttrCache | None) -> dict[str, Any]:
    raw = (cache if cache is not None else AttrCache()).of(obj)
    return {key: python_value(value) for key, value in raw.items() if not isinstance(value, Unreadable)}


class Channel:
    """One channel of one point: a lazily read 1-D float array with its metadata.

    Attributes
    ----------
    name, units, quantity : str
    sample_rate : float
        Hz.
    t0 : float
        Time of the first sample, s from the start of the point.
    sensitivity : float or None
        In ``sensitivity_units``; ``physical_channel`` and ``location`` likewise None if not set.
    node, direction : int or None
        Where an imported file put the sensor: node number and UFF direction code (1..6 = +X..+RZ,
        negative the opposite sense, 0 none); ``entity`` and ``description`` what it called the
        point and the record (UFF entity name, ID line 1). None if not set.
    """

    def __init__(self, dataset: h5py.Dataset, path: str, cache: AttrCache | None = None):
        self._dataset = dataset
        self._path = path
        self.name = dataset.name.rsplit("/", 1)[-1]
        self.attrs = _attrs(dataset, cache)
        self.units: str = self.attrs["units"]
        self.quantity: str = self.attrs["quantity"]
        self.sample_rate = float(self.attrs["sample_rate"])
        self.t0 = float(self.attrs["t0"])
        self.sensitivity: float | None = self.attrs.get("sensitivity")
        self.sensitivity_units: str | None = self.attrs.get("sensitivity_units")
        self.physical_channel: str | None = self.attrs.get("physical_channel")
        self.location: str | None = self.attrs.get("location")
        self.node: int | None = self.attrs.get("node")
        self.direction: int | None = self.attrs.get("direction")
        self.entity: str | None = self.attrs.get("entity")
        self.description: str | None = self.attrs.get("description")

    def __repr__(self) -> str:
        return (
            f"<Channel {self.name!r}: {len(self)} samples of {self.quantity} in {self.units} "
            f"at {self.sample_rate:g} Hz>"
        )

    @property
    def shape(self) -> tuple[int]:
        return self._dataset.shape

    @property
    def dtype(self) -> np.dtype:
        return self._dataset.dtype

    ndim = 1

    @property
    def size(self) -> int:
        return self._dataset.shape[0]

    def __len__(self) -> int:
        return self._dataset.shape[0]

    @property
    def duration(self) -> float:
        """Recorded length in seconds (``len / sample_rate``)."""
        return len(self) / self.sample_rate

    def __getitem__(self, key: Any) -> np.ndarray:
        try:
            return self._dataset[key]
        except (OSError, RuntimeError) as exc:
            raise RecordingError(f"{self._path}: cannot read {self._dataset.name} ({_reason(exc)})") from None

    def read(self) -> np.ndarray:
        """All samples as a numpy array."""
        return self[()] if len(self) else np.empty(0, dtype=self.dtype)

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        data = self.read()
        return data if dtype is None else data.astype(dtype)

    def time(self) -> np.ndarray:
        """Sample times in s from the start of the point: ``t0 + i / sample_rate``."""
        return self.t0 + np.arange(len(self)) / self.sample_rate

    def refresh(self) -> None:
        """Pick up samples a live SWMR writer appended since the file was opened."""
        if self._dataset.file.swmr_mode:
            self._dataset.refresh()


class Point:
    """One steady-state point: ``params`` (dict) and ``channels`` (name -> :class:`Channel`)."""

    def __init__(
        self,
        group: h5py.Group,
        path: str,
        cache: AttrCache | None = None,
        omit: frozenset[str] = frozenset(),
    ):
        self.name = group.name.rsplit("/", 1)[-1]
        self.index = int(self.name)
        attrs = _attrs(group, cache)
        self.start_time: str = attrs.pop("start_time")
        self.end_time: str = attrs.pop("end_time")
        # v1 files written before the vocabulary read with today's names.
        self.params: dict[str, Any] = current_parameters(attrs)
        self.channels: dict[str, Channel] = {
            name: Channel(group[name], path, cache) for name in group if name not in omit
        }

    def __repr__(self) -> str:
        return f"<Point {self.name}: {self.params} channels={list(self.channels)}>"

    def __getitem__(self, name: str) -> Channel:
        return self.channels[name]

    @property
    def ended(self) -> bool:
        """True if the writer ended this point normally (its end-of-point parameters are set)."""
        return bool(self.end_time)

    @property
    def complete(self) -> bool:
        """True if the point was ended by its writer: all its samples and end-of-point parameters
        were written. False for a point still being written or cut off (writer killed, write
        error); such a point must not be counted as a valid measurement."""
        return bool(self.end_time)

    @property
    def stopped(self) -> bool:
        """True if the procedure was stopped inside this point (``point_complete`` false): the
        writer may have ended it (:attr:`complete` true), but its record is cut short."""
        return self.params.get("point_complete", True) is False

    @property
    def whole(self) -> bool:
        """True if the point's record is whole: ended by its writer (:attr:`complete`) and not
        stopped inside (:attr:`stopped`); what is passed on as data (``rig export``)."""
        return self.complete and not self.stopped

    @property
    def n_samples(self) -> int:
        """Samples per channel (the shortest channel, if a killed writer left them uneven)."""
        return min((len(c) for c in self.channels.values()), default=0)

    @property
    def sample_rate(self) -> float | None:
        rates = {c.sample_rate for c in self.channels.values()}
        return rates.pop() if len(rates) == 1 else None

    @property
    def duration(self) -> float:
        """Recorded seconds (``n_samples / sample_rate``; 0 for an empty point)."""
        if not self.channels:
            return 0.0
        return self.n_samples / next(iter(self.channels.values())).sample_rate

    @property
    def record_window(self) -> tuple[int, int]:
        """``(first sample, samples)`` of the settled record window: the point parameters
        ``record_start`` (s) and ``record_samples`` where the writer set them, else the whole point."""
        n = self.n_samples
        rate = self.sample_rate or 1.0
        start = round(float(self.params.get("record_start", 0.0) or 0.0) * rate)
        start = min(max(start, 0), n)
        count = int(self.params.get("record_samples", n - start) or (n - start))
        return start, max(0, min(count, n - start))

    def settled(self, channel: str) -> np.ndarray:
        """Samples of ``channel`` (SI units) in the settled record window (:attr:`record_window`)."""
        start, count = self.record_window
        return np.asarray(self.channels[channel][start : start + count], dtype=float)

    def to_dataframe(self):
        """Wide table: index ``time`` (s), one column per channel (trimmed to ``n_samples``)."""
        import pandas as pd

        n = self.n_samples
        first = next(iter(self.channels.values()), None)
        time_s = first.time()[:n] if first is not None else np.empty(0)
        frame = pd.DataFrame(
            {name: c[:n] if n else np.empty(0) for name, c in self.channels.items()},
            index=pd.Index(time_s, name="time"),
        )
        return frame


class Recording:
    """An open recording; use as a context manager or call :meth:`Recording.close`.

    Attributes
    ----------
    status : str
        ``"recording"`` (writer running or killed), ``"complete"`` or ``"aborted"``.
    complete : bool
        ``status == "complete"``; ``incomplete`` is its negation.
    abort_reason, backend, created, ended, software_version : str
    schema_version : int
    rig : str
        The rig description text (TOML or JSON).
    experiment : dict
    points : list of Point
    notes : list of str
        One line per damaged point or channel left out, or damaged file-level attribute read
        on, when the file was opened with ``skip_damaged=True``; empty otherwise.
    opened_as : str
        How HDF5 had to open the file: ``"clean"``, ``"swmr"`` or ``"flags-cleared"``.
    writer : str or None
        The live writer holding the file's lock (``"pid 4242 on labpc since ..."``) when the file
        was opened, else None. ``status == "recording"`` with no writer means it was killed.
    """

    def __init__(
        self,
        f: h5py.File,
        path: str,
        opened_as: str,
        cache: AttrCache | None = None,
        unreadable: frozenset[str] = frozenset(),
        damaged: list[Problem] | None = None,
    ):
        self._file = f
        self.path = path
        self.opened_as = opened_as
        attrs = _attrs(f, cache)
        self.attrs = attrs
        self.schema_version: int = attrs["schema_version"]
        self.status: str = attrs["status"]
        self.abort_reason: str = attrs["abort_reason"]
        self.backend: str = attrs["backend"]
        self.created: str = attrs["created"]
        self.ended: str = attrs["ended"]
        self.software_version: str = attrs["software_version"]
        self.rig: str = attrs["rig"]
        self.experiment: dict[str, Any] = json.loads(attrs["experiment"])
        group = f[POINTS_GROUP]
        names = sorted((n for n in group if point_index(n) is not None), key=int)
        self.points: list[Point] = []
        left_out, omit, self.notes = _left_out(damaged or [])
        #: Points of an unfinished file (status "recording": writer live or killed) whose structure
        #: cannot be read: a killed writer cut them off mid-write, or a live one is changing them.
        #: They are not in :attr:`points`; every point that can be read is (nothing else is lost).
        self.unreadable_points: list[str] = []
        for n in names:
            if n in unreadable:
                self.unreadable_points.append(n)
                continue
            if n in left_out:
                continue
            try:
                self.points.append(Point(group[n], path, cache, omit.get(n, frozenset())))
            except (OSError, RuntimeError, KeyError, ValueError):
                if self.status != STATUS_RECORDING:
                    raise
                self.unreadable_points.append(n)
        self.writer: str | None = None

    @property
    def writing(self) -> bool:
        """True if a writer was running on the file when it was opened."""
        return self.writer is not None

    @property
    def complete_points(self) -> list[Point]:
        """The points their writer ended (:attr:`Point.complete`): the ones to analyse."""
        return [p for p in self.points if p.complete]

    def __repr__(self) -> str:
        return f"<Recording {self.path}: {self.status}, backend {self.backend}, {len(self.points)} points>"

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self._file.close()

    def __iter__(self) -> Iterator[Point]:
        return iter(self.points)

    @property
    def complete(self) -> bool:
        return self.status == STATUS_COMPLETE

    @property
    def incomplete(self) -> bool:
        return not self.complete

    def rig_config(self) -> RigConfig:
        """The rig description validated into a :class:`rigtools.config.RigConfig`."""
        try:
            data = json.loads(self.rig)
        except ValueError:
            try:
                data = tomllib.loads(self.rig)
            except tomllib.TOMLDecodeError as exc:
                raise RecordingError(f"{self.path}: rig attribute is neither JSON nor TOML ({exc})") from None
        if not isinstance(data, dict):
            raise RecordingError(
                f"{self.path}: rig attribute is not a rig description (a {type(data).__name__})"
            )
        return parse_rig(data, source=f"{self.path} rig")

    def to_dataframe(self, per: str = "sample"):
        """The recording as a pandas DataFrame.

        Parameters
        ----------
        per : {"sample", "point"}
            ``"sample"``: tidy long table, one row per sample and channel, columns ``point``
            (int), ``channel`` (categorical), ``time`` (s from the point's start), ``value``
            (in the channel's units). ``"point"``: one row per point, columns ``point``,
            ``start_time``, ``end_time``, ``n_samples``, ``duration`` (s), then the parameters.
        """
        import pandas as pd

        if per == "point":
            rows = [
                {
                    "point": p.index,
                    "start_time": p.start_time,
                    "end_time": p.end_time,
                    "n_samples": p.n_samples,
                    "duration": p.duration,
                    **p.params,
                }
                for p in self.points
            ]
            return pd.DataFrame(rows)
        if per != "sample":
            raise ValueError(f"per={per!r}: use 'sample' or 'point'")
        names = list(dict.fromkeys(c for p in self.points for c in p.channels))
        parts: dict[str, list[np.ndarray]] = {"point": [], "channel": [], "time": [], "value": []}
        for p in self.points:
            for name, channel in p.channels.items():
                n = len(channel)
                parts["point"].append(np.full(n, p.index, dtype=np.int64))
                parts["channel"].append(np.full(n, names.index(name), dtype=np.int32))
                parts["time"].append(channel.time())
                parts["value"].append(channel.read())

        def cat(key: str, dtype: type[np.generic]) -> np.ndarray:
            return np.concatenate(parts[key]) if parts[key] else np.empty(0, dtype)

        codes: npt.NDArray[np.int32] = cat("channel", np.int32)
        return pd.DataFrame(
            {
                "point": cat("point", np.int64),
                "channel": pd.Categorical.from_codes(codes, categories=pd.Index(names)),
                "time": cat("time", np.float64),
                "value": cat("value", np.float64),
            }
        )


def open_recording(
    path: str | os.PathLike,
    wait: bool = True,
    *,
    skip_damaged: bool | None = None,
    check_samples: bool = True,
) -> Recording:
    """Open a recording (schema v1) for reading.

    The file is checked as ``rig check`` checks it (its samples included): a file check rejects
    is refused in one line naming its first problem, unless ``skip_damaged``.

    Parameters
    ----------
    path
        The HDF5 file (a file being written may be read while it grows).
    wait
        False: one attempt; a file its live writer is changing at that moment raises
        :class:`RecordingError` at once instead of being retried for up to a few seconds.
    skip_damaged
        True: read a damaged file, leaving each damaged point or channel out with one line in
        ``Recording.notes`` (a damaged file-level attribute is noted and read on). None: as
        the enclosing ``reading_damaged`` says (``rig ... --skip-damaged``), else False.
    check_samples
        False: check the metadata only, not every sample (a follower of a live file that reads
        only what was appended: ``rigtools.monitor``).

    Returns
    -------
    Recording
        With ``status``, ``rig``, ``experiment``, ``points`` (parameters and lazily read
        channels) and ``to_dataframe()``. Files of killed writers open with ``complete False``.

    Raises
    ------
    RecordingError
        One line: missing or unreadable file (truncated, not HDF5), another schema, a newer
        ``schema_version``, or a missing/invalid required attribute; or, unless
        ``skip_damaged``, any other problem ``rig check`` reports as an error ("FILE is damaged:
        /points/0003: ... (rig check FILE lists 2 problems; skip_damaged=True reads the rest)").

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "dwell.h5"
    >>> run = rigtools.dwell("60 Hz", "5 N", out, gap="5 mm", record_periods=6, backend="sim", seed=1)
    >>> with rigtools.open_recording(run.file) as rec:
    ...     point = rec.points[0]
    ...     force = point.settled("force")  # N, the settled record window only
    ...     print(rec.status, rec.backend, force.size == point.record_window[1])
    complete simulated True
    """
    named(path)
    deadline = time.monotonic() + LIVE_RETRY_S
    while True:
        writer = writer_alive(path)
        try:
            rec = _open_once(path, wait, _skip(skip_damaged), check_samples)
        except RecordingError as exc:
            if writer is None and PAST_END.search(str(exc)):
                # a writer killed between writing an object and recording the file's new end:
                # read it with the end at the file's size (h5clear --increment, in memory only)
                rec = _open_once(path, wait, _skip(skip_damaged), check_samples, extend_eoa=True)
                rec.writer = None
                return rec
            # A live writer between two states of the file (closing/reopening it between
            # points, or trimming it as it ends the run) can make one look damaged for a moment:
            # look again. A writer that ended meanwhile left its final file: one more look (the
            # next attempt finds no writer and its answer stands).
            if not wait or writer is None or time.monotonic() > deadline:
                raise
            time.sleep(0.05)
            continue
        rec.writer = writer if writer is not None else writer_alive(path)
        return rec


_SKIP_DAMAGED: ContextVar[bool] = ContextVar("skip_damaged", default=False)


@contextmanager
def reading_damaged(skip: bool = True) -> Iterator[None]:
    """Inside the block, :func:`open_recording` calls that do not say ``skip_damaged`` read
    damaged recordings leaving their damaged parts out (``skip``) or refuse them (the default).
    ``rig``'s entry point opens one around a command given ``--skip-damaged``."""
    token = _SKIP_DAMAGED.set(bool(skip))
    try:
        yield
    finally:
        _SKIP_DAMAGED.reset(token)


def _skip(skip_damaged: bool | None) -> bool:
    return _SKIP_DAMAGED.get() if skip_damaged is None else switch(skip_damaged, "skip_damaged")


def _left_out(damaged: list[Problem]) -> tuple[set[str], dict[str, frozenset[str]], list[str]]:
    """What a damaged file read with ``skip_damaged`` leaves out: point names, channel names per
    point, and one note per point, channel or file-level problem (its first problem; the count
    of the others)."""
    by_place: dict[tuple[str | None, str | None], list[Problem]] = {}
    for problem in damaged:
        point = point_of(problem.where)
        parts = problem.where.strip("/").split("/")
        channel = parts[2] if point is not None and len(parts) >= 3 else None
        by_place.setdefault((point, channel), []).append(problem)
    points = {point for point, channel in by_place if point is not None and channel is None}
    channels: dict[str, set[str]] = {}
    notes: list[str] = []
    for (point, channel), problems in by_place.items():
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        first = problems[0].message
        if point is None:
            notes.append(f"{problems[0].where}: {first}{more}: read on (skip_damaged)")
        elif channel is None:
            notes.append(f"point {int(point)} left out: {first}{more}")
        elif point not in points:
            channels.setdefault(point, set()).add(channel)
            notes.append(f"point {int(point)} channel {channel} left out: {first}{more}")
    return points, {k: frozenset(v) for k, v in channels.items()}, notes


#: Sample scans of finished files by (path, size, modification time): a command opens one file
#: several times (analysis, tables, figures) and its samples are scanned once.
_SCANS: dict[tuple[str, int, int], list[Problem]] = {}


def _scanned(path: str | os.PathLike, f: h5py.File, cut_off: frozenset[str]) -> list[Problem]:
    if f.attrs.get("status") == STATUS_RECORDING or writer_alive(path):
        return sample_problems(f, skip=cut_off)  # still growing: scan what is there now
    st = os.stat(path)
    key = (os.path.realpath(path), st.st_size, st.st_mtime_ns)
    if key not in _SCANS:
        if len(_SCANS) > 64:
            _SCANS.clear()
        _SCANS[key] = sample_problems(f, skip=cut_off)
    return _SCANS[key]


def _open_once(
    path: str | os.PathLike,
    wait: bool = True,
    skip_damaged: bool = False,
    check_samples: bool = True,
    extend_eoa: bool = False,
) -> Recording:
    f, opened_as = open_h5(path, wait, extend_eoa)
    try:
        cache = AttrCache()
        problems = find_problems(f, cache)
        fatal = [p for p in problems if p.fatal]
        cut_off = cut_off_points(f, fatal)
        fatal = [p for p in fatal if point_of(p.where) not in cut_off]
        if fatal:
            where = "" if fatal[0].where == "/" else f"{fatal[0].where}: "
            more = f" (and {len(fatal) - 1} more; run: rig check {path})" if len(fatal) > 1 else ""
            raise RecordingError(f"{path}: {where}{fatal[0].message}{more}")
        if check_samples:
            problems += _scanned(path, f, cut_off)
        # what rig check reports as errors beyond the fatal ones: the file is refused, or read
        # without the damaged parts (a point cut off by a killed writer is left out either way)
        errors = [
            p for p in problems if p.severity == ERROR and not p.fatal and point_of(p.where) not in cut_off
        ]
        damaged = [p for p in errors if not p.model_only]
        if damaged and not skip_damaged:
            raise RecordingError(damaged_line(path, damaged, len(errors)))
        rec = Recording(f, str(path), opened_as, cache, cut_off, damaged)
        # the rig description matters to the readers that build the model (they refuse it,
        # naming --rig); the others read the intact samples and say it
        rec.notes.extend(f"{p.message} (the samples are read)" for p in errors if p.model_only)
        return rec
    except RecordingError:
        f.close()
        raise
    except (OSError, RuntimeError, KeyError, ValueError) as exc:
        f.close()
        raise RecordingError(f"{path}: damaged HDF5 structure ({_reason(exc)})") from None
