"""Plain parameter objects the physics takes (SI units). Built from the validated rig file by
:func:`rigtools.config.RigConfig.to_params`; ``sim`` never reads files itself.

Axes of every blade: x along the blade from the root, y the thin (impact, "flexural") direction,
z the chord ("edgewise") direction. The active blade's shroud faces the passive blade's shroud
across ``gap`` along y.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

Theory = Literal["euler-bernoulli", "timoshenko"]


@dataclass(frozen=True)
class BladeParams:
    """Geometry and material of one blade (a uniform rectangular beam)."""

    length: float
    width: float
    thickness: float
    youngs_modulus: float
    density: float
    poisson: float = 0.3
    elements: int = 100
    theory: Theory = "euler-bernoulli"

    @property
    def area(self) -> float:
        return self.width * self.thickness

    @property
    def i_flexural(self) -> float:
        """Second moment of area for bending in the thin (y) direction, m^4."""
        return self.width * self.thickness**3 / 12.0

    @property
    def i_edgewise(self) -> float:
        """Second moment of area for bending in the chord (z) direction, m^4."""
        return self.thickness * self.width**3 / 12.0

    @property
    def shear_modulus(self) -> float:
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson))


@dataclass(frozen=True)
class RootParams:
    """Blade root: rigid clamp, or translational and rotational springs on every root DOF."""

    kind: Literal["clamped", "springs"] = "clamped"
    rotational_stiffness: float = 0.0  # N*m/rad
    translational_stiffness: float = 0.0  # N/m


@dataclass(frozen=True)
class LumpedMass:
    """A rigid mass at a point of a blade, with the same rotary inertia about all three axes."""

    mass: float
    rotary_inertia: float
    position: float  # m from the root


@dataclass(frozen=True)
class ContactParams:
    """Penalty contact between the two shrouds along y."""

    gap: float
    stiffness: float
    damping: float = 0.0
    law: Literal["linear", "hertz", "hunt-crossley"] = "linear"
    hertz_exponent: float = 1.5


@dataclass(frozen=True)
class DampingParams:
    """Modal damping ratio (same for every mode) or Rayleigh C = alpha*M + beta*K."""

    ratio: float | None = 0.01
    alpha: float = 0.0
    beta: float = 0.0


@dataclass(frozen=True)
class RigParams:
    """The whole two-blade rig as the physics sees it."""

    active: BladeParams
    passive: BladeParams
    root: RootParams
    shroud: LumpedMass  # at each blade tip (position is the blade length)
    force_sensor: LumpedMass  # on the active blade; the shaker force acts here
    contact: ContactParams
    damping: DampingParams = field(default_factory=DampingParams)
    passive_root: RootParams | None = None  # None: same as ``root``
