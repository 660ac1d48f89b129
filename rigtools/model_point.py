"""One point of the model from a lab script (:func:`rigtools.simulate_point`,
:class:`rigtools.SimulatedPoint`): the model driven by ``F0 sin(2 pi fe t)`` until settled, then
recorded; with the rig and run settings both model runs of the front door share
(:func:`model_system`, :func:`model_settings`; :func:`rigtools.simulate_study` is the other).

Takes quantity strings as the CLI does (``"60 Hz"``, ``"0.5 mm"``) or SI floats and refuses a bad
value with one :class:`rigtools.errors.UserError` line naming it; the run itself is
:mod:`rigtools.simulation`'s.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rigtools import simulation as simu
from rigtools.config import RigConfig, load_rig
from rigtools.errors import UserError
from rigtools.model_options import announce_model, announce_work, excitation, run_settings
from rigtools.options import HDF5_SUFFIXES, output_path
from rigtools.options import gap as gap_option
from rigtools.recording import RecordingWriter
from rigtools.sim.reduction import reduced_system

if TYPE_CHECKING:
    import pandas as pd


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


def model_settings(duration: float | str, max_settle_time: float | str, fe_values: Sequence[float]) -> Any:
    """The run settings of :func:`simulate_point` and :func:`rigtools.simulate_study` (keyword
    names in the refusals, as the front door spells them)."""
    return run_settings(
        duration, max_settle_time, None, fe_values, names=("duration", "max_settle_time", "steps_per_period")
    )


def model_system(rig: Any, model: str, gap: float | str | None) -> tuple[RigConfig, Any]:
    """``(rig config, reduced system)``; a model too large for the memory is refused in one line."""
    if model not in ("fem", "am"):
        raise UserError(f"model = {model!r}: use 'fem' (finite elements) or 'am' (analytical model)")
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
    f, F = excitation(fe, force, names=("fe", "force"))
    settings = model_settings(duration, max_settle_time, [f])
    cfg, system = model_system(rig, model, gap)
    announce_work(system, [(f, F)], settings, quiet=True, names=("fe", "duration"))
    target = None
    if out is not None:
        target = output_path(str(out), overwrite, "out", suffixes=HDF5_SUFFIXES)
    run = simu.simulate_point(system, f, F, settings)
    if target is not None:
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
