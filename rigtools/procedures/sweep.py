"""Stepped sine (force-controlled at every step) and rig studies over gap, F0 or fe.

Both are sine procedures on one running drive: the drive amplitude is carried from step to
step (the controller starts from where the last step ended), every step is one recording point
written as it completes, with the harmonics k = 1..K of every channel (amplitude, and phase
relative to the force fundamental) as point parameters.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from rigtools.analysis.jumps import contact_seen, find_jumps
from rigtools.errors import UserError
from rigtools.options import value_list
from rigtools.procedures.base import validate
from rigtools.procedures.session import point_attrs
from rigtools.procedures.sine import ControlParameters, SineProcedure, target_not_reached
from rigtools.quantity_fields import Force, Frequency, Length
from rigtools.units import MAX_GAP


class SweepParameters(BaseModel):
    """A stepped sine (SI)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    frequencies: tuple[Frequency, ...] = Field(min_length=2, description="step frequencies, Hz")
    force: Force = Field(gt=0, le=1000, description="force amplitude F0 at every step, N")
    gap: Length | None = Field(None, ge=0, le=MAX_GAP, description="shroud gap, m (None: as set)")
    direction: Literal["up", "down", "both"] = "up"
    record_periods: int = Field(30, ge=1, le=1_000_000, description="periods recorded at each step")
    k_max: int = Field(10, ge=1, le=100, description="highest harmonic k of fe analysed")
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

    @field_validator("frequencies", mode="before")
    @classmethod
    def _range_string(cls, v):
        # the CLI's "62 Hz:72 Hz:2 Hz" or "62 Hz,65 Hz", read by its one parser
        if isinstance(v, str):
            return value_list(v, "frequency", "frequencies", minimum=2)
        return v

    @field_validator("frequencies")
    @classmethod
    def _positive(cls, v):
        if any(not (math.isfinite(f) and f > 0) for f in v):
            raise ValueError("every frequency must be > 0 Hz")
        if len({float(f) for f in v}) < 2:
            raise ValueError("a stepped sine needs at least 2 different frequencies")
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


def passive_channel(device) -> int | None:
    """Row of the passive shroud's accelerometer (driven only through the contact), or ``None``."""
    for i, spec in enumerate(device.input_channels):
        if spec.kind == "accel" and "passive" in spec.name.lower():
            return i
    return None


def detect_jumps(
    freqs: Sequence[float],
    amps: Sequence[float],
    threshold: float,
    *,
    contact: Sequence[bool | None] | None = None,
    other: tuple[Sequence[float], Sequence[float]] | None = None,
) -> list[dict]:
    """Jumps between neighbouring steps of one sweep direction (in run order), as the sweep's
    summary lists them (:meth:`rigtools.analysis.jumps.Jump.as_dict`).

    A jump is a step where the response changes by more than ``threshold`` (relative to the
    smaller of the two) AND something independent says it is not a linear response: the contact
    appears or vanishes across it (``contact``: per step, see
    :func:`rigtools.analysis.jumps.contact_seen`), the sweep the other way (``other``: its
    ``(freqs, amps)``) differs there (hysteresis), or, in contact on both sides, the step stands
    out from its neighbours (:func:`rigtools.analysis.jumps.find_jumps`). A step with no contact
    on either side is never a jump.
    """
    return [j.as_dict() for j in find_jumps(freqs, amps, threshold, contact=contact, other=other)]


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
        passive = passive_channel(self.device)
        session = self.running_session()
        name = session.names[row]
        n = len(self.order)
        curves: dict[str, tuple[list, list]] = {"up": ([], []), "down": ([], [])}
        touch: dict[str, list[bool | None]] = {"up": [], "down": []}
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
            missed = target_not_reached(res, p.force, fe, f"{i + 1} of {n} steps recorded and kept")
            if missed is not None:
                session.finish()  # the ramp to zero goes into this step
            res.update(gap=gap, direction=direction)
            amp = res["harmonics"][name]["amplitude"][0]
            res["response_per_newton"] = amp / max(res["force_amplitude_measured"], 1e-300)
            self.end_point(point_attrs(res))
            self.result.points.append(res)
            curves[direction][0].append(fe)
            curves[direction][1].append(amp)
            touch[direction].append(_contact(res, name, None if passive is None else session.names[passive]))
            self.emit("point_done", point=i + 1, n_points=n)
            if missed is not None:
                raise missed  # every further step would run at the same limit, not at --force
        session.finish()
        self.result.summary = {
            "response_channel": name,
            "jumps": {
                d: detect_jumps(
                    f, a, p.jump_threshold, contact=touch[d], other=curves["down" if d == "up" else "up"]
                )
                for d, (f, a) in curves.items()
                if f
            },
        }
        pts = [r for r in self.result.points if r["direction"] == self.order[0][1]]
        per_n = [r["response_per_newton"] for r in pts]
        k = int(np.argmax(per_n))
        self.result.summary["peak_hz"] = peak_frequency([r["fe"] for r in pts], per_n, k)


def _contact(res: dict, active: str, passive: str | None) -> bool | None:
    """Whether the shrouds touch at a step, from its harmonics (:func:`rigtools.analysis.jumps.contact_seen`)."""
    harmonics = res.get("harmonics", {})
    if active not in harmonics:
        return None
    passive_amps = harmonics[passive]["amplitude"] if passive in harmonics else None
    return contact_seen(harmonics[active]["amplitude"], passive_amps)


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
