"""Experiments on the rig, as a lab script runs them: one function per procedure.

:func:`dwell`, :func:`stepped_sine`, :func:`study`, :func:`frf_test` and :func:`tap_test` run
the procedures of :mod:`rigtools.procedures` on the NI rig (``backend="nidaq"``) or on the
simulated rig (``backend="sim"``, the FE model behind a simulated shaker and DAQ), write one
recording each and return a :class:`RunResult`. Every parameter takes a quantity string as the
CLI does (``"60 Hz"``, ``"0.5 mm"``, ``"1 V"``) or an SI float; a bad one is one
:class:`rigtools.errors.UserError` line naming the parameter, the value and the allowed range.
The parameters, their units, defaults and bounds: :func:`rigtools.procedures.reference_table`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pandas as pd

    from rigtools.analyze import RecordingAnalysis
    from rigtools.config import RigConfig
    from rigtools.procedures.base import ProcedureResult, ProgressEvent
    from rigtools.recording.reader import Recording


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
    extra
        Every other parameter the procedure reported, by its vocabulary name.

    Examples
    --------
    >>> from rigtools.experiments import PointResult
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
    extra: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def from_procedure(cls, index: int, values: Mapping[str, Any]) -> PointResult:
        """A point of ``points`` of a :class:`rigtools.procedures.ProcedureResult` (a plain mapping)."""
        known = {
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

        def number(name: str) -> float | None:
            v = values.get(name)
            return None if v is None else float(v)

        harmonics = {
            str(name): tuple(float(a) for a in h["amplitude"])
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
            control_updates=None if values.get("control_updates") is None else int(values["control_updates"]),
            record_start=number("record_start"),
            record_samples=None if values.get("record_samples") is None else int(values["record_samples"]),
            harmonics=harmonics,
            extra={k: v for k, v in values.items() if k not in known},
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


@dataclass(frozen=True)
class RunResult:
    """How a procedure ended and what it recorded.

    Attributes
    ----------
    procedure
        ``"dwell"``, ``"stepped sine"``, ``"study"``, ``"frf test"`` or ``"tap test"``.
    status
        ``"finished"``, ``"aborted"`` (a stop request) or ``"failed"``.
    reason
        Why it stopped early (empty when finished).
    file
        The recording written.
    points
        :class:`PointResult` of each point, in recording order.
    summary
        What the procedure concluded (e.g. ``jumps`` of a stepped sine, ``modes`` of a tap test).

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "sweep.h5"
    >>> run = rigtools.stepped_sine(["55 Hz", "60 Hz"], "5 N", out, gap="5 mm", record_periods=5)
    >>> table = run.to_dataframe()  # one row per point, SI units
    >>> list(table["fe"]), bool(table["settled"].all())
    ([55.0, 60.0], True)
    """

    procedure: str
    status: str
    reason: str
    file: Path
    points: tuple[PointResult, ...]
    summary: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def from_procedure(cls, procedure: str, result: ProcedureResult, out: str | Path) -> RunResult:
        """The typed form of a :class:`rigtools.procedures.ProcedureResult`; the points of a
        procedure that reports none (FRF and tap tests) are read back from its recording."""
        file = Path(result.file or out)
        points = list(result.points)
        if not points and file.is_file():
            from rigtools.recording import RecordingError, open_recording

            try:
                with open_recording(file) as rec:
                    points = [dict(p.params) for p in rec.points if p.complete]
            except RecordingError:
                points = []
        return cls(
            procedure=procedure,
            status=result.status.value,
            reason=result.reason,
            file=file,
            points=tuple(PointResult.from_procedure(i, p) for i, p in enumerate(points)),
            summary=dict(result.summary),
        )

    def open(self) -> Recording:
        """The recording (:func:`rigtools.open_recording`); use it in a ``with`` block."""
        from rigtools.recording import open_recording

        return open_recording(self.file)

    def analyze(self, **options: Any) -> RecordingAnalysis:
        """:func:`rigtools.analyze` of the recording."""
        from rigtools.analyze import analyze_recording

        return analyze_recording(self.file, **options)

    def to_dict(self) -> dict[str, Any]:
        """Plain Python: the fields, each point by :meth:`PointResult.to_dict`."""
        return {
            "procedure": self.procedure,
            "status": self.status,
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


def _config(rig: Any) -> RigConfig:
    from rigtools.config import RigConfig, load_rig

    return rig if isinstance(rig, RigConfig) else load_rig(rig)


def _run(
    procedure: str,
    cls_name: str,
    params: dict[str, Any],
    out: str | Path,
    rig: Any,
    backend: str,
    overwrite: bool,
    progress: Callable[[ProgressEvent], None] | None,
    seed: int | None,
    **kwargs: Any,
) -> RunResult:
    from rigtools import procedures
    from rigtools.errors import UserError
    from rigtools.options import seed as seed_option

    if backend not in ("sim", "nidaq"):
        raise UserError(f"backend = {backend!r}: use 'sim' (the simulated rig) or 'nidaq' (the NI rig)")
    seed = seed_option(seed, "seed")
    cls = getattr(procedures, cls_name)
    params = {k: v for k, v in params.items() if v is not None}
    proc = cls(
        _config(rig),
        params,
        out,
        backend=backend,
        overwrite=overwrite,
        progress=progress,
        seed=seed,
        **kwargs,
    )
    return RunResult.from_procedure(procedure, proc.run(), out)


def dwell(
    fe: float | str,
    force: float | str,
    out: str | Path,
    *,
    gap: float | str | None = None,
    record_periods: int = 60,
    rig: Any = None,
    backend: str = "sim",
    overwrite: bool = False,
    progress: Callable[[ProgressEvent], None] | None = None,
    seed: int | None = None,
    **params: Any,
) -> RunResult:
    """Hold the force amplitude at one excitation frequency and record the settled response.

    Parameters
    ----------
    fe
        Excitation frequency: ``"60 Hz"`` or Hz.
    force
        Force amplitude F0 (fundamental of the force into the active blade): ``"15 N"`` or N.
    out
        Recording to write (HDF5).
    gap
        Shroud gap, ``"0.5 mm"`` or m; ``None``: as set (the rig file's on the simulated rig).
    record_periods
        Periods recorded once settled.
    rig
        A :class:`rigtools.config.RigConfig`, a rig file, or ``None`` for the calibrated default.
    backend
        ``"sim"`` (the simulated rig) or ``"nidaq"`` (the NI rig).
    overwrite
        Replace ``out`` if it exists.
    progress
        Called with each :class:`rigtools.procedures.ProgressEvent`.
    seed
        Noise seed of the simulated rig (``None``: 0, so that two runs record the same noise).
    **params
        More :class:`rigtools.procedures.DwellParameters` (``k_max``, ``control={...}``).

    Returns
    -------
    RunResult
        One point: the measured force, drive and harmonics, and the settled record window.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "dwell.h5"
    >>> run = rigtools.dwell("60 Hz", "5 N", out, gap="5 mm", record_periods=6, seed=1)
    >>> run.status, run.points[0].settled
    ('finished', True)
    >>> abs(run.points[0].force_amplitude_measured - 5.0) < 0.05  # force control within 1 %
    True
    """
    p = {"fe": fe, "force": force, "gap": gap, "record_periods": record_periods, **params}
    return _run("dwell", "SineDwell", p, out, rig, backend, overwrite, progress, seed)


def stepped_sine(
    frequencies: Sequence[float | str],
    force: float | str,
    out: str | Path,
    *,
    gap: float | str | None = None,
    direction: str = "up",
    record_periods: int = 30,
    rig: Any = None,
    backend: str = "sim",
    overwrite: bool = False,
    progress: Callable[[ProgressEvent], None] | None = None,
    seed: int | None = None,
    **params: Any,
) -> RunResult:
    """Step the excitation frequency at a held force amplitude; one point per step.

    Parameters
    ----------
    frequencies
        Step frequencies (``["62 Hz", "64 Hz"]`` or Hz), at least two.
    force
        Force amplitude F0 at every step: ``"15 N"`` or N.
    out
        Recording to write.
    gap
        Shroud gap, ``"0.7 mm"`` or m; ``None``: as set.
    direction
        ``"up"``, ``"down"`` or ``"both"`` (up, then down: hysteresis and jumps).
    record_periods
        Periods recorded at each step.
    rig, backend, overwrite, progress, seed
        As :func:`dwell`.
    **params
        More :class:`rigtools.procedures.SweepParameters` (``jump_threshold``, ``response``, ...).

    Returns
    -------
    RunResult
        One point per step; ``summary["jumps"]`` lists the jumps found.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "sweep.h5"
    >>> run = rigtools.stepped_sine(["55 Hz", "60 Hz"], "5 N", out, gap="5 mm", record_periods=5)
    >>> [p.fe for p in run.points]
    [55.0, 60.0]
    """
    p = {
        "frequencies": tuple(frequencies),
        "force": force,
        "gap": gap,
        "direction": direction,
        "record_periods": record_periods,
        **params,
    }
    return _run("stepped sine", "SteppedSine", p, out, rig, backend, overwrite, progress, seed)


def study(
    kind: str,
    values: Sequence[float | str],
    out: str | Path,
    *,
    fe: float | str | None = None,
    force: float | str | None = None,
    gap: float | str | None = None,
    direction: str = "up",
    record_periods: int = 30,
    resume: bool = False,
    rig: Any = None,
    backend: str = "sim",
    overwrite: bool = False,
    progress: Callable[[ProgressEvent], None] | None = None,
    seed: int | None = None,
    **params: Any,
) -> RunResult:
    """A force-controlled study over the gap, the force amplitude or the excitation frequency.

    Parameters
    ----------
    kind
        The swept parameter: ``"gap"``, ``"force"`` or ``"frequency"``.
    values
        The swept values, in the unit of ``kind`` (``["0.3 mm", "0.6 mm"]``, or SI floats).
    out
        Recording to write.
    fe, force, gap
        The parameters held fixed (the swept one is left ``None``).
    direction
        ``"up"``, ``"down"`` or ``"both"``.
    record_periods
        Periods recorded at each point.
    resume
        Continue an aborted study in ``out`` after its last complete point.
    rig, backend, overwrite, progress, seed
        As :func:`dwell`. On the NI rig a gap study asks the operator to set each gap.
    **params
        More :class:`rigtools.procedures.StudyParameters`.

    Returns
    -------
    RunResult
        One point per study value.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "study.h5"
    >>> run = rigtools.study("gap", ["4 mm", "5 mm"], out, fe="60 Hz", force="5 N", record_periods=5)
    >>> [round(p.gap * 1e3, 3) for p in run.points]
    [4.0, 5.0]
    """
    p = {
        "kind": kind,
        "values": tuple(values),
        "fe": fe,
        "force": force,
        "gap": gap,
        "direction": direction,
        "record_periods": record_periods,
        **params,
    }
    return _run("study", "RigStudy", p, out, rig, backend, overwrite, progress, seed, resume=resume)


def frf_test(
    band: tuple[float | str, float | str],
    level: float | str,
    out: str | Path,
    *,
    signal: str = "chirp",
    frame: float | str = 1.0,
    averages: int = 10,
    gap: float | str | None = None,
    rig: Any = None,
    backend: str = "sim",
    overwrite: bool = False,
    progress: Callable[[ProgressEvent], None] | None = None,
    seed: int | None = None,
    **params: Any,
) -> RunResult:
    """Broadband FRF test: periodic chirp or burst random over a band, averaged frames.

    Parameters
    ----------
    band
        ``(low, high)``: ``("20 Hz", "500 Hz")`` or Hz.
    level
        Drive level: the chirp's peak or the burst's rms within the burst, ``"1 V"`` or V.
    out
        Recording to write.
    signal
        ``"chirp"`` or ``"burst"``.
    frame
        Frame (period) length, ``"1 s"`` or s: the frequency resolution is 1/frame.
    averages
        Frames averaged.
    gap
        Shroud gap; open it (e.g. ``"5 mm"``) for the linear FRF.
    rig, backend, overwrite, progress, seed
        As :func:`dwell`.
    **params
        More :class:`rigtools.procedures.FrfParameters`.

    Returns
    -------
    RunResult
        One point holding the frames; :func:`rigtools.analyze` gives the FRF and modes.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "frf.h5"
    >>> run = rigtools.frf_test(("20 Hz", "500 Hz"), "1 V", out, frame="0.5 s", averages=2, gap="5 mm")
    >>> run.status, run.points[0].extra["signal"]
    ('finished', 'chirp')
    """
    p = {
        "band": tuple(band),
        "level": level,
        "signal": signal,
        "frame": frame,
        "averages": averages,
        "gap": gap,
    }
    return _run("frf test", "FrfTest", {**p, **params}, out, rig, backend, overwrite, progress, seed)


def tap_test(
    position: float | str,
    out: str | Path,
    *,
    blade: str = "passive",
    hits: int = 5,
    gap: float | str | None = None,
    rig: Any = None,
    backend: str = "sim",
    overwrite: bool = False,
    progress: Callable[[ProgressEvent], None] | None = None,
    seed: int | None = None,
    **params: Any,
) -> RunResult:
    """Impact-hammer test of one blade: triggered hits, one point each (the simulated rig's
    hammer hits by itself; on the NI rig the operator taps).

    Parameters
    ----------
    position
        Hit position from the blade root: ``"85 mm"`` or m.
    out
        Recording to write.
    blade
        ``"passive"`` or ``"active"``.
    hits
        Accepted hits (double hits and undecayed frames are refused and repeated).
    gap
        Shroud gap; open it for the blade alone.
    rig, backend, overwrite, progress, seed
        As :func:`dwell`.
    **params
        More :class:`rigtools.procedures.TapParameters` (``frame``, ``trigger``, ...).

    Returns
    -------
    RunResult
        One point per accepted hit; ``summary`` holds the modes identified.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "tap.h5"
    >>> run = rigtools.tap_test("85 mm", out, hits=2, gap="5 mm", seed=1)
    >>> run.status, len(run.points), run.summary["accepted"]
    ('finished', 2, 2)
    """
    p = {"position": position, "blade": blade, "hits": hits, "gap": gap, **params}
    return _run("tap test", "TapTest", p, out, rig, backend, overwrite, progress, seed)
