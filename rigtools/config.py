"""The rig description: a TOML file validated into typed objects.

Quantities are SI numbers or strings such as ``"0.5 mm"``. Unknown keys and out-of-range values
raise :class:`rigtools.errors.ConfigError` with one line naming the key, the value and what is
allowed. The calibrated default rig ships as ``rigtools/data/default_rig.toml``.
"""

from __future__ import annotations

import json
import tomllib
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, model_validator

from rigtools.errors import ConfigError
from rigtools.units import parse_quantity
from sim.params import (
    BladeParams,
    ContactParams,
    DampingParams,
    LumpedMass,
    RigParams,
    RootParams,
)


def _quantity(dimension: str):
    return BeforeValidator(lambda v: parse_quantity(v, dimension))


Length = Annotated[float, _quantity("length")]
Mass = Annotated[float, _quantity("mass")]
Pressure = Annotated[float, _quantity("pressure")]
Density = Annotated[float, _quantity("density")]
Stiffness = Annotated[float, _quantity("stiffness")]
RotStiffness = Annotated[float, _quantity("rotational_stiffness")]
Damping = Annotated[float, _quantity("damping")]
Inertia = Annotated[float, _quantity("inertia")]


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class BladeConfig(_Section):
    length: Length = Field(gt=0, le=5.0)
    width: Length = Field(gt=0, le=1.0)
    thickness: Length = Field(gt=0, le=0.5)
    elements: int = Field(default=100, ge=2, le=2000)
    youngs_modulus: Pressure = Field(gt=1e6, le=1e13)
    density: Density = Field(gt=1.0, le=1e5)
    poisson: float = Field(default=0.3, ge=0.0, lt=0.5)
    theory: Literal["euler-bernoulli", "timoshenko"] = "euler-bernoulli"


class PassiveBladeConfig(_Section):
    """Overrides for the passive blade; what is not given is taken from [blade]."""

    length: Length | None = None
    width: Length | None = None
    thickness: Length | None = None
    elements: int | None = None
    youngs_modulus: Pressure | None = None
    density: Density | None = None
    poisson: float | None = None
    theory: Literal["euler-bernoulli", "timoshenko"] | None = None


class RootConfig(_Section):
    kind: Literal["clamped", "springs"] = "clamped"
    rotational_stiffness: RotStiffness = Field(default=0.0, ge=0)
    translational_stiffness: Stiffness = Field(default=0.0, ge=0)

    @model_validator(mode="after")
    def _springs_need_stiffness(self) -> "RootConfig":
        if self.kind == "springs" and (self.rotational_stiffness <= 0 or self.translational_stiffness <= 0):
            raise ValueError("kind = 'springs' needs rotational_stiffness > 0 and translational_stiffness > 0")
        return self


class ShroudConfig(_Section):
    mass: Mass = Field(gt=0, le=10.0)
    rotary_inertia: Inertia = Field(default=0.0, ge=0, le=1.0)


class ForceSensorConfig(_Section):
    mass: Mass = Field(ge=0, le=10.0)
    rotary_inertia: Inertia = Field(default=0.0, ge=0, le=1.0)
    position: Length = Field(gt=0)


class ContactConfig(_Section):
    gap: Length = Field(ge=0, le=0.05)
    stiffness: Stiffness = Field(gt=0, le=1e12)
    damping: Damping = Field(default=0.0, ge=0)
    law: Literal["linear", "hertz"] = "linear"


class DampingConfig(_Section):
    ratio: float | None = Field(default=None, gt=0, lt=1)
    alpha: float = Field(default=0.0, ge=0)
    beta: float = Field(default=0.0, ge=0)

    @model_validator(mode="after")
    def _one_kind(self) -> "DampingConfig":
        rayleigh = self.alpha > 0 or self.beta > 0
        if self.ratio is not None and rayleigh:
            raise ValueError("give either ratio or alpha/beta (Rayleigh), not both")
        if self.ratio is None and not rayleigh:
            raise ValueError("give ratio (modal) or alpha/beta (Rayleigh)")
        return self


class RigConfig(_Section):
    """The validated rig file."""

    name: str = "rig"
    blade: BladeConfig
    passive_blade: PassiveBladeConfig = PassiveBladeConfig()
    root: RootConfig = RootConfig()
    shroud: ShroudConfig
    force_sensor: ForceSensorConfig
    contact: ContactConfig
    damping: DampingConfig = DampingConfig(ratio=0.01)

    @model_validator(mode="after")
    def _sensor_on_blade(self) -> "RigConfig":
        if self.force_sensor.position >= self.blade.length:
            raise ValueError(
                f"force_sensor.position = {self.force_sensor.position} m is beyond the blade "
                f"(must be between 0 and blade.length = {self.blade.length} m)"
            )
        return self

    def passive_blade_config(self) -> BladeConfig:
        """The passive blade: [blade] with the [passive_blade] overrides applied."""
        overrides = {k: v for k, v in self.passive_blade.model_dump().items() if v is not None}
        return BladeConfig(**{**self.blade.model_dump(), **overrides})

    def to_params(self) -> RigParams:
        """The physics' view of this rig (:class:`sim.params.RigParams`)."""
        active = BladeParams(**self.blade.model_dump())
        passive = BladeParams(**self.passive_blade_config().model_dump())
        return RigParams(
            active=active,
            passive=passive,
            root=RootParams(**self.root.model_dump()),
            shroud=LumpedMass(self.shroud.mass, self.shroud.rotary_inertia, active.length),
            force_sensor=LumpedMass(
                self.force_sensor.mass, self.force_sensor.rotary_inertia, self.force_sensor.position
            ),
            contact=ContactParams(**self.contact.model_dump()),
            damping=DampingParams(**self.damping.model_dump()),
        )

    def to_json(self) -> str:
        """The full description as JSON text (SI numbers), e.g. for a recording's ``rig`` attribute."""
        return json.dumps(self.model_dump(), indent=1)


def _raw_value(data: Any, loc: list[str], fallback: Any) -> Any:
    """The value as the user wrote it (before unit conversion), if it can be found."""
    for part in loc:
        if not isinstance(data, dict) or part not in data:
            return fallback
        data = data[part]
    return data


def _describe(error: dict[str, Any], data: dict[str, Any]) -> str:
    loc = [str(p) for p in error["loc"]]
    key = ".".join(loc) if loc else "(file)"
    if error["type"] == "extra_forbidden":
        return f"unknown key '{key}'"
    if error["type"] == "missing":
        return f"missing key '{key}'"
    value = _raw_value(data, loc, error.get("input"))
    message = error["msg"].removeprefix("Value error, ")
    if not loc:
        return message
    return f"{key} = {value!r}: {message}"


def parse_rig(data: dict[str, Any], source: str = "rig file") -> RigConfig:
    """Validate a parsed TOML mapping into a :class:`RigConfig`.

    Raises
    ------
    ConfigError
        One line naming the first offending key and value and what is allowed.
    """
    try:
        return RigConfig.model_validate(data)
    except ValidationError as exc:
        errors = exc.errors()
        more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
        raise ConfigError(f"{source}: {_describe(errors[0], data)}{more}") from None


def default_rig_text() -> str:
    """TOML text of the calibrated default rig shipped with the package."""
    return resources.files("rigtools").joinpath("data/default_rig.toml").read_text(encoding="utf-8")


def load_rig(path: str | Path | None = None) -> RigConfig:
    """Load and validate a rig file; ``None`` gives the calibrated default rig.

    Raises
    ------
    ConfigError
        If the file is missing, is not TOML, or does not validate.
    """
    if path is None:
        return parse_rig(tomllib.loads(default_rig_text()), "default rig")
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"cannot read rig file {path}: {exc.strerror}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"rig file {path} is not valid TOML: {exc}") from None
    return parse_rig(data, f"rig file {path}")
