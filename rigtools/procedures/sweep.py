"""Stepped sine (force-controlled at every step) and rig studies over gap, F0 or fe.

Both are sine procedures on one running drive: the drive amplitude is carried from step to
step (the controller starts from where the last step ended), every step is one recording point
written as it completes, with the harmonics k = 1..K of every channel (amplitude, and phase
relative to the force fundamental) as point parameters.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from rigtools.errors import UserError
from rigtools.procedures.base import validate
from rigtools.procedures.dwell import MAX_GAP, ControlParameters, SineProcedure
from rigtools.procedures.session import SineSession, point_attrs


class SweepParameters(BaseModel):
    """A stepped sine (SI)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    frequencies: tuple[float, ...] = Field(min_length=2, description="step frequencies, Hz")
    force: float = Field(gt=0, le=1000, description="force amplitude F0 at every step, N")
    gap: float | None = Field(None, ge=0, le=MAX_GAP)
    direction: Literal["up", "down", "both"] = "up"
    record_periods: int = Field(30, ge=1, le=1_000_000)
    k_max: int = Field(10, ge=1, le=100)
    jump_threshold: float = Field(
        0.3,
        gt=0,
        le=10,
        description="relative change of the response between neighbouring steps called a jump",
    )
    response: str | None = Field(
        None, description="response channel (default: the active shroud accelerometer)"
    )
    control: ControlParameters = ControlParameters()

    @field_validator("frequencies")
    @classmethod
    def _positive(cls, v):
        if any(not (math.isfinite(f) and f > 0) for f in v):
            raise ValueError("every frequency must be > 0 Hz")
        return tuple(sorted({float(f) for f in v}))


def response_channel(device, name: str | None) -> int:
    """Row of the response channel: ``name``, else the first accelerometer not on the passive blade."""
    specs = device.input_channels
    if name is not None:
        for i, s in enumerate(specs):
            if s.name == name:
                return i
        raise UserError(
            f"response channel {name!r} is not an input (inputs: {', '.join(s.name for s in specs)})"
        )
    for i, s in enumerate(specs):
        if s.kind == "accel" and "passive" not in s.name.lower():
            return i
    return 0


def detect_jumps(
    freqs: list[float], amps: list[float], threshold: float, contrast: float = 2.0
) -> list[dict]:
    """Jumps between neighbouring steps of one sweep direction (in run order).

    A jump is a step where the response changes by more than ``threshold`` (relative to the
    smaller of the two) AND its change of log-amplitude is ``contrast`` times larger than the
    steps on either side: a discontinuity, not the steep flank of a resonance.
    """
    a = np.log(np.maximum(np.asarray(amps, dtype=float), 1e-300))
    d = np.abs(np.diff(a))
    out = []
    for i in range(1, len(freqs)):
        a0, a1 = amps[i - 1], amps[i]
        change = abs(a1 - a0) / max(min(a0, a1), 1e-300)
        neighbours = [d[j] for j in (i - 2, i) if 0 <= j < d.size]
        if change > threshold and all(d[i - 1] > contrast * x for x in neighbours):
            out.append(
                {
                    "from_hz": freqs[i - 1],
                    "to_hz": freqs[i],
                    "frequency_hz": 0.5 * (freqs[i - 1] + freqs[i]),
                    "change": change,
                    "kind": "up" if a1 > a0 else "down",
                }
            )
    return out


class SteppedSine(SineProcedure):
    """Force-controlled stepped sine up, down or both; jumps reported per direction."""

    name = "stepped sine"

    def __init__(self, cfg, params: SweepParameters | dict, out, **kwargs) -> None:
        super().__init__(cfg, out, **kwargs)
        self.params = params if isinstance(params, SweepParameters) else validate(SweepParameters, **params)
        vals = list(self.params.frequencies)
        d = self.params.direction
        self.order = (
            [(f, "up") for f in vals]
            if d == "up"
            else [(f, "down") for f in vals[::-1]]
            if d == "down"
            else [(f, "up") for f in vals] + [(f, "down") for f in vals[::-1][1:]]
        )

    def first_frequency(self) -> float:
        return self.order[0][0]

    def record_seconds(self) -> float:
        return self.params.record_periods / min(self.params.frequencies)

    def parameters_doc(self) -> dict:
        return self.params.model_dump()

    def execute(self) -> None:
        p = self.params
        gap = self.set_gap(p.gap)
        row = response_channel(self.device, p.response)
        session = self.running_session()
        name = session.names[row]
        n = len(self.order)
        curves: dict[str, tuple[list, list]] = {"up": ([], []), "down": ([], [])}
        for i, (fe, direction) in enumerate(self.order):
            self.emit("point", point=i + 1, n_points=n, text=f"{fe:g} Hz ({direction})")
            self.begin_point(
                {"fe": fe, "force_amplitude": p.force, "gap": gap, "direction": direction, "study_value": fe}
            )
            res = session.run_point(
                fe,
                p.force,
                record_periods=p.record_periods,
                k_max=p.k_max,
                point=i + 1,
                n_points=n,
                **p.control.model_dump(),
            )
            res.update(gap=gap, direction=direction)
            amp = res["harmonics"][name]["amplitude"][0]
            res["response_per_newton"] = amp / max(res["force_amplitude_measured"], 1e-300)
            self.end_point(point_attrs(res))
            self.result.points.append(res)
            curves[direction][0].append(fe)
            curves[direction][1].append(amp)
            self.emit("point_done", point=i + 1, n_points=n)
        session.finish()
        self.result.summary = {
            "response_channel": name,
            "jumps": {d: detect_jumps(f, a, p.jump_threshold) for d, (f, a) in curves.items() if f},
        }
        pts = [r for r in self.result.points if r["direction"] == self.order[0][1]]
        per_n = [r["response_per_newton"] for r in pts]
        k = int(np.argmax(per_n))
        self.result.summary["peak_hz"] = peak_frequency([r["fe"] for r in pts], per_n, k)


def peak_frequency(freqs: list[float], values: list[float], k: int) -> float:
    """The peak of ``values(freqs)`` by a parabola through the largest step and its neighbours."""
    if 0 < k < len(freqs) - 1:
        f = np.array(freqs[k - 1 : k + 2])
        y = np.array(values[k - 1 : k + 2])
        c = np.polyfit(f - f[1], y, 2)
        if c[0] < 0:
            return float(f[1] - c[1] / (2 * c[0]))
    return float(freqs[k])


# ------------------------------------------------------------------------------------ studies


class StudyParameters(BaseModel):
    """A rig study over gap, F0 or fe, in the model study's plan (:class:`rigtools.sim.studies.StudyPlan`)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    kind: Literal["gap", "force", "frequency"]
    values: tuple[float, ...] = Field(min_length=1)
    direction: Literal["up", "down", "both"] = "up"
    fe: float | None = Field(None, gt=0, le=25000)
    force: float | None = Field(None, gt=0, le=1000)
    gap: float | None = Field(None, ge=0, le=MAX_GAP)
    record_periods: int = Field(30, ge=1, le=1_000_000)
    k_max: int = Field(10, ge=1, le=100)
    control: ControlParameters = ControlParameters()

    def plan(self):
        from rigtools.sim.studies import StudyPlan
        from rigtools.sim.vibro_impact import SimulationInputError

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
    from rigtools.recording import open_recording

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
        from rigtools.recording import RecordingWriter

        if not self.resume:
            return super().open_writer(experiment)
        out = self.out
        backup = out.with_name(out.name + ".resume-source")
        if not out.exists() and not backup.exists():
            raise UserError(f"--resume: {out} does not exist; run without --resume to start the study")
        use_out = out.exists() and (not backup.exists() or complete_points(out) >= complete_points(backup))
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
        )
        self._copy_points(backup, self.start_index)
        backup.unlink()

    def _check_same_study(self, path: Path, experiment: dict) -> None:
        from rigtools.recording import open_recording

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
        from rigtools.recording import open_recording

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
            res.update(gap=gap, direction=planned.direction, study_value=planned.value, index=i)
            self.end_point(point_attrs(res))
            self.result.points.append(res)
            self.emit("point_done", point=i + 1, n_points=n)
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
