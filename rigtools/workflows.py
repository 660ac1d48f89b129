"""The offline steps of a lab script: spectra of a recorded point, model runs (a point, a study),
the comparison of a recording with the model, and model updating.

Each function takes quantity strings as the CLI does (``"60 Hz"``, ``"0.5 mm"``) or SI floats,
refuses a bad value with one :class:`rigtools.errors.UserError` line naming it, and returns a
typed result; the work itself is done by the library (:mod:`rigtools.simulation`,
:mod:`rigtools.recording_comparison`, :mod:`rigtools.model_update`, :mod:`rigtools.analysis`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rigtools.errors import UserError
from rigtools.model_options import announce_model, announce_work, excitation, run_settings
from rigtools.model_study import record_study
from rigtools.model_update import DEFAULT_PARAMETERS, update_rig_file
from rigtools.options import HDF5_SUFFIXES, band_option, duration, output_path, quantity, switch
from rigtools.options import gap as gap_option
from rigtools.recording import reading_damaged

if TYPE_CHECKING:
    import pandas as pd

    from rigtools.model_update import UpdateOutcome
    from rigtools.recording.reader import Point
    from rigtools.recording_comparison import Comparison


@dataclass(frozen=True)
class Spectrum:
    """Amplitude spectrum of one channel over a point's settled record window.

    Attributes
    ----------
    channel
        The channel's vocabulary name (``"active_shroud_accel"``).
    units
        SI unit of the channel (``"m/s^2"``); the amplitudes are in it.
    frequency_hz
        Bin frequencies, Hz.
    amplitude
        Amplitude per bin (peak, or rms with ``amplitude="rms"``), in ``units``.
    amplitude_kind
        ``"peak"`` or ``"rms"``.
    window
        The window used (``"flattop"``: amplitude-accurate between bins).

    Examples
    --------
    >>> import numpy as np
    >>> from rigtools.workflows import Spectrum
    >>> s = Spectrum("force", "N", np.array([0.0, 60.0, 120.0]), np.array([0.0, 15.0, 0.1]))
    >>> s.at(60.0), s.to_dataframe().shape
    (15.0, (3, 2))
    """

    channel: str
    units: str
    frequency_hz: np.ndarray = field(repr=False)
    amplitude: np.ndarray = field(repr=False)
    amplitude_kind: str = "peak"
    window: str = "flattop"

    def at(self, frequency_hz: float) -> float:
        """Largest amplitude within two bins of ``frequency_hz`` (a flat-top peak spans bins).

        A frequency outside the spectrum (NaN, negative, above its last bin: the Nyquist
        frequency) is a :class:`rigtools.errors.UserError` naming it.
        """
        top = float(self.frequency_hz[-1]) if len(self.frequency_hz) else 0.0
        if not (isinstance(frequency_hz, int | float) and 0.0 <= frequency_hz <= top):
            raise UserError(
                f"frequency_hz = {frequency_hz!r}: not in this spectrum (0 to {top:g} Hz, its last bin)"
            )
        i = int(np.argmin(np.abs(self.frequency_hz - frequency_hz)))
        return float(np.max(self.amplitude[max(0, i - 2) : i + 3]))

    def to_dataframe(self) -> pd.DataFrame:
        """Columns ``frequency_hz`` and ``amplitude`` (in :attr:`units`)."""
        import pandas as pd

        return pd.DataFrame({"frequency_hz": self.frequency_hz, "amplitude": self.amplitude})


def spectrum(point: Point, channel: str, *, window: str = "flattop", amplitude: str = "peak") -> Spectrum:
    """Amplitude spectrum of ``channel`` over the point's settled record window.

    Parameters
    ----------
    point
        A recorded point (``rigtools.open_recording(path).points[i]``).
    channel
        Channel name, e.g. ``"force"`` or ``"active_shroud_accel"``.
    window
        ``"flattop"``, ``"hann"`` or ``"boxcar"`` (:func:`rigtools.analysis.spectra.amplitude_spectrum`).
    amplitude
        ``"peak"`` or ``"rms"``.

    Returns
    -------
    Spectrum

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "dwell.h5"
    >>> run = rigtools.dwell("60 Hz", "5 N", out, gap="5 mm", record_periods=6, backend="sim", seed=1)
    >>> with rigtools.open_recording(run.file) as rec:
    ...     s = rigtools.spectrum(rec.points[0], "force")
    >>> s.units, round(s.at(60.0), 1)  # the force fundamental, N peak
    ('N', 5.0)
    """
    from rigtools.analysis.spectra import amplitude_spectrum

    if not hasattr(point, "channels") or not hasattr(point, "settled"):
        raise UserError(f"point = {point!r}: give a recorded point (rigtools.open_recording(path).points[i])")
    if channel not in point.channels:
        raise UserError(
            f"channel = {channel!r}: not in point {point.index} (channels: {', '.join(point.channels)})"
        )
    rate = point.sample_rate
    if rate is None:
        raise UserError(f"point {point.index}: channels at different sample rates")
    try:
        f, a = amplitude_spectrum(point.settled(channel), rate, window=window, amplitude=amplitude)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    return Spectrum(channel, point.channels[channel].units, f, a, amplitude, window)


@dataclass(frozen=True)
class SimulatedPoint:
    """One settled run of the model under ``F0 sin(2 pi fe t)`` (SI units).

    Attributes
    ----------
    fe
        Excitation frequency, Hz.
    force
        Force amplitude F0, N.
    gap
        Shroud gap, m.
    model
        ``"fem"`` or ``"am"`` (analytical model).
    settled
        The run reached its periodic steady state before the record.
    sample_rate
        Samples per second of the record, Hz.
    time
        Time of each recorded sample, s.
    channels
        ``{channel: samples}`` by vocabulary name (``force`` N, ``active_shroud_accel`` m/s^2,
        ``contact_force`` N, ...), the settled record only.
    harmonics
        ``{channel: peak amplitudes of k = 1..30}`` of ``force``, both shroud accelerations and
        the contact force.
    impacts_per_period
        Shroud impacts per excitation period.
    peak_contact_force
        Largest contact force, N.

    Examples
    --------
    >>> import rigtools
    >>> run = rigtools.simulate_point("60 Hz", "5 N", gap="5 mm", duration="0.1 s")
    >>> frame = run.to_dataframe()  # index time (s), one column per channel (SI)
    >>> "active_shroud_accel" in frame.columns, len(frame) == run.time.size
    (True, True)
    """

    fe: float
    force: float
    gap: float
    model: str
    settled: bool
    sample_rate: float
    time: np.ndarray = field(repr=False)
    channels: Mapping[str, np.ndarray] = field(repr=False)
    harmonics: Mapping[str, np.ndarray] = field(repr=False)
    impacts_per_period: float = 0.0
    peak_contact_force: float = 0.0

    def to_dataframe(self) -> pd.DataFrame:
        """The record: index ``time`` (s), one column per channel."""
        import pandas as pd

        return pd.DataFrame(dict(self.channels), index=pd.Index(self.time, name="time"))

    def to_dict(self) -> dict[str, Any]:
        """The scalars and the harmonics (lists), JSON-ready."""
        return {
            "fe": self.fe,
            "force": self.force,
            "gap": self.gap,
            "model": self.model,
            "settled": self.settled,
            "sample_rate": self.sample_rate,
            "impacts_per_period": self.impacts_per_period,
            "peak_contact_force": self.peak_contact_force,
            "harmonics": {k: [float(a) for a in v] for k, v in self.harmonics.items()},
        }


def _settings(duration: float | str, max_settle_time: float | str, fe_values: Sequence[float]):
    return run_settings(
        duration, max_settle_time, None, fe_values, names=("duration", "max_settle_time", "steps_per_period")
    )


def _system(rig: Any, model: str, gap: float | str | None):
    """``(rig config, reduced system)``; a model too large for the memory is refused in one line."""
    from rigtools.config import RigConfig, load_rig

    if model not in ("fem", "am"):
        raise UserError(f"model = {model!r}: use 'fem' (finite elements) or 'am' (analytical model)")
    from rigtools.sim.reduction import reduced_system

    cfg = rig if isinstance(rig, RigConfig) else load_rig(rig)
    params = cfg.to_params()
    announce_model(params, model, quiet=True)
    system = reduced_system(params, model)
    if gap is not None:
        system = system.with_contact(gap=gap_option(gap, "gap"))
    return cfg, system


def simulate_point(
    fe: float | str,
    force: float | str,
    *,
    gap: float | str | None = None,
    rig: Any = None,
    model: str = "fem",
    duration: float | str = "0.2 s",
    max_settle_time: float | str = "30 s",
    out: str | Path | None = None,
    overwrite: bool = False,
) -> SimulatedPoint:
    """Simulate one point: the model driven by ``F0 sin(2 pi fe t)`` until settled, then recorded.

    Parameters
    ----------
    fe
        Excitation frequency, ``"60 Hz"`` or Hz.
    force
        Force amplitude F0, ``"15 N"`` or N.
    gap
        Shroud gap, ``"0.5 mm"`` or m; ``None``: the rig file's.
    rig
        A :class:`rigtools.config.RigConfig`, a rig file, or ``None`` (the calibrated default).
    model
        ``"fem"`` (finite elements) or ``"am"`` (the analytical model).
    duration
        Recorded time after settling, ``"0.2 s"`` or s (whole periods, at least one).
    max_settle_time
        Simulated time after which settling gives up (``settled`` is then False).
    out
        Also write the run as a one-point recording (as ``rig simulate``); ``None``: don't.
    overwrite
        Replace ``out`` if it exists.

    Returns
    -------
    SimulatedPoint

    Examples
    --------
    >>> import rigtools
    >>> run = rigtools.simulate_point("60 Hz", "5 N", gap="5 mm", duration="0.1 s")
    >>> run.settled, run.gap
    (True, 0.005)
    >>> round(float(run.harmonics["force"][0]), 3)  # the applied force fundamental, N peak
    5.0
    """
    from rigtools import simulation as simu

    f, F = excitation(fe, force, names=("fe", "force"))
    settings = _settings(duration, max_settle_time, [f])
    cfg, system = _system(rig, model, gap)
    announce_work(system, [(f, F)], settings, quiet=True, names=("fe", "duration"))
    target = None
    if out is not None:
        target = output_path(str(out), overwrite, "out", suffixes=HDF5_SUFFIXES)
    run = simu.simulate_point(system, f, F, settings)
    if target is not None:
        from rigtools.recording import RecordingWriter

        experiment = {"procedure": "simulate", "model": model, "cli": "rigtools.simulate_point"}
        with RecordingWriter(
            target, backend="fem", rig=cfg.to_json(), experiment=experiment, overwrite=overwrite
        ) as rec:
            simu.write_point(rec, run, model)
    harmonics = {
        name: np.array([h["amplitude"] for h in rows]) for name, rows in simu.harmonics_of(run).items()
    }
    return SimulatedPoint(
        fe=float(run.fe),
        force=float(run.force_amplitude),
        gap=float(run.gap),
        model=model,
        settled=bool(run.steady_state),
        sample_rate=float(run.sample_rate),
        time=np.asarray(run.time),
        channels={name: np.asarray(run.outputs[src]) for name, src in simu.MODEL_OUTPUTS.items()},
        harmonics=harmonics,
        impacts_per_period=float(run.impacts_per_period),
        peak_contact_force=float(run.peak_contact_force),
    )


def simulate_study(
    kind: str,
    values: Sequence[float | str] | str,
    out: str | Path,
    *,
    fe: float | str | None = None,
    force: float | str | None = None,
    gap: float | str | None = None,
    direction: str = "up",
    carry_state: bool = True,
    rig: Any = None,
    model: str = "fem",
    duration: float | str = "0.2 s",
    max_settle_time: float | str = "30 s",
    overwrite: bool = False,
    on_point: Callable[[object, dict], None] | None = None,
) -> list[dict[str, Any]]:
    """Simulate a study over the gap, the force amplitude or the excitation frequency, each point
    written to the recording ``out`` as soon as it settles (as ``rig study``).

    Parameters
    ----------
    kind
        ``"gap"``, ``"force"`` or ``"frequency"``.
    values
        The swept values in the unit of ``kind``: ``["0.3 mm", "0.6 mm"]``, SI floats, or the
        CLI's ``"0.3 mm:0.9 mm:0.3 mm"`` (start:stop:step) or ``"0.3 mm,0.6 mm"``.
    out
        Recording to write (backend ``fem``); if the study stops early it keeps every finished
        point (status ``aborted``).
    fe, force, gap
        The parameters held fixed.
    direction
        ``"up"``, ``"down"`` or ``"both"``.
    carry_state
        Start each point from the previous one's settled state (follows a branch, as a rig does).
    rig, model, duration, max_settle_time, overwrite
        As :func:`simulate_point`.
    on_point
        ``on_point(planned, summary)`` after each point is on disk.

    Returns
    -------
    list of dict
        Per point: ``value``, ``direction``, ``fe`` (Hz), ``force_amplitude`` (N), ``gap`` (m),
        ``steady_state``, ``impacts_per_period``, ``harmonics`` (peak amplitudes by channel).
        Read the samples back with :func:`rigtools.open_recording`.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "study.h5"
    >>> points = rigtools.simulate_study("force", ["2 N", "4 N"], out, fe="60 Hz", gap="5 mm", duration="0.1 s")
    >>> [p["value"] for p in points]
    [2.0, 4.0]
    >>> with rigtools.open_recording(out) as rec:
    ...     rec.status, len(rec.points)
    ('complete', 2)
    """
    from rigtools.procedures.base import validate
    from rigtools.procedures.rig_study import StudyParameters
    from rigtools.sim.studies import StudyPlan
    from rigtools.sim.vibro_impact import SimulationInputError

    given = values if isinstance(values, str) else tuple(values)  # "0.3 mm:0.9 mm:0.3 mm" as the CLI
    swept = validate(StudyParameters, kind=kind, values=given, direction=direction).values
    fixed: dict[str, float] = {}
    if fe is not None:
        fixed["fe"] = quantity(fe, "frequency", "fe")
    if force is not None:
        fixed["force"] = quantity(force, "force", "force")
    if gap is not None:
        fixed["gap"] = gap_option(gap, "gap")
    try:
        plan = StudyPlan(
            kind, tuple(swept), direction, carry_state=switch(carry_state, "carry_state"), **fixed
        )
    except SimulationInputError as exc:
        raise UserError(str(exc)) from None
    target = output_path(str(out), overwrite, "out", suffixes=HDF5_SUFFIXES)
    settings = _settings(duration, max_settle_time, sorted({p.fe for p in plan.points()}))
    cfg, system = _system(rig, model, None)

    announce_work(
        system, [(p.fe, p.force) for p in plan.points()], settings, quiet=True, names=("fe", "duration")
    )
    experiment = {
        "procedure": f"{kind} study",
        "model": model,
        "direction": direction,
        "carry_state": carry_state,
        "fixed": plan.fixed,
        "values": list(swept),
        "plan": plan.to_dict(),
        "cli": "rigtools.simulate_study",
    }
    return record_study(
        target,
        plan,
        cfg,
        system,
        settings,
        experiment=experiment,
        model=model,
        overwrite=overwrite,
        on_point=on_point,
    )


def compare_with_model(
    em: str | Path,
    model_recording: str | Path | None = None,
    *,
    model: str = "fem",
    excitation: str = "measured",
    rig: str | Path | None = None,
    frf: str | Path | None = None,
    k_max: int = 30,
    workers: int | None = None,
    max_settle_time: float | str = "30 s",
    progress: Callable[[int, int, str], None] | None = None,
    skip_damaged: bool = False,
) -> Comparison:
    """Compare an EM recording with the model: harmonics, waveforms, agreement per point.

    Parameters
    ----------
    em
        The EM recording (a dwell, stepped sine or study on the rig or the simulated rig).
    model_recording
        A model recording to pair with (``rigtools.simulate_study``, ``rig simulate``/``study``);
        ``None``: run the model at every EM point (fe, gap and the force felt there).
    model
        ``"fem"`` or ``"am"``: the model run (with ``model_recording=None``).
    excitation
        ``"measured"`` (the EM force's harmonics drive the model) or ``"nominal"`` (``F0 sin``).
    rig
        Rig file of the model; default: the rig description stored in the EM recording.
    frf
        An FRF test recording whose modes fill the EM column of the natural-frequency table.
    k_max
        Harmonics compared, k = 1..k_max.
    workers
        Model runs on a Dask LocalCluster of this many workers (default: in-process).
    max_settle_time
        Longest simulated settling per model run, ``"30 s"`` or s.
    progress
        ``progress(done, total, text)`` as model runs finish.
    skip_damaged
        Read recordings ``rig check`` rejects, leaving their damaged points and channels out
        (one note each); by default such a file is refused in one line.

    Returns
    -------
    rigtools.recording_comparison.Comparison
        ``points`` (per point: EM and model harmonics, ``score``), ``mean_score``, ``to_dict()``.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "dwell.h5"
    >>> run = rigtools.dwell("60 Hz", "5 N", out, gap="5 mm", record_periods=6, backend="sim", seed=1)
    >>> cmp = rigtools.compare_with_model(run.file)
    >>> t = cmp.points[0].table  # one row per channel and harmonic k, peak amplitudes in SI
    >>> f1 = t[(t.channel == "force") & (t.k == 1)].iloc[0]
    >>> bool(round(f1.em, 3) == round(f1.fem, 3))  # the model is driven by the measured force
    True
    >>> a1 = t[(t.channel == "active_shroud_accel") & (t.k == 1)].iloc[0]
    >>> bool(0.8 < a1.fem / a1.em < 1.25)  # the active shroud's fundamental agrees within 25 %
    True
    """
    from rigtools.recording_comparison import compare_recordings

    if isinstance(k_max, bool) or not isinstance(k_max, int) or k_max < 1:
        raise UserError(f"k_max = {k_max!r}: the harmonics compared are k = 1..k_max, a whole number >= 1")
    with reading_damaged(switch(skip_damaged, "skip_damaged")):
        return compare_recordings(
            str(em),
            None if model_recording is None else str(model_recording),
            simulate=model_recording is None,
            model=model,
            excitation=excitation,
            rig=None if rig is None else str(rig),
            frf=None if frf is None else str(frf),
            k_max=k_max,
            workers=workers,
            max_settle_time=duration(max_settle_time, "max_settle_time"),
            progress=progress,
        )


def update_model(
    recordings: str | Path | Sequence[str | Path],
    out: str | Path,
    *,
    rig: str | Path | None = None,
    parameters: str | Sequence[str] | None = None,
    modes: int = 3,
    band: tuple[float | str, float | str] | str | None = None,
    damping: bool = True,
    contact: Sequence[str | Path] = (),
    law: str = "rig",
    overwrite: bool = False,
) -> UpdateOutcome:
    """Fit the rig file's model to test recordings and write the updated rig file (``rig update``).

    Parameters
    ----------
    recordings
        FRF tests and tap tests: the modes identified in them are the targets.
    out
        The updated rig file to write (``.toml``).
    rig
        Rig file to update; ``None``: the calibrated default rig.
    parameters
        Rig-file keys fitted (:data:`rigtools.model_update.PARAMETER_NAMES`); ``None``: the default set.
    modes
        Flexural modes per blade used as targets, lowest first.
    band
        ``(low, high)`` searched for modes, e.g. ``("20 Hz", "2 kHz")`` or the CLI's
        ``"20 Hz:2 kHz"``; ``None``: each test's band.
    damping
        Fit the identified damping ratios too.
    contact
        Force-controlled dwells with impacts: fit the contact stiffness and damping to them.
    law
        Contact law fitted: ``"rig"``, ``"linear"``, ``"hertz"`` or ``"compare"``.
    overwrite
        Replace ``out`` if it exists.

    Returns
    -------
    rigtools.model_update.UpdateOutcome
        ``out`` (the file written), ``paired`` (targets with the nominal model's modes), ``fit``.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> tap = rigtools.tap_test("85 mm", folder / "tap.h5", hits=2, gap="5 mm", backend="sim", seed=1)
    >>> done = rigtools.update_model([tap.file], folder / "updated.toml", modes=2)
    >>> done.out.name, rigtools.load_rig(done.out).name != ""
    ('updated.toml', True)
    """
    files = [recordings] if isinstance(recordings, str | Path) else list(recordings)
    if not files:
        raise UserError("recordings = []: give at least one test recording (an FRF test or a dwell)")
    span = None
    if isinstance(band, str):
        span = band_option(band, "band")
    elif band is not None:
        span = (quantity(band[0], "frequency", "band"), quantity(band[1], "frequency", "band"))
    return update_rig_file(
        files,
        out,
        rig=rig,
        parameters=DEFAULT_PARAMETERS if parameters is None else parameters,
        modes=modes,
        band=span,
        damping=switch(damping, "damping"),
        contact=contact,
        law=law,
        overwrite=overwrite,
    )
