"""A whole recording analysed (:func:`analyze_recording`, the front door's
:func:`rigtools.analyze_recording`): every point sent to the analysis of its kind (periodic,
broadband, without a force, a tap test's hits together, an FRF set's stored FRFs), and the FEM's
natural frequencies beside the identified ones."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from rigtools.errors import UserError, in_script_words
from rigtools.frf_set import is_frf_set
from rigtools.operational import analyze_operational
from rigtools.options import quantity
from rigtools.recording import RecordingError, open_recording
from rigtools.recording.schema import SINE_PROCEDURES
from rigtools.recording_analysis.broadband import PROCEDURE_FRF, analyze_broadband
from rigtools.recording_analysis.fem_frequencies import frequency_table
from rigtools.recording_analysis.frf_estimate import FRFOptions
from rigtools.recording_analysis.imported_frfs import analyze_frf_set
from rigtools.recording_analysis.periodic import analyze_periodic
from rigtools.recording_analysis.results import PointAnalysis, RecordingAnalysis, frf_kind
from rigtools.recording_analysis.samples import force_channel
from rigtools.recording_analysis.tap_test import analyze_tap_test, is_hit_per_point_tap_test
from rigtools.sim.channel_names import FORCE
from rigtools.vocabulary import excitation_frequency, source_of

METHODS = ("lscf", "peak")
FOREIGN_PROCEDURES = ("import",)


def is_foreign(experiment: dict) -> bool:
    """True for a recording written elsewhere and imported (``rig import``): it does not describe
    this rig, so it is compared with the rig's FEM only when asked."""
    return str((experiment or {}).get("procedure", "")) in FOREIGN_PROCEDURES


@in_script_words
def analyze_recording(
    path: str | Path,
    *,
    kind: str = "accelerance",
    method: str = "lscf",
    channels: Sequence[str] | None = None,
    progress: Callable[[int, int], None] | None = None,
    options: FRFOptions | None = None,
    fe: float | None = None,
    compare_fem: bool | None = None,
    skip_damaged: bool | None = None,
) -> RecordingAnalysis:
    """Analyse every complete point of a recording (see :mod:`rigtools.recording_analysis`).

    Parameters
    ----------
    path
        The recording (HDF5, schema v1).
    kind
        FRF kind of the results: ``"accelerance"``, ``"mobility"`` or ``"receptance"``.
    method
        Modal identification of broadband points: ``"lscf"`` or ``"peak"``.
    channels
        Only these channels (the force is always kept); unknown names are a :class:`UserError`.
    progress
        ``progress(done, total)`` after each point.
    options
        Band and FRF-estimate overrides of broadband points (:class:`~rigtools.recording_analysis.frf_estimate.FRFOptions`).
    fe
        Excitation frequency whose harmonics are marked in the spectra of a point without a
        force channel (an operational recording).
    compare_fem
        Add the table of this rig's FEM/AM natural frequencies beside the identified ones;
        default: yes for the rig's own recordings, no for imported ones (they do not describe
        this rig).
    skip_damaged
        Read a recording ``rig check`` rejects, leaving its damaged points and channels out
        (one note each); by default such a file is refused in one line.

    Returns
    -------
    RecordingAnalysis
        ``points`` (:class:`~rigtools.recording_analysis.results.PointAnalysis`: harmonics of periodic points, FRFs and modes of
        broadband ones), ``notes``, ``skipped``, ``to_dict()``.

    Raises
    ------
    UserError
        One line: unreadable file, unknown channel, a point that cannot be analysed.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "frf.h5"
    >>> run = rigtools.frf_test(("20 Hz", "500 Hz"), "1 V", out, frame="0.5 s", averages=2, gap="5 mm", backend="sim")
    >>> run.status
    'finished'
    >>> analysis = rigtools.analyze_recording(run.file)
    >>> point = analysis.points[0]
    >>> point.kind, point.frf.responses[0]
    ('broadband', 'active_shroud_accel')
    """
    checked_kind = frf_kind(kind)
    if fe is not None:
        fe = quantity(fe, "frequency", "fe")
        if not fe > 0:
            raise UserError(f"fe = {fe!r}: the excitation frequency must be > 0 Hz")
    if method not in METHODS:
        raise UserError(f"--method {method!r}: use one of {', '.join(METHODS)}")
    if Path(path).is_file() and is_frf_set(path):
        return analyze_frf_set(path, kind=kind, method=method, channels=channels, options=options)
    options = options or FRFOptions()
    try:
        rec = open_recording(path, skip_damaged=skip_damaged)
    except RecordingError as exc:
        raise UserError(str(exc)) from None
    with rec:
        experiment = rec.experiment
        procedure = str(experiment.get("procedure", ""))
        out = RecordingAnalysis(
            str(path), procedure, rec.backend, source_of(rec.backend), rec.status, checked_kind, []
        )
        out.notes.extend(rec.notes)
        if rec.incomplete:
            out.notes.append(
                f"recording status {rec.status}"
                + (f" ({rec.abort_reason})" if rec.abort_reason else "")
                + ": only points its writer ended are analysed"
            )
        points = rec.points
        _check_channels(path, points, channels)
        try:
            _analyze_points(
                out, points, experiment, kind, method, channels, options, fe=fe, progress=progress
            )
        except RecordingError as exc:
            raise UserError(str(exc)) from None
    _refuse_unused_options(out, path, options)
    foreign = is_foreign(experiment)
    if compare_fem is None:
        compare_fem = not foreign
    if out.broadband and compare_fem:
        out.frequency_table = frequency_table(out, path)
    elif out.broadband and foreign:
        out.notes.append("imported recording: not compared with this rig's FEM (ask with --compare-fem)")
    if not out.points and not out.skipped:
        out.notes.append("the recording holds no points")
    return out


def _check_channels(path: str | Path, points, channels: Sequence[str] | None) -> None:
    """A :class:`UserError` naming the channels asked for that no point of the recording has."""
    if not channels:
        return
    known = set().union(*(p.channels for p in points)) if points else set()
    unknown = [c for c in channels if c not in known]
    if unknown:
        raise UserError(f"{path}: no channel {', '.join(unknown)} (channels: {', '.join(sorted(known))})")


def _analyze_points(
    out: RecordingAnalysis,
    points,
    experiment: dict,
    kind: str,
    method: str,
    channels: Sequence[str] | None,
    options: FRFOptions,
    *,
    fe: float | None,
    progress: Callable[[int, int], None] | None,
) -> None:
    """Every point analysed into ``out.points`` or named in ``out.skipped`` with the reason; a tap
    test's hits (one point each) together as one point."""
    procedure = out.procedure
    if is_hit_per_point_tap_test(procedure, points):
        options.refuse_unused("a tap test's FRF is one recorded frame per accepted hit", band=False)
        out.points.append(analyze_tap_test(points, experiment, kind=kind, method=method, band=options.band))
        points = []
    for i, point in enumerate(points):
        why_not = _skip_reason(point, procedure)
        if why_not is not None:
            out.skipped.append(f"point {point.index}: {why_not}")
        else:
            out.points.append(_analyze_point(point, procedure, kind, method, channels, options, fe))
        if progress is not None:
            progress(i + 1, len(points))


def _skip_reason(point, procedure: str) -> str | None:
    """Why a point cannot be analysed, None when it can."""
    if not point.complete:
        return "not ended by its writer (cut off)"
    if point.n_samples == 0:
        return "no samples"
    if point.sample_rate is None:
        return "channels at different sample rates"
    if procedure in SINE_PROCEDURES and "fe" not in point.params:
        return "a sine point without fe (its excitation frequency)"
    if _no_frequency_no_frames(point, procedure):
        return (
            "fe = 0 (no single excitation frequency) and no frames: neither a periodic nor a broadband point"
        )
    return None


def _no_frequency_no_frames(point, procedure: str) -> bool:
    """A point with ``fe = 0`` (no single excitation frequency) in a recording not of an FRF test
    and without frames: there is no frequency to analyse it at, and a sine record is no
    broadband test."""
    return (
        "fe" in point.params
        and excitation_frequency(point.params) is None
        and "frame_samples" not in point.params
        and procedure not in PROCEDURE_FRF
    )


def _analyze_point(
    point,
    procedure: str,
    kind: str,
    method: str,
    channels: Sequence[str] | None,
    options: FRFOptions,
    fe: float | None,
) -> PointAnalysis:
    """One point by its kind: periodic (it has ``fe``, not in an FRF test), without a force
    (operational), else broadband."""
    if excitation_frequency(point.params) and procedure not in PROCEDURE_FRF:
        names = None
        if channels:
            names = list(dict.fromkeys([FORCE, *channels])) if FORCE in point.channels else list(channels)
        return analyze_periodic(point, channels=names)
    force = force_channel(point)
    if force is None:
        return analyze_operational(point, fe=fe, channels=channels, band=options.band)
    responses = [c for c in channels if c != force] if channels else None
    return analyze_broadband(point, procedure, kind=kind, method=method, responses=responses, options=options)


def _refuse_unused_options(out: RecordingAnalysis, path: str | Path, options: FRFOptions) -> None:
    """FRF options on a recording without a broadband point are refused in one line (``--band``
    also sets the band of the modes of points without a force)."""
    if out.broadband:
        return
    options.refuse_unused(
        f"{path} holds no broadband point (FRF, tap or impact test)", band=not out.operational
    )
    if options.band and all(p.oma is None for p in out.operational):
        why = next((n for n in out.operational[0].notes if n.startswith(("no modes", "no motion"))), "")
        raise UserError(f"--band: no point of {path} could be identified in it ({why})")
