"""Sine dwell with closed-loop force control (the shared machinery: :mod:`rigtools.procedures.sine`)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from rigtools.procedures.base import validate
from rigtools.procedures.session import point_attrs
from rigtools.procedures.sine import ControlParameters, SineProcedure, target_not_reached
from rigtools.quantity_fields import Force, Frequency, Length
from rigtools.units import MAX_GAP  # the one gap limit of rig files and every command


class DwellParameters(BaseModel):
    """A force-controlled sine dwell (SI: Hz, N, m)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    fe: Frequency = Field(gt=0, le=25000, description="excitation frequency, Hz")
    force: Force = Field(gt=0, le=1000, description="force amplitude F0 (fundamental), N")
    gap: Length | None = Field(None, ge=0, le=MAX_GAP, description="shroud gap, m (None: as set)")
    record_periods: int = Field(60, ge=1, le=1_000_000, description="periods recorded after settling")
    k_max: int = Field(10, ge=1, le=100, description="highest harmonic k of fe analysed")
    control: ControlParameters = ControlParameters()


class SineDwell(SineProcedure):
    """Hold the force fundamental at F0 at one frequency, wait for steady state, record
    ``record_periods`` whole periods; the drive then ramps to zero (recorded in the point)."""

    name = "sine dwell"

    def __init__(self, cfg, params: DwellParameters | dict, out, **kwargs) -> None:
        super().__init__(cfg, out, **kwargs)
        self.params = params if isinstance(params, DwellParameters) else validate(DwellParameters, **params)

    def first_frequency(self) -> float:
        return self.params.fe

    def record_seconds(self) -> float:
        return self.params.record_periods / self.params.fe

    def parameters_doc(self) -> dict:
        return self.params.model_dump()

    def execute(self) -> None:
        p = self.params
        gap = self.set_gap(p.gap)
        self.emit("point", point=1, n_points=1, text=f"{p.fe:g} Hz, {p.force:g} N")
        self.begin_point({"fe": p.fe, "force_amplitude": p.force, "gap": gap})
        session = self.running_session()
        res = session.run_point(
            p.fe,
            p.force,
            record_periods=p.record_periods,
            k_max=p.k_max,
            point=1,
            n_points=1,
            **p.control.model_dump(),
        )
        res["gap"] = gap
        session.finish()  # the ramp to zero goes into the point
        self.end_point(point_attrs(res))
        self.result.points.append(res)
        self.emit("point_done", point=1, n_points=1)
        missed = target_not_reached(res, p.force, p.fe, "the point is kept")
        if missed is not None:
            raise missed
