"""Phase-locked-loop (PLL) testing: hold the response's phase to the force by the drive frequency.

Each point holds the phase of the active shroud's displacement fundamental relative to the force
fundamental at a target (the phase detector and PI of :mod:`rigtools.procedures.pll_loop`; one
update per stream piece, ~20 ms) while an outer, slower loop holds the force fundamental at its
target by the drive amplitude (the same limits as the force control of
:class:`rigtools.procedures.session.SineSession`: never planned past ``margin`` of a channel's
warning level, the drive's warning or its maximum). Two modes, from the lists given:

* backbone: phase -90 deg at each force of a list (stepped force);
* stepped phase: each phase of a list at one held force, through and beyond the fold where a
  stepped sine jumps (phase control holds orbits that are unstable at a fixed frequency).

A point is locked when the phase error's RMS over the last ``lock_periods`` periods is at most
``lock_tolerance`` deg and the force is within ``force_tolerance``; then ``record_periods`` periods
are recorded with both loops running and give the point (a :class:`ControlledPoint`: frequency,
amplitude, force, phase, converged, periods to lock, the drive's harmonics). A point not locked
within ``max_periods``, one whose frequency runs into ``[f_min, f_max]``, or whose amplitude
passes ``max_amplitude`` (lock loss) is written marked not converged with one line saying why;
``on_lock_loss = "continue"`` goes on to the next point from where the loop is,
``"stop"`` ends the run there (drive ramped to zero, status finished, the points kept). Between
points the target moves at ``phase_rate`` deg/s and the force target at once (the outer loop
follows it at its own pace). The stream runs from the first point to the last; the drive ramps to
zero at the end and on every other exit (stop request, fault, error), as every procedure's does.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from rigtools.controlled_point import ControlledPoint
from rigtools.drivers.realtime_pll import NO_REALTIME_PLL
from rigtools.procedures.base import validate
from rigtools.procedures.pll_realtime import RealTimePllRun
from rigtools.procedures.pll_run import DETECT_PERIODS, PllRun
from rigtools.procedures.sine import SineProcedure
from rigtools.quantity_fields import Force, Frequency, Length, VoltageAmplitude
from rigtools.units import MAX_GAP

PROCEDURE = "phase-locked loop"
KIND = "pll"


class PllParameters(BaseModel):
    """A phase-locked-loop test (SI: Hz, N, m; phases in degrees)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    forces: list[Force] = Field(min_length=1, max_length=200, description="force fundamental F1 per point, N")
    phases: list[float] = Field(
        default=[-90.0], min_length=1, max_length=200, description="target phase per point, deg in (-180, 0)"
    )
    gap: Length | None = Field(None, ge=0, le=MAX_GAP, description="shroud gap, m (None: as set)")
    fe_start: Frequency = Field(gt=0, le=25000, description="frequency the first point starts at, Hz")
    f_min: Frequency | None = Field(
        None, gt=0, description="lowest drive frequency, Hz (default 0.7 fe_start)"
    )
    f_max: Frequency | None = Field(
        None, gt=0, description="highest drive frequency, Hz (default 1.5 fe_start)"
    )
    kp: float = Field(0.009, ge=0, le=1, description="proportional gain, Hz/deg")
    ki: float = Field(0.07, gt=0, le=100, description="integral gain, Hz/(deg s)")
    max_step: Frequency = Field(0.05, gt=0, description="largest frequency change per update, Hz")
    force_periods: int = Field(
        16, ge=1, le=1000, description="periods between two outer-loop (force) updates at least"
    )
    phase_rate: float = Field(
        30.0, gt=0, le=3600, description="how fast the target moves between points, deg/s"
    )
    lock_periods: int = Field(20, ge=3, le=10000, description="periods the lock criterion looks back over")
    lock_tolerance: float = Field(1.0, gt=0, le=45, description="phase error RMS at lock, deg")
    force_tolerance: float = Field(0.01, gt=0, le=0.2, description="force error at lock (fraction of F1)")
    max_periods: int = Field(
        600, ge=10, le=1_000_000, description="periods a point may take to lock (>= lock_periods)"
    )
    record_periods: int = Field(20, ge=1, le=100_000, description="periods recorded after lock")
    k_max: int = Field(10, ge=1, le=50, description="harmonics fitted (the fundamental and 2..K rejected)")
    max_amplitude: Length | None = Field(
        None, gt=0, description="active shroud amplitude limit, m (lock loss)"
    )
    on_lock_loss: Literal["continue", "stop"] = Field(
        "continue", description="after a point not locked: go on to the next, or end the run there"
    )
    initial_drive: VoltageAmplitude = Field(0.2, gt=0, le=10, description="first drive amplitude, V peak")
    margin: float = Field(0.8, gt=0, le=1, description="fraction of a warning level never planned past")
    inner_loop: Literal["realtime", "buffered"] | None = Field(
        None,
        description="the phase loop: the backend's real-time PLL, or the host's buffered one "
        "(None: real-time where the backend has one)",
    )

    @model_validator(mode="after")
    def _lists(self) -> PllParameters:
        if len(self.forces) > 1 and len(self.phases) > 1 and len(self.forces) != len(self.phases):
            raise ValueError("give one force or one phase, or as many forces as phases")
        for p in self.phases:
            if not -180.0 < p < 0.0:
                raise ValueError(f"phases = {p:g} deg: use -180 < phase < 0 (the response lags the force)")
        if self.max_periods < self.lock_periods:
            raise ValueError(
                f"max_periods {self.max_periods} is below lock_periods {self.lock_periods}: no point could "
                "lock (the lock test looks back over lock_periods)"
            )
        lo, hi = self.frequency_range()
        if not lo < hi:  # reversed or empty: say that, not that the start lies outside it
            raise ValueError(f"f_min {lo:g} Hz must be below f_max {hi:g} Hz")
        if not lo < self.fe_start < hi:
            raise ValueError(
                f"fe_start {self.fe_start:g} Hz must lie inside f_min..f_max ({lo:g}..{hi:g} Hz)"
            )
        return self

    def frequency_range(self) -> tuple[float, float]:
        """``(f_min, f_max)``, Hz."""
        lo = self.f_min if self.f_min is not None else 0.7 * self.fe_start
        hi = self.f_max if self.f_max is not None else 1.5 * self.fe_start
        return lo, hi

    def targets(self) -> list[tuple[float, float]]:
        """``(force N, phase deg)`` of each point."""
        n = max(len(self.forces), len(self.phases))
        f = self.forces * n if len(self.forces) == 1 else self.forces
        p = self.phases * n if len(self.phases) == 1 else self.phases
        return list(zip(f, p, strict=True))


class PhaseLockedLoop(SineProcedure):
    """The PLL test (see the module docstring); ``run()`` returns a :class:`~rigtools.procedures.result.RunResult` whose
    points carry the :class:`ControlledPoint` fields (``point.extra``), and :attr:`points` holds
    the :class:`ControlledPoint` of each."""

    name = PROCEDURE

    def __init__(self, cfg, params: PllParameters | dict, out, **kwargs) -> None:
        super().__init__(cfg, out, **kwargs)
        self.params = params if isinstance(params, PllParameters) else validate(PllParameters, **params)
        self.points: list[ControlledPoint] = []
        self.note = ""  # the line rig acquire prints first (a backend without a real-time loop)
        self.lost: list[str] = []  # why each point not locked was not (rig acquire prints them)

    def first_frequency(self) -> float:
        return self.params.fe_start

    def _inner_loop(self) -> type[PllRun]:
        """The run of the inner loop chosen; the one-line note where the backend has no
        real-time loop (the buffered PLL runs)."""
        has = bool(getattr(self.device, "has_realtime_loop", False))
        if not has and self.params.inner_loop != "buffered":
            if not self.note:
                self.note = NO_REALTIME_PLL
            self.emit("message", text=NO_REALTIME_PLL)
        if self.params.inner_loop == "buffered" or not has:
            return PllRun
        return RealTimePllRun

    def record_seconds(self) -> float:
        lo, _ = self.params.frequency_range()
        return (self.params.record_periods + self.params.lock_periods + DETECT_PERIODS) / lo

    def parameters_doc(self) -> dict:
        return {**self.params.model_dump(), "kind": KIND}

    # -- the run -----------------------------------------------------------------------------------
    def execute(self) -> None:
        p = self.params
        gap = self.set_gap(p.gap)
        run = self._inner_loop()(self, self.running_session(), p)
        self.result.summary["inner_loop"] = run.name
        targets = p.targets()
        for i, (force, phase) in enumerate(targets):
            text = f"{force:g} N, {phase:g} deg"
            self.emit("point", point=i + 1, n_points=len(targets), text=text)
            # fe where the point starts (the lock's replaces it): a point cut short by a stop
            # stays a readable sine point
            self.begin_point({"fe": run.fe, "force_amplitude": force, "phase_target": phase, "gap": gap})
            res = run.point(force, phase, i + 1, len(targets))
            res["gap"] = gap
            last = i == len(targets) - 1 or (not res["converged"] and p.on_lock_loss == "stop")
            if last:
                self.running_session().finish()  # the ramp to zero goes into the last point
            self.end_point(point_attrs(res))
            self.result.points.append(res)
            self.points.append(controlled_point(res))
            self.emit("point_done", point=i + 1, n_points=len(targets))
            if not res["converged"]:
                self.lost.append(res["lock_message"])
                self.result.summary["lost"] = self.lost
                self.emit("message", point=i + 1, n_points=len(targets), text=res["lock_message"])
                if p.on_lock_loss == "stop":
                    self.result.summary["stopped"] = res["lock_message"]
                    break
        self.result.summary["points"] = [c.to_dict() for c in self.points]


def controlled_point(res: dict) -> ControlledPoint:
    """The :class:`ControlledPoint` of a PLL point's result."""
    return ControlledPoint(**{name: res[name] for name in ControlledPoint.__dataclass_fields__})


def point_attrs(res: dict) -> dict:
    """The recording point attributes of a PLL point: the :class:`ControlledPoint` fields, how it
    locked, and the harmonics of every channel as a sine point has them."""
    attrs = controlled_point(res).to_dict()
    for key in (
        "fe",
        "force_amplitude_measured",
        "drive_amplitude",
        "settled",
        "record_start",
        "record_samples",
        "phase_error_rms",
        "lock_message",
        "safety_warnings",
    ):
        attrs[key] = res[key]
    attrs["procedure_kind"] = KIND
    for name, h in res["harmonics"].items():
        attrs[f"{name}_harmonic_amplitude"] = h["amplitude"]
        attrs[f"{name}_harmonic_phase"] = h["phase"]
    return attrs


__all__ = ["KIND", "PROCEDURE", "PhaseLockedLoop", "PllParameters", "point_attrs"]
