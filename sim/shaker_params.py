"""The shaker's parameters, defined once: default and allowed range of each (SI). The model
(:class:`ShakerCoupling`, here), the simulated rig
(:class:`rigtools.drivers.shaker.ShakerParams`) and the rig file's ``[shaker]`` all check against
:data:`SHAKER_BOUNDS`, so a value one accepts the others accept (``force_factor = 0`` is refused
by all: a shaker without Bl drives nothing)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from numbers import Real

from rigtools.sim.params import SimulationInputError


@dataclass(frozen=True)
class ParamBound:
    """Default and allowed range of one shaker parameter (SI), the one definition used by the
    model's :class:`ShakerCoupling`, the simulated rig's
    :class:`rigtools.drivers.shaker.ShakerParams` and the rig file's ``[shaker]``
    (:class:`rigtools.config.ShakerConfig`)."""

    default: float
    low: float
    high: float
    low_open: bool  # True: low itself is refused (> low); False: >= low
    unit: str
    dimension: str  # for :func:`rigtools.units.parse_quantity`; "" for a plain ratio

    def check(self, name: str, value: float, error: type[ValueError] = ValueError) -> None:
        """Raise ``error`` (one line naming ``shaker.name`` and ``value``) if out of range."""
        ok = (
            isinstance(value, Real)
            and not isinstance(value, bool)
            and math.isfinite(value)
            and (value > self.low if self.low_open else value >= self.low)
            and value <= self.high
        )
        if not ok:
            low = "(" if self.low_open else "["
            raise error(
                f"shaker.{name} = {value!r} {self.unit}: must be a finite number in "
                f"{low}{self.low:g}, {self.high:g}] {self.unit}"
            )


# Physically sensible ranges for a lab shaker and its amplifier, from a 10 N modal exciter to a
# large electrodynamic shaker.
SHAKER_BOUNDS: dict[str, ParamBound] = {
    "armature_mass": ParamBound(0.1, 0.0, 10.0, True, "kg", "mass"),
    "suspension_stiffness": ParamBound(2.0e4, 0.0, 1e8, False, "N/m", "stiffness"),
    "suspension_damping": ParamBound(5.0, 0.0, 1e5, False, "N*s/m", "damping"),
    "force_factor": ParamBound(10.0, 0.0, 1e3, True, "N/A", "force_factor"),
    "coil_resistance": ParamBound(2.5, 0.0, 1e3, True, "ohm", "resistance"),
    "coil_inductance": ParamBound(5e-4, 0.0, 1.0, False, "H", "inductance"),
    "amplifier_gain": ParamBound(4.0, 0.0, 1e3, True, "V/V", ""),
}


@dataclass(frozen=True)
class ShakerCoupling:
    """Electrodynamic shaker rigidly attached at the force point, force sensor in between.

    ``L di/dt + R i + Bl v = V``; the armature mass and suspension act at the force point; the
    sensor reads ``Bl i - m_a a - k_s x - c_s v`` (the force passed into the blade).
    """

    armature_mass: float  # kg
    suspension_stiffness: float  # N/m
    suspension_damping: float  # N s/m
    force_factor: float  # Bl, N/A
    coil_resistance: float  # ohm
    coil_inductance: float  # H

    def __post_init__(self) -> None:
        for f in fields(self):
            SHAKER_BOUNDS[f.name].check(f.name, getattr(self, f.name), SimulationInputError)
