"""A study of the model from a lab script (:func:`rigtools.simulate_study`, as ``rig study``):
the gap, the force amplitude or the excitation frequency swept, each point written to the
recording as soon as it settles.

The swept values are read as the rig's study reads them
(:class:`rigtools.procedures.rig_study.StudyParameters`); the plan is
:class:`rigtools.sim.studies.StudyPlan`, the recording :func:`rigtools.model_study.record_study`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from rigtools.errors import UserError
from rigtools.model_options import announce_work
from rigtools.model_point import model_settings, model_system
from rigtools.model_study import record_study
from rigtools.options import HDF5_SUFFIXES, output_path, quantity, switch
from rigtools.options import gap as gap_option
from rigtools.procedures.base import validate
from rigtools.procedures.rig_study import StudyParameters
from rigtools.sim.studies import StudyPlan
from rigtools.sim.vibro_impact import SimulationInputError


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
        As :func:`rigtools.simulate_point`.
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
    settings = model_settings(duration, max_settle_time, sorted({p.fe for p in plan.points()}))
    cfg, system = model_system(rig, model, None)

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
