"""The one result of every procedure, however it is called: :class:`RunResult`.

``rigtools.dwell(...)`` and ``SineDwell(...).run()`` return the same :class:`RunResult`: its
``status`` a :class:`~rigtools.procedures.result.Status` (a string enum: ``run.status == "finished"`` and ``run.status is
Status.FINISHED`` both hold, and it prints as the word), its ``points`` :class:`~rigtools.PointResult`
objects with attributes in SI units (``point.fe``, ``point.harmonics["force"][0]``).
"""

from __future__ import annotations

import enum
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rigtools.recording import RecordingError, open_recording

if TYPE_CHECKING:
    import pandas as pd

    from rigtools.recording.reader import Recording
    from rigtools.recording_analysis.results import RecordingAnalysis


class Status(str, enum.Enum):  # noqa: UP042 -- the word is printed by str(), format() and repr() alike
    """How a procedure ended: ``"finished"``, ``"aborted"`` (a stop request, Ctrl-C, a signal)
    or ``"failed"`` (a fault, a safety abort, an error).

    A string: it equals its word and prints as it.

    Examples
    --------
    >>> from rigtools.procedures import Status
    >>> Status.FINISHED == "finished", f"{Status.ABORTED}", Status.FAILED
    (True, 'aborted', 'failed')
    """

    FINISHED = "finished"
    ABORTED = "aborted"
    FAILED = "failed"

    def __str__(self) -> str:
        return self.value

    def __format__(self, spec: str) -> str:
        return format(self.value, spec)

    def __repr__(self) -> str:
        return repr(self.value)


# the procedures' own names of the fields PointResult holds as attributes
_KNOWN = {
    "fe",
    "force_amplitude",
    "gap",
    "force_amplitude_measured",
    "drive_amplitude",
    "settled",
    "control_updates",
    "record_start",
    "record_samples",
    "harmonics",
}


@dataclass(frozen=True)
class PointResult:
    """What one recorded point measured (SI units).

    Attributes
    ----------
    index
        Point number in the recording (0-based).
    fe
        Excitation frequency, Hz (``None`` for broadband points: FRF and tap tests).
    force
        Force amplitude asked for (F0, fundamental), N, or ``None``.
    gap
        Shroud gap, m, or ``None`` when not set by the procedure.
    force_amplitude_measured
        Fundamental of the measured force, N (peak), or ``None``.
    drive_amplitude
        Drive voltage amplitude at the end of force control, V peak, or ``None``.
    settled
        The response reached its steady state before the record (``None`` if not judged).
    control_updates
        Force-control updates made, or ``None``.
    record_start
        Start of the settled record window in the point, s (``None``: the whole point).
    record_samples
        Samples in the settled record window (``None``: the whole point).
    harmonics
        ``{channel: (peak amplitudes of k = 1, 2, ...)}`` in the channel's SI unit (sine points).
    phases
        ``{channel: (phases of k = 1, 2, ...)}``, rad, relative to the force's (sine points).
    extra
        Every other parameter the procedure reported, by its vocabulary name (``direction`` of
        a stepped-sine step, ``study_value``, ``peaks``, ``accepted`` of a tap, ...).

    Examples
    --------
    >>> from rigtools.procedures.result import PointResult
    >>> p = PointResult.from_procedure(0, {"fe": 60.0, "force_amplitude": 15.0, "record_start": 1.5})
    >>> p.fe, p.force, p.record_start
    (60.0, 15.0, 1.5)
    """

    index: int
    fe: float | None = None
    force: float | None = None
    gap: float | None = None
    force_amplitude_measured: float | None = None
    drive_amplitude: float | None = None
    settled: bool | None = None
    control_updates: int | None = None
    record_start: float | None = None
    record_samples: int | None = None
    harmonics: Mapping[str, tuple[float, ...]] = field(default_factory=dict)
    phases: Mapping[str, tuple[float, ...]] = field(default_factory=dict, repr=False)
    extra: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def from_procedure(cls, index: int, values: Mapping[str, Any]) -> PointResult:
        """A point as a procedure reports it (a plain mapping, SI units)."""

        def number(name: str) -> float | None:
            v = values.get(name)
            return None if v is None else float(v)

        def whole(name: str) -> int | None:
            v = values.get(name)
            return None if v is None else int(v)

        rows = {
            str(name): h
            for name, h in (values.get("harmonics") or {}).items()
            if isinstance(h, Mapping) and "amplitude" in h
        }
        return cls(
            index=index,
            fe=number("fe"),
            force=number("force_amplitude"),
            gap=number("gap"),
            force_amplitude_measured=number("force_amplitude_measured"),
            drive_amplitude=number("drive_amplitude"),
            settled=None if values.get("settled") is None else bool(values["settled"]),
            control_updates=whole("control_updates"),
            record_start=number("record_start"),
            record_samples=whole("record_samples"),
            harmonics={k: tuple(float(a) for a in h["amplitude"]) for k, h in rows.items()},
            phases={k: tuple(float(a) for a in h["phase"]) for k, h in rows.items() if "phase" in h},
            extra={k: v for k, v in values.items() if k not in _KNOWN},
        )

    def to_dict(self) -> dict[str, Any]:
        """Plain Python (JSON-ready apart from what ``extra`` holds)."""
        return {
            "index": self.index,
            "fe": self.fe,
            "force": self.force,
            "gap": self.gap,
            "force_amplitude_measured": self.force_amplitude_measured,
            "drive_amplitude": self.drive_amplitude,
            "settled": self.settled,
            "control_updates": self.control_updates,
            "record_start": self.record_start,
            "record_samples": self.record_samples,
            "harmonics": {k: list(v) for k, v in self.harmonics.items()},
            **dict(self.extra),
        }

    def __getitem__(self, key: str) -> Any:
        """Deprecated: the points were plain dicts (``point["fe"]``); use the attributes."""
        warnings.warn(
            f"point[{key!r}] is deprecated: a point is a PointResult, use its attributes "
            f"(point.fe, point.force, point.harmonics[channel][k - 1], point.extra[name])",
            DeprecationWarning,
            stacklevel=2,
        )
        if key == "force_amplitude":
            return self.force
        if key == "harmonics":
            return {
                k: {"amplitude": list(v), "phase": list(self.phases.get(k, ()))}
                for k, v in self.harmonics.items()
            }
        if key in _KNOWN:
            return getattr(self, key)
        return self.extra[key]


@dataclass(frozen=True)
class RunResult:
    """How a procedure ended and what it recorded: what every procedure returns, called from
    the front door (:func:`rigtools.dwell`, ...) or as a class (``SineDwell(...).run()``).

    Attributes
    ----------
    procedure
        ``"sine dwell"``, ``"stepped sine"``, ``"rig study"``, ``"frf test"`` or ``"tap test"``.
    status
        :class:`~rigtools.procedures.result.Status`: ``"finished"``, ``"aborted"`` (a stop request) or ``"failed"``;
        compares equal to the word.
    reason
        Why it stopped early (empty when finished).
    file
        The recording written.
    points
        :class:`~rigtools.PointResult` of each point, in recording order.
    summary
        What the procedure concluded (e.g. ``jumps`` of a stepped sine, ``modes`` of a tap test).

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "sweep.h5"
    >>> run = rigtools.stepped_sine("55 Hz:60 Hz:5 Hz", "5 N", out, gap="5 mm", periods=5, backend="sim")
    >>> table = run.to_dataframe()  # one row per point, SI units
    >>> run.status, list(table["fe"]), bool(table["settled"].all())
    ('finished', [55.0, 60.0], True)
    """

    procedure: str
    status: Status
    reason: str
    file: Path
    points: tuple[PointResult, ...]
    summary: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def from_procedure(cls, procedure: str, result: Any, out: str | Path) -> RunResult:
        """The result of a procedure's working record (``status``, ``reason``, ``file``,
        ``points`` as mappings, ``summary``); the points of a procedure that reports none (an
        FRF test) are read back from its recording."""
        file = Path(result.file or out)
        points = list(result.points)
        if not points and file.is_file():
            try:
                with open_recording(file) as rec:
                    points = [dict(p.params) for p in rec.points if p.complete]
            except RecordingError:
                points = []
        return cls(
            procedure=procedure,
            status=Status(result.status),
            reason=result.reason,
            file=file,
            points=tuple(PointResult.from_procedure(i, p) for i, p in enumerate(points)),
            summary=dict(result.summary),
        )

    def open(self) -> Recording:
        """The recording (:func:`rigtools.open_recording`); use it in a ``with`` block."""
        return open_recording(self.file)

    def analyze(self, **options: Any) -> RecordingAnalysis:
        """:func:`rigtools.analyze_recording` of the recording."""
        from rigtools.recording_analysis.dispatch import analyze_recording

        return analyze_recording(self.file, **options)

    def to_dict(self) -> dict[str, Any]:
        """Plain Python: the fields, each point by :meth:`~rigtools.PointResult.to_dict`."""
        return {
            "procedure": self.procedure,
            "status": self.status.value,
            "reason": self.reason,
            "file": str(self.file),
            "points": [p.to_dict() for p in self.points],
            "summary": dict(self.summary),
        }

    def to_dataframe(self) -> pd.DataFrame:
        """One row per point: the scalar fields (SI units), indexed by point."""
        import pandas as pd

        rows = [
            {k: v for k, v in p.to_dict().items() if not isinstance(v, (dict, list, tuple))}
            for p in self.points
        ]
        return pd.DataFrame(rows).set_index("index") if rows else pd.DataFrame()
