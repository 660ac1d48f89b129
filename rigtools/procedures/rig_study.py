"""A gap, force or frequency study on the rig (:class:`RigStudy`), force-controlled at every point,
in the model study's plan (:class:`rigtools.sim.studies.StudyPlan`); ``resume`` continues an
interrupted one."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from rigtools.errors import UserError
from rigtools.options import value_list
from rigtools.procedures.base import validate
from rigtools.procedures.session import SineSession, point_attrs
from rigtools.procedures.sine import ControlParameters, SineProcedure, target_not_reached
from rigtools.quantity_fields import Force, Frequency, Length
from rigtools.recording import RecordingWriter, open_recording
from rigtools.recording.lock import LockBusy, WriterLock
from rigtools.sim.studies import StudyPlan
from rigtools.sim.vibro_impact import SimulationInputError
from rigtools.units import MAX_GAP, parse_quantity


class StudyParameters(BaseModel):
    """A rig study over gap, F0 or fe, in the model study's plan (:class:`rigtools.sim.studies.StudyPlan`)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    kind: Literal["gap", "force", "frequency"] = Field(description="the swept parameter")
    values: tuple[float, ...] = Field(
        min_length=1, description="swept values: m (gap), N (force) or Hz (frequency), or quantity strings"
    )
    direction: Literal["up", "down", "both"] = "up"
    fe: Frequency | None = Field(
        None, gt=0, le=25000, description="excitation frequency, Hz (fixed unless swept)"
    )
    force: Force | None = Field(None, gt=0, le=1000, description="force amplitude F0, N (fixed unless swept)")
    gap: Length | None = Field(None, ge=0, le=MAX_GAP, description="shroud gap, m (fixed unless swept)")
    record_periods: int = Field(30, ge=1, le=1_000_000, description="periods recorded at each point")
    k_max: int = Field(10, ge=1, le=100, description="highest harmonic k of fe analysed")
    control: ControlParameters = ControlParameters()

    @model_validator(mode="before")
    @classmethod
    def _values_in_si(cls, data: Any) -> Any:
        # the unit of the swept values follows the kind: "0.3 mm" for a gap study, "60 Hz" ...
        dimension = {"gap": "length", "force": "force", "frequency": "frequency"}
        if isinstance(data, dict) and data.get("kind") in dimension and "values" in data:
            values = data["values"]
            if isinstance(values, str):  # the CLI's "0.3 mm:0.9 mm:0.3 mm" or "a,b,c", its one parser
                values = value_list(values, data["kind"], "values")
            if isinstance(values, (int, float)):
                values = [values]
            try:
                data = {**data, "values": tuple(parse_quantity(v, dimension[data["kind"]]) for v in values)}
            except (ValueError, TypeError) as exc:
                raise ValueError(f"values: {exc}") from None
        return data

    def plan(self):
        try:
            return StudyPlan(
                self.kind,
                self.values,
                self.direction,
                fe=self.fe,
                force=self.force,
                gap=self.gap,
                carry_state=True,
            )
        except SimulationInputError as exc:
            raise UserError(str(exc)) from None


def complete_points(path: Path) -> int:
    """Leading points of a recording that ended complete (end_time set, point_complete)."""
    n = 0
    try:
        with open_recording(path) as rec:
            for point in rec:
                if not point.end_time or not bool(point.params.get("point_complete", False)):
                    break
                n += 1
    except Exception:  # noqa: BLE001 - an unreadable file has no complete point
        return 0
    return n


class RigStudy(SineProcedure):
    """Gap, force or frequency study on the rig, force-controlled at every point.

    On the simulated rig the gap is set directly; on the real rig ``confirm_gap(gap, index)``
    is called (the CLI prompts the operator and waits; ``--yes`` skips the prompt) with the
    drive ramped to zero, and the gap each point ran at is stored. ``resume=True`` continues an
    interrupted study in ``out``: its complete points are kept (copied into the new file in
    order), the incomplete one is dropped and the study goes on from the next planned point.
    """

    name = "rig study"

    def __init__(self, cfg, params: StudyParameters | dict, out, *, resume: bool = False, **kwargs) -> None:
        super().__init__(cfg, out, **kwargs)
        self.params = params if isinstance(params, StudyParameters) else validate(StudyParameters, **params)
        self.plan = self.params.plan()
        self.points_planned = self.plan.points()
        self.resume = resume
        self.start_index = 0
        self._source: Path | None = None

    def first_frequency(self) -> float:
        return self.points_planned[0].fe

    def record_seconds(self) -> float:
        return self.params.record_periods / min(p.fe for p in self.points_planned)

    def parameters_doc(self) -> dict:
        return {**self.params.model_dump(), "plan": self.plan.to_dict()}

    def open_writer(self, experiment: dict) -> None:
        if not self.resume:
            return super().open_writer(experiment)
        out = self.out
        backup = out.with_name(out.name + ".resume-source")
        # the writer lock first: a study still writing `out` is never touched
        lock = WriterLock(out, writing=False)  # read what is continued as a killed writer's file
        try:
            lock.acquire()
        except LockBusy as busy:
            raise UserError(
                f"--resume: {out} is being written by another run ({busy.holder}); "
                "wait for it to end (or stop it), then resume"
            ) from None
        except OSError as exc:
            raise UserError(f"--resume: cannot lock {out} ({exc.strerror or exc})") from None
        try:
            if not out.exists() and not backup.exists():
                raise UserError(f"--resume: {out} does not exist; run without --resume to start the study")
            use_out = out.exists() and (
                not backup.exists() or complete_points(out) >= complete_points(backup)
            )
            self._check_same_study(out if use_out else backup, experiment)  # before touching files
            if use_out:
                os.replace(out, backup)
            elif out.exists():
                out.unlink()  # a copy cut short: the backup holds every point it had
            self.start_index = complete_points(backup)
            self.start_index = min(len(self.points_planned), self.start_index)
            self.writer = RecordingWriter(
                out,
                backend=self.device.backend,
                rig=self.cfg.to_json(),
                experiment={**experiment, "resumed": True},
                lock=lock,
            )
        finally:
            if self.writer is None:
                lock.release()
        self._copy_points(backup, self.start_index)
        backup.unlink()

    def _check_same_study(self, path: Path, experiment: dict) -> None:
        try:
            with open_recording(path) as rec:
                old = rec.experiment
        except Exception as exc:  # noqa: BLE001 - one line for the user
            raise UserError(f"--resume: cannot read {path}: {exc}") from None
        if old.get("parameters", {}).get("plan") != experiment["parameters"]["plan"]:
            raise UserError(
                f"--resume: {self.out} holds a different study (plan "
                f"{old.get('parameters', {}).get('plan')}); give the same options"
            )

    def _copy_points(self, path: Path, n: int) -> None:
        with open_recording(path) as rec:
            for i, point in enumerate(rec):
                if i >= n:
                    break
                attrs = {**point.params, "first_start_time": point.start_time}
                channels = list(self.specs)
                w = self.recording_writer().begin_point(params=attrs, channels=channels)
                data = np.vstack([point[c.name].read() for c in channels])
                w.append(data)
                w.end()

    def execute(self) -> None:
        p = self.params
        n = len(self.points_planned)
        self.result.summary = {"kind": p.kind, "resumed_from": self.start_index}
        last_gap = None
        for planned in self.points_planned[self.start_index :]:
            i = planned.index
            text = f"{p.kind} {planned.value:g} ({planned.direction})"
            self.emit("point", point=i + 1, n_points=n, text=text)
            if hasattr(self.device, "set_gap"):
                gap = self.set_gap(planned.gap, i)
            else:  # the operator sets it; the point records what was asked
                if planned.gap != last_gap:
                    self._hand_gap(planned.gap, i)
                gap = planned.gap
            last_gap = planned.gap
            self.begin_point(
                {
                    "fe": planned.fe,
                    "force_amplitude": planned.force,
                    "gap": gap,
                    "direction": planned.direction,
                    "study_value": planned.value,
                    "study_index": i,
                }
            )
            res = self.running_session().run_point(
                planned.fe,
                planned.force,
                record_periods=p.record_periods,
                k_max=p.k_max,
                point=i + 1,
                n_points=n,
                **p.control.model_dump(),
            )
            kept = f"{i + 1} of {n} points recorded and kept"
            missed = target_not_reached(res, planned.force, planned.fe, kept)
            if missed is not None:
                self.running_session().finish()  # the ramp to zero goes into this point
            res.update(gap=gap, direction=planned.direction, study_value=planned.value, index=i)
            self.end_point(point_attrs(res))
            self.result.points.append(res)
            self.emit("point_done", point=i + 1, n_points=n)
            if missed is not None:
                raise missed  # the next points would run at the same limit, not at their force
        self.running_session().finish()

    def _hand_gap(self, gap: float, index: int) -> None:
        """Real rig: ramp the drive down, let the operator set the gap, start a new stream."""
        s = self.running_session()
        if s.stream._started:
            s.finish()
            self.session = SineSession(
                self.device,
                self.cfg,
                s.monitor,
                s.fe,
                self,
                s.force_row,
                ring_seconds=s.sink._ring.shape[1] / s.rate,
            )
        if self.confirm_gap is not None:
            self.confirm_gap(gap, index)
