"""Plain parameter objects the physics takes (SI units). Built from the validated rig file by
:func:`rigtools.config.RigConfig.to_params`; ``sim`` never reads files itself.

Axes of every blade: x along the blade from the root, y the thin (impact, "flexural") direction,
z the chord ("edgewise") direction. The active blade's shroud faces the passive blade's shroud
across ``gap`` along y.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

Theory = Literal["euler-bernoulli", "timoshenko"]
ContactLaw = Literal["linear", "hertz", "hunt-crossley"]
THEORIES = ("euler-bernoulli", "timoshenko")
CONTACT_LAWS = ("linear", "hertz", "hunt-crossley")
# Elements per blade: what builds in a few seconds. The model builds and reduces in about linear
# time and memory (benchmarks/bench_model_build.py: 1.4-4.5 s and 0.34 GB at 20 000 elements per
# blade on a shared 2-core machine; 16 s and 0.7 GB at 50 000). Round-off no longer limits it: the
# stiffness is applied through the element deformations (rigtools.sim.deformation): measured up to
# 25 600 elements, the frequencies of the clamped beam within 5e-15 of the closed form and its
# static tip deflection within 5e-13 (the assembled matrix alone lost ~n^4 eps: 3e-8 of the first
# frequency at 100 elements, 7.5e-4 of the static deflection at 6400).
# Computing every mode (dense, O(n^3): the full-order integrator, the harmonic response over all
# modes, an FRF fit) has its own, lower limit: rigtools.sim.modal.DENSE_MAX_ELEMENTS.
MAX_ELEMENTS = 20000
# a root spring stiffer than this many times the root element's own stiffness brings nothing a
# clamp does not, and ruins the FE eigen-solve (measured: 1e6 times agrees with the clamp to
# 4e-8; 1e7 times gives a first flexural frequency 43 % high, 1e11 times 0 Hz)
MAX_ROOT_SPRING_RATIO = 1e6


class SimulationInputError(ValueError):
    """Physically invalid input (negative gap, too coarse a step, ...); one-line message."""


def _finite(
    owner: str,
    name: str,
    value,
    *,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
    unit: str = "",
) -> None:
    """One-line refusal of a value that is not a finite number in the given range."""
    shown = f"{value!r}{(' ' + unit) if unit else ''}"
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SimulationInputError(f"{owner}.{name} must be a number, got {shown}") from None
    if isinstance(value, bool) or not math.isfinite(v):
        raise SimulationInputError(f"{owner}.{name} must be a finite number, got {shown}")
    for bound, ok, word in (
        (gt, lambda b: v > b, ">"),
        (ge, lambda b: v >= b, ">="),
        (lt, lambda b: v < b, "<"),
        (le, lambda b: v <= b, "<="),
    ):
        if bound is not None and not ok(bound):
            raise SimulationInputError(
                f"{owner}.{name} must be {word} {bound:g}{(' ' + unit) if unit else ''}, "
                f"got {v:g}{(' ' + unit) if unit else ''}"
            )


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

    def __post_init__(self) -> None:
        o = "blade"
        for name, unit in (
            ("length", "m"),
            ("width", "m"),
            ("thickness", "m"),
            ("youngs_modulus", "Pa"),
            ("density", "kg/m^3"),
        ):
            _finite(o, name, getattr(self, name), gt=0, unit=unit)
        _finite(o, "poisson", self.poisson, gt=-1.0, lt=0.5)
        if isinstance(self.elements, bool) or int(self.elements) != self.elements:
            raise SimulationInputError(f"blade.elements must be a whole number, got {self.elements!r}")
        _finite(o, "elements", self.elements, ge=1, le=MAX_ELEMENTS)
        if self.theory not in THEORIES:
            raise SimulationInputError(
                f"blade.theory must be one of {', '.join(THEORIES)}, got {self.theory!r}"
            )

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

    def __post_init__(self) -> None:
        if self.kind not in ("clamped", "springs"):
            raise SimulationInputError(f"root.kind must be 'clamped' or 'springs', got {self.kind!r}")
        strict = self.kind == "springs"  # a spring root needs both springs
        _finite(
            "root",
            "rotational_stiffness",
            self.rotational_stiffness,
            **({"gt": 0} if strict else {"ge": 0}),
            unit="N*m/rad",
        )
        _finite(
            "root",
            "translational_stiffness",
            self.translational_stiffness,
            **({"gt": 0} if strict else {"ge": 0}),
            unit="N/m",
        )

    def check_against(self, blade: BladeParams, which: str = "root") -> None:
        """Refuse springs so stiff, next to the root element of ``blade``, that the FE eigen-solve
        loses its precision (:data:`MAX_ROOT_SPRING_RATIO`); a clamp is the rigid root."""
        if self.kind != "springs":
            return
        le = blade.length / blade.elements
        refs = (
            ("translational_stiffness", blade.youngs_modulus * blade.area / le, "N/m", "axial EA/Le"),
            (
                "rotational_stiffness",
                blade.youngs_modulus * blade.i_flexural / le,
                "N*m/rad",
                "bending EI/Le",
            ),
        )
        for name, ref, unit, what in refs:
            k = getattr(self, name)
            if k > MAX_ROOT_SPRING_RATIO * ref:
                raise SimulationInputError(
                    f"{which}.{name} {k:.3g} {unit} is {k / ref:.2g} times the root element's {what} "
                    f"({ref:.3g} {unit}); above {MAX_ROOT_SPRING_RATIO:.0e} times the natural frequencies "
                    f'come out wrong: use kind = "clamped" for a rigid root'
                )


@dataclass(frozen=True)
class LumpedMass:
    """A rigid mass at a point of a blade, with the same rotary inertia about all three axes."""

    mass: float
    rotary_inertia: float
    position: float  # m from the root

    def __post_init__(self) -> None:
        _finite("mass", "mass", self.mass, ge=0, unit="kg")
        _finite("mass", "rotary_inertia", self.rotary_inertia, ge=0, unit="kg*m^2")
        _finite("mass", "position", self.position, ge=0, unit="m")


@dataclass(frozen=True)
class ContactParams:
    """Penalty contact between the two shrouds along y."""

    gap: float
    stiffness: float
    damping: float = 0.0
    law: ContactLaw = "linear"
    hertz_exponent: float = 1.5

    def __post_init__(self) -> None:
        _finite("contact", "gap", self.gap, ge=0, unit="m")
        _finite("contact", "stiffness", self.stiffness, gt=0, unit="N/m")
        _finite("contact", "damping", self.damping, ge=0, unit="N*s/m")
        if self.law not in CONTACT_LAWS:
            raise SimulationInputError(
                f"contact.law must be one of {', '.join(CONTACT_LAWS)}, got {self.law!r}"
            )
        _finite("contact", "hertz_exponent", self.hertz_exponent, ge=1.0, le=3.0)


@dataclass(frozen=True)
class DampingParams:
    """Modal damping ratio (same for every mode) or Rayleigh C = alpha*M + beta*K."""

    ratio: float | None = 0.01
    alpha: float = 0.0
    beta: float = 0.0

    def __post_init__(self) -> None:
        if self.ratio is not None:
            _finite("damping", "ratio", self.ratio, ge=0, lt=1)
        _finite("damping", "alpha", self.alpha, ge=0, unit="1/s")
        _finite("damping", "beta", self.beta, ge=0, unit="s")


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

    def __post_init__(self) -> None:
        for name in ("active", "passive"):
            if not isinstance(getattr(self, name), BladeParams):
                raise SimulationInputError(f"rig.{name} must be BladeParams")
        if not self.force_sensor.position <= self.active.length:
            raise SimulationInputError(
                f"force_sensor.position {self.force_sensor.position * 1e3:g} mm lies beyond the active "
                f"blade's length {self.active.length * 1e3:g} mm"
            )
        if not self.force_sensor.position > 0:
            raise SimulationInputError("force_sensor.position must be > 0 (the root is clamped)")
        self.root.check_against(self.active, "root")
        self.root.check_against(self.passive, "root")
        if self.passive_root is not None:
            self.passive_root.check_against(self.passive, "passive_root")

    def root_of(self, blade: str) -> RootParams:
        """The root of ``blade`` (``"active"`` or ``"passive"``): the passive blade has its own
        ``passive_root`` when given, else both blades share ``root``. The one place this fallback lives."""
        if blade == "passive" and self.passive_root is not None:
            return self.passive_root
        return self.root

    def blade(self, name: str) -> BladeParams:
        """The :class:`BladeParams` of ``name`` (``"active"`` or ``"passive"``)."""
        return self.active if name == "active" else self.passive
