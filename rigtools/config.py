"""The rig description: a TOML file validated into typed objects.

Quantities are SI numbers or strings such as ``"0.5 mm"`` (the rules: :mod:`rigtools.units`).
Unknown keys, non-finite numbers and out-of-range values raise
:class:`rigtools.errors.ConfigError` with one line naming the key, the value and what is allowed;
so does a file that is not UTF-8 TOML text. The calibrated default rig ships as
``rigtools/data/default_rig.toml``.
"""

from __future__ import annotations

import json
import math
import tomllib
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from rigtools.drivers.contracts import STANDARD_GRAVITY, InputChannelSpec, OutputChannelSpec
from rigtools.drivers.shaker import ShakerParams
from rigtools.drivers.test_article import TestArticle
from rigtools.errors import ConfigError
from rigtools.quantity_fields import (
    Acceleration,
    Damping,
    Density,
    Force,
    ForceFactor,
    Frequency,
    Inductance,
    Inertia,
    Length,
    Mass,
    Pressure,
    Resistance,
    RotStiffness,
    Stiffness,
    Time,
    Voltage,
    VoltageAmplitude,
    describe_error,
    quantity_validator,
)
from rigtools.sim.params import (
    MAX_ELEMENTS,
    BladeParams,
    ContactParams,
    DampingParams,
    LumpedMass,
    RigParams,
    RootParams,
)
from rigtools.sim.shaker_params import SHAKER_BOUNDS
from rigtools.units import MAX_GAP, parse_quantity
from rigtools.vocabulary import ACTIVE_SHROUD, PASSIVE_SHROUD, channel_name_legal

if TYPE_CHECKING:
    from pydantic_core import ErrorDetails

_quantity = quantity_validator  # short name in the field annotations below


class _Section(BaseModel):
    # allow_inf_nan=False: TOML's inf/nan (and 1e400, read as inf) are refused in every section
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


# A blade: physically sensible ranges for a lab test blade (a steel or titanium strip of a few
# cm to a metre; rubber to diamond), shared by [blade] and [passive_blade].
BladeLength = Annotated[Length, Field(ge=1e-3, le=5.0)]
BladeWidth = Annotated[Length, Field(ge=1e-4, le=1.0)]
BladeThickness = Annotated[Length, Field(ge=1e-5, le=0.5)]
Elements = Annotated[int, Field(ge=2, le=MAX_ELEMENTS)]  # the limit's reason: sim.params
YoungsModulus = Annotated[Pressure, Field(ge=1e6, le=1.5e12)]
BladeDensity = Annotated[Density, Field(ge=100.0, le=3e4)]
Poisson = Annotated[float, Field(ge=0.0, lt=0.5)]
Theory = Literal["euler-bernoulli", "timoshenko"]


class BladeConfig(_Section):
    length: BladeLength
    width: BladeWidth
    thickness: BladeThickness
    elements: Elements = 100
    youngs_modulus: YoungsModulus
    density: BladeDensity
    poisson: Poisson = 0.3
    theory: Theory = "euler-bernoulli"


class PassiveBladeConfig(_Section):
    """Overrides for the passive blade; what is not given is taken from [blade]. Same ranges."""

    length: BladeLength | None = None
    width: BladeWidth | None = None
    thickness: BladeThickness | None = None
    elements: Elements | None = None
    youngs_modulus: YoungsModulus | None = None
    density: BladeDensity | None = None
    poisson: Poisson | None = None
    theory: Theory | None = None


# Root springs: far stiffer than the blade the stiffness matrix is so badly conditioned that the
# reduced model goes wrong (default rig, FEM reduction: 1e9 N*m/rad with 1e13 N/m still gives the
# clamped 53.2 Hz; 1e12 with 1e16 adds spurious 77 Hz modes; 1e18 with 1e24 gives 0 Hz). The
# limits keep a factor 100 below the first failure; stiffer than them, a clamp is the right model.
MAX_ROOT_ROTATIONAL_STIFFNESS = 1e7  # N*m/rad (the default blade's EI/L is ~140 N*m/rad)
MAX_ROOT_TRANSLATIONAL_STIFFNESS = 1e11  # N/m (its 3EI/L^3 is ~1.8e4 N/m; axially EA/L ~ 1.7e8 N/m)
# Far softer than the blade the root is almost free and the FEM reduction's static solve is
# singular (default rig: 1e-4 N*m/rad with 1e3 N/m, or 1e7 N*m/rad with 1 N/m, end in a
# LinAlgError or NaN frequencies); the same factor 100 is kept above those failures.
MIN_ROOT_ROTATIONAL_STIFFNESS = 1e-2  # N*m/rad
MIN_ROOT_TRANSLATIONAL_STIFFNESS = 1e2  # N/m


class RootConfig(_Section):
    kind: Literal["clamped", "springs"] = "clamped"
    rotational_stiffness: RotStiffness = Field(default=0.0, ge=0, le=MAX_ROOT_ROTATIONAL_STIFFNESS)
    translational_stiffness: Stiffness = Field(default=0.0, ge=0, le=MAX_ROOT_TRANSLATIONAL_STIFFNESS)

    @model_validator(mode="after")
    def _springs_need_stiffness(self) -> RootConfig:
        if self.kind == "springs" and (
            self.rotational_stiffness < MIN_ROOT_ROTATIONAL_STIFFNESS
            or self.translational_stiffness < MIN_ROOT_TRANSLATIONAL_STIFFNESS
        ):
            raise ValueError(
                f"kind = 'springs' needs rotational_stiffness >= {MIN_ROOT_ROTATIONAL_STIFFNESS:g} N*m/rad "
                f"and translational_stiffness >= {MIN_ROOT_TRANSLATIONAL_STIFFNESS:g} N/m (got "
                f"{self.rotational_stiffness:g} N*m/rad, {self.translational_stiffness:g} N/m); a softer "
                "root leaves the blade almost free, which the FE reduction cannot solve"
            )
        return self


class ShroudConfig(_Section):
    mass: Mass = Field(gt=0, le=10.0)
    rotary_inertia: Inertia = Field(default=0.0, ge=0, le=1.0)


class ForceSensorConfig(_Section):
    mass: Mass = Field(ge=0, le=10.0)
    rotary_inertia: Inertia = Field(default=0.0, ge=0, le=1.0)
    position: Length = Field(gt=0)


# Contact damping above this multiple of the critical damping of the shroud on the contact
# spring, 2*sqrt(stiffness*shroud mass), is refused: an over-damped contact has no rebound left to
# model, and the step chosen from the contact period does not resolve the damper's time constant
# (default rig at 60 Hz, 15 N: 1e5 N*s/m gives no contact force at all; the issue saw all-NaN).
MAX_CONTACT_DAMPING_RATIO = 2.0


class ContactConfig(_Section):
    gap: Length = Field(ge=0, le=MAX_GAP)
    stiffness: Stiffness = Field(gt=0, le=1e12)
    damping: Damping = Field(default=0.0, ge=0)
    law: Literal["linear", "hertz", "hunt-crossley"] = "linear"

    @model_validator(mode="before")
    @classmethod
    def _units_of_the_law(cls, data: Any) -> Any:
        # a Hertz-type law's stiffness is in N/m^1.5 (and Hunt-Crossley's damping in N*s/m^2.5):
        # read those units here; a plain number stays SI, a linear unit is refused
        if not isinstance(data, dict) or data.get("law") not in ("hertz", "hunt-crossley"):
            return data
        data = dict(data)
        dims = {"stiffness": "hertz_stiffness"}
        if data.get("law") == "hunt-crossley":
            dims["damping"] = "hertz_damping"
        for key, dimension in dims.items():
            if isinstance(data.get(key), str):
                try:
                    data[key] = parse_quantity(data[key], dimension)
                except ValueError as exc:
                    raise ValueError(f"{key} = {data[key]!r} with law = {data['law']!r}: {exc}") from None
        return data


class DampingConfig(_Section):
    ratio: float | None = Field(default=None, gt=0, lt=1)
    alpha: float = Field(default=0.0, ge=0, le=1e4)  # 1/s; 2*zeta*omega, zeta = 1 at 800 Hz
    beta: float = Field(default=0.0, ge=0, le=1e-2)  # s; 2*zeta/omega, zeta = 1 at 32 Hz

    @model_validator(mode="after")
    def _one_kind(self) -> DampingConfig:
        rayleigh = self.alpha > 0 or self.beta > 0
        if self.ratio is not None and rayleigh:
            raise ValueError("give either ratio or alpha/beta (Rayleigh), not both")
        if self.ratio is None and not rayleigh:
            raise ValueError("give ratio (modal) or alpha/beta (Rayleigh)")
        return self


# ----------------------------------------------------------------- acquisition and safety
# [daq], [signal_source], [safety]: the measurement chain (owner: drivers). Values SI.


_SENSITIVITY_DIMENSION = {"accel": "sensitivity_accel", "force": "sensitivity_force", "voltage": None}
# plausible sensor sensitivities, SI (V per m/s^2, V per N, V per V): 0.05 mV/g..10 V/g, 0.05 mV/N..1 V/N
_SENSITIVITY_RANGE = {"accel": (5e-6, 1.02), "force": (5e-5, 1.0), "voltage": (1e-6, 1e3)}


# the SI quantity a channel reads, for its range and its safety limits
# (a voltage channel's range and limits are peak values: "2 Vpp" is 1 V)
_KIND_DIMENSION = {"accel": "acceleration", "force": "force", "voltage": "voltage_amplitude"}
IEPE_EXCITATION = 0.004  # A, default for accel and force channels (voltage channels: none)


def _channel_quantity(value: Any, kind: str) -> float:
    """``value`` in the SI units of a channel of ``kind`` (m/s^2, N, V); other units refused."""
    try:
        return parse_quantity(value, _KIND_DIMENSION[kind])
    except ValueError as exc:
        hint = " (standard gravity is written g0, e.g. '500 g0')" if kind == "accel" else ""
        raise ValueError(f"{exc}{hint}") from None


class DaqChannelConfig(_Section):
    """One analog input: physical channel, sensor kind, sensitivity, IEPE excitation, range."""

    physical_channel: str = Field(min_length=1)
    kind: Literal["accel", "force", "voltage"]
    sensitivity: float  # SI (V/(m/s^2), V/N, V/V) or "10 mV/g", "11.24 mV/N"
    # A; default IEPE_EXCITATION for accel/force, 0 for voltage ("4 mA" or 0.004)
    excitation_current: Annotated[float, _quantity("current")] = Field(ge=0, le=0.025)
    range: float  # +- in the channel's SI units (m/s^2, N, V) or "4900 m/s^2", "200 N"
    location: str = ""

    @model_validator(mode="before")
    @classmethod
    def _default_excitation(cls, data: Any) -> Any:
        if isinstance(data, dict) and "excitation_current" not in data:
            data = {**data, "excitation_current": 0.0 if data.get("kind") == "voltage" else IEPE_EXCITATION}
        return data

    @field_validator("range", mode="before")
    @classmethod
    def _range_in_channel_units(cls, value: Any, info: ValidationInfo) -> float:
        kind = info.data.get("kind")
        if kind is None:
            raise ValueError("needs a valid kind")
        full_scale = _channel_quantity(value, kind)
        if not full_scale > 0:
            raise ValueError("must be > 0")
        return full_scale

    @model_validator(mode="after")
    def _voltage_is_not_iepe(self) -> DaqChannelConfig:
        if self.kind == "voltage" and self.excitation_current > 0:
            raise ValueError("a voltage channel takes no excitation current (give 0 or leave it out)")
        return self

    @field_validator("sensitivity", mode="before")
    @classmethod
    def _units_suit_kind(cls, value: Any, info: ValidationInfo) -> float:
        kind = info.data.get("kind")
        if kind is None:
            raise ValueError("needs a valid kind")
        sens = parse_quantity(value, _SENSITIVITY_DIMENSION[kind])
        low, high = _SENSITIVITY_RANGE[kind]
        if not low <= sens <= high:
            raise ValueError(
                f"implausible for kind {kind!r}; write it with units, e.g. '10 mV/g' or '11.24 mV/N'"
            )
        return float(f"{sens:.12g}")  # stored SI


# names of channels the toolkit records itself beside the inputs (the drive output)
RESERVED_CHANNEL_NAMES = frozenset({"drive"})


def channel_name_problem(name: str) -> str | None:
    """Why ``name`` cannot be an input channel's name (``None`` if it can): the recording schema's
    dataset-name rule (:func:`rigtools.vocabulary.channel_name_legal`) and the reserved names
    (``drive``)."""
    if name.casefold() in RESERVED_CHANNEL_NAMES:
        return f"reserved ({', '.join(sorted(RESERVED_CHANNEL_NAMES))} is recorded by the toolkit itself)"
    if not channel_name_legal(name):
        return "a recording cannot store it: use letters, digits, '_', '.', '-', not starting with '.' or '-'"
    return None


# the default rig's inputs: name -> (terminal, kind, sensitivity, range in SI, location)
_DEFAULT_INPUTS = {
    "force": ("Dev1/ai0", "force", "11.24 mV/N", 200.0, "active blade, force sensor at mid-span"),
    "active_shroud_accel": ("Dev1/ai1", "accel", "10 mV/g", 4900.0, ACTIVE_SHROUD),
    "passive_shroud_accel": ("Dev1/ai2", "accel", "10 mV/g", 4900.0, PASSIVE_SHROUD),
}


def _default_daq_channels() -> dict[str, DaqChannelConfig]:
    return {
        name: DaqChannelConfig(
            physical_channel=terminal,
            kind=kind,
            sensitivity=sensitivity,
            excitation_current=IEPE_EXCITATION,
            range=span,
            location=location,
        )
        for name, (terminal, kind, sensitivity, span, location) in _DEFAULT_INPUTS.items()
    }


class DaqConfig(_Section):
    """The acquisition device: shared sample clock, inputs by name, the drive output."""

    device: str = "Dev1"
    sample_rate: Frequency = Field(default=51200.0, gt=0, le=1e7)
    block_duration: Time = Field(default=0.1, gt=0, le=10.0)
    drive_channel: str = "Dev1/ao0"
    drive_range: VoltageAmplitude = Field(default=10.0, gt=0, le=100.0)  # AO range, +- V
    channels: dict[str, DaqChannelConfig] = Field(default_factory=_default_daq_channels, min_length=1)

    @field_validator("channels", mode="after")
    @classmethod
    def _names_storable(cls, channels: dict[str, DaqChannelConfig]) -> dict[str, DaqChannelConfig]:
        for name in channels:
            problem = channel_name_problem(name)
            if problem:
                raise ValueError(f"channel name {name!r}: {problem}")
        return channels

    @model_validator(mode="after")
    def _terminals_used_once(self) -> DaqConfig:
        seen: dict[str, str] = {self.drive_channel.strip().lower(): "drive_channel"}
        for name, ch in self.channels.items():
            terminal = ch.physical_channel.strip().lower()
            if terminal in seen:
                raise ValueError(
                    f"channels.{name}.physical_channel = {ch.physical_channel!r} is "
                    f"already used by {seen[terminal]}"
                )
            seen[terminal] = f"channels.{name}"
        return self

    def input_specs(self) -> list[InputChannelSpec]:
        """The inputs as :class:`rigtools.drivers.contracts.InputChannelSpec`, in file order."""
        specs = []
        for name, ch in self.channels.items():
            if ch.kind == "accel":
                sens, units = float(f"{ch.sensitivity * 1e3 * STANDARD_GRAVITY:.12g}"), "mV/g"
            elif ch.kind == "force":
                sens, units = float(f"{ch.sensitivity * 1e3:.12g}"), "mV/N"
            else:
                sens, units = ch.sensitivity, "V/V"
            specs.append(
                InputChannelSpec(
                    name=name,
                    physical_channel=ch.physical_channel,
                    kind=ch.kind,
                    sensitivity=sens,
                    sensitivity_units=units,
                    excitation_current=ch.excitation_current,
                    min_value=-ch.range,
                    max_value=ch.range,
                    location=ch.location,
                )
            )
        return specs

    def output_spec(self) -> OutputChannelSpec:
        """The drive as :class:`rigtools.drivers.contracts.OutputChannelSpec`."""
        return OutputChannelSpec("drive", self.drive_channel, -self.drive_range, self.drive_range)

    def block_size(self) -> int:
        """Samples per channel per block (``block_duration`` at ``sample_rate``, at least 1)."""
        return max(1, round(self.block_duration * self.sample_rate))


class SignalSourceConfig(_Section):
    """A VISA waveform generator feeding the shaker amplifier (optional)."""

    resource: str = ""  # e.g. "TCPIP0::192.168.1.20::inst0::INSTR"
    frequency_min: Frequency = Field(default=1.0, gt=0)
    frequency_max: Frequency = Field(default=5000.0, gt=0, le=3e7)
    # peak V into the amplifier ("2 Vpp" is 1 V peak, see rigtools.units)
    max_amplitude: VoltageAmplitude = Field(default=1.0, gt=0, le=10.0)
    timeout: Time = Field(default=2.0, gt=0, le=60.0)

    @property
    def max_amplitude_vpp(self) -> float:
        """``max_amplitude`` in peak-to-peak volts (the 33500's VOLT unit), for
        :class:`rigtools.drivers.visa_source` limits."""
        return 2.0 * self.max_amplitude

    @model_validator(mode="after")
    def _range(self) -> SignalSourceConfig:
        if self.frequency_min >= self.frequency_max:
            raise ValueError(
                f"frequency_min {self.frequency_min} Hz must be below frequency_max {self.frequency_max} Hz"
            )
        return self


class ChannelLimitConfig(_Section):
    """Warning and abort limits on ``|value|`` in the channel's SI units (N, m/s^2, V)."""

    warning: Annotated[float, BeforeValidator(parse_quantity)] = Field(gt=0)
    abort: Annotated[float, BeforeValidator(parse_quantity)] = Field(gt=0)

    @field_validator("abort", mode="after")
    @classmethod
    def _ordered(cls, abort: float, info: ValidationInfo) -> float:
        warning = info.data.get("warning")
        if warning is not None and not warning < abort:
            raise ValueError(f"must be above the warning limit {warning}")
        return abort


def _default_limits() -> dict[str, ChannelLimitConfig]:
    return {
        "force": ChannelLimitConfig(warning=40.0, abort=60.0),
        "active_shroud_accel": ChannelLimitConfig(warning=2500.0, abort=4000.0),
        "passive_shroud_accel": ChannelLimitConfig(warning=2500.0, abort=4000.0),
        "drive": ChannelLimitConfig(warning=4.5, abort=5.5),
    }


class SafetyConfig(_Section):
    """Limits checked on every block, the maximum drive and the drive ramps."""

    max_drive: VoltageAmplitude = Field(default=5.0, gt=0, le=100.0)  # peak V at the drive output
    ramp_time: Time = Field(default=0.5, gt=0, le=60.0)  # normal ramp up/down
    abort_ramp_time: Time = Field(default=0.05, gt=0, le=0.1)  # ramp down on abort
    limits: dict[str, ChannelLimitConfig] = Field(default_factory=_default_limits)


# ----------------------------------------------------------- simulated rig (owner: simrig)
# [shaker]: the power amplifier and electrodynamic shaker; [test_article]: how the simulated rig's
# blades deviate from the nominal model above, and its measurement chain. Values SI.


def _shaker_field(name: str) -> Any:
    """Default and range of a [shaker] key: from :data:`rigtools.sim.shaker_params.SHAKER_BOUNDS`, their one
    definition."""
    bound = SHAKER_BOUNDS[name]
    if bound.low_open:
        return Field(default=bound.default, gt=bound.low, le=bound.high)
    return Field(default=bound.default, ge=bound.low, le=bound.high)


class ShakerConfig(_Section):
    """Voltage amplifier and electrodynamic shaker driving the active blade through the force sensor.
    Defaults and ranges: :data:`rigtools.sim.shaker_params.SHAKER_BOUNDS`."""

    armature_mass: Mass = _shaker_field("armature_mass")  # kg
    suspension_stiffness: Stiffness = _shaker_field("suspension_stiffness")  # N/m
    suspension_damping: Damping = _shaker_field("suspension_damping")  # N*s/m
    force_factor: ForceFactor = _shaker_field("force_factor")  # Bl, N/A
    coil_resistance: Resistance = _shaker_field("coil_resistance")  # ohm
    coil_inductance: Inductance = _shaker_field("coil_inductance")  # H
    amplifier_gain: float = _shaker_field("amplifier_gain")  # V/V

    def to_params(self) -> ShakerParams:
        """As :class:`rigtools.drivers.shaker.ShakerParams`."""
        return ShakerParams(**self.model_dump())


class TestArticleConfig(_Section):
    """The simulated rig's real blades: a bolted root (springs, softer than the clamp), their own
    damping, small mass deviations of shroud and sensor; and its sensor noise and coupling."""

    root_rotational_stiffness: RotStiffness = Field(
        default=1.2e4, gt=0, le=MAX_ROOT_ROTATIONAL_STIFFNESS
    )  # N*m/rad
    root_translational_stiffness: Stiffness = Field(
        default=3e8, gt=0, le=MAX_ROOT_TRANSLATIONAL_STIFFNESS
    )  # N/m
    damping_ratio: float = Field(default=0.012, gt=0, lt=1)  # modal
    shroud_mass_deviation: float = Field(default=0.01, ge=-0.2, le=0.2)  # fraction of nominal
    sensor_mass_deviation: float = Field(default=-0.01, ge=-0.2, le=0.2)  # fraction of nominal
    force_noise: Force = Field(default=0.005, ge=0, le=100.0)  # N rms
    accel_noise: Acceleration = Field(default=0.02, ge=0, le=1e3)  # m/s^2 rms
    adc_noise: Voltage = Field(default=2e-5, ge=0, le=1.0)  # V rms
    iepe_highpass: Frequency = Field(default=0.5, ge=0, le=100.0)  # Hz, 0 = DC
    input_to_output_delay: Time = Field(default=8e-4, ge=0, le=1.0)  # s

    def to_params(self) -> TestArticle:
        """As :class:`rigtools.drivers.test_article.TestArticle`."""
        return TestArticle(**self.model_dump())


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
    daq: DaqConfig = DaqConfig()
    signal_source: SignalSourceConfig = SignalSourceConfig()
    safety: SafetyConfig = SafetyConfig()
    shaker: ShakerConfig = ShakerConfig()
    test_article: TestArticleConfig = TestArticleConfig()

    @model_validator(mode="before")
    @classmethod
    def _limits_in_channel_units(cls, data: Any) -> Any:
        """Limits written with units must be in their channel's units (N, m/s^2, V): checked on
        the raw file, since a limit alone does not know its channel."""
        if not isinstance(data, dict):
            return data
        safety = data.get("safety")
        limits = safety.get("limits") if isinstance(safety, dict) else None
        if not isinstance(limits, dict):
            return data
        daq = data.get("daq")
        channels = daq.get("channels") if isinstance(daq, dict) else None
        if isinstance(channels, dict):
            kinds = {n: c.get("kind") for n, c in channels.items() if isinstance(c, dict)}
        else:
            kinds = {n: c.kind for n, c in _default_daq_channels().items()}
        kinds["drive"] = "voltage"
        for name, limit in limits.items():
            kind = kinds.get(name)
            if kind is None or kind not in _KIND_DIMENSION or not isinstance(limit, dict):
                continue  # unknown channels and kinds are reported by the validation
            for key in ("warning", "abort"):
                if isinstance(limit.get(key), str):
                    try:
                        _channel_quantity(limit[key], kind)
                    except ValueError as exc:
                        raise ValueError(f"safety.limits.{name}.{key} = {limit[key]!r}: {exc}") from None
        return data

    @model_validator(mode="after")
    def _sensor_on_blade(self) -> RigConfig:
        if self.force_sensor.position >= self.blade.length:
            raise ValueError(
                f"force_sensor.position = {self.force_sensor.position} m is beyond the blade "
                f"(must be between 0 and blade.length = {self.blade.length} m)"
            )
        return self

    @model_validator(mode="after")
    def _contact_damping_integrable(self) -> RigConfig:
        c = self.contact
        if c.law == "linear" and c.damping > 0:
            critical = 2.0 * math.sqrt(c.stiffness * self.shroud.mass)
            if c.damping > MAX_CONTACT_DAMPING_RATIO * critical:
                raise ValueError(
                    f"contact.damping = {c.damping:g} N*s/m: at most {MAX_CONTACT_DAMPING_RATIO:g} x the "
                    f"critical damping 2*sqrt(stiffness*shroud.mass) = {critical:.4g} N*s/m"
                )
        return self

    @model_validator(mode="after")
    def _safety_names_known_channels(self) -> RigConfig:
        known = set(self.daq.channels) | {"drive"}
        if "limits" not in self.safety.model_fields_set:  # defaults follow the channels given
            limits = {k: v for k, v in self.safety.limits.items() if k in known}
            object.__setattr__(self.safety, "limits", limits)
        for name in self.safety.limits:
            if name not in known:
                raise ValueError(f"safety.limits.{name}: no such channel (known: {', '.join(sorted(known))})")
        drive = self.safety.limits.get("drive")
        if drive is not None and self.safety.max_drive > drive.abort:
            raise ValueError(
                f"safety.max_drive = {self.safety.max_drive} V is above the drive abort limit {drive.abort} V"
            )
        if self.safety.max_drive > self.daq.drive_range:
            raise ValueError(
                f"safety.max_drive = {self.safety.max_drive} V is beyond daq.drive_range "
                f"{self.daq.drive_range} V"
            )
        return self

    def passive_blade_config(self) -> BladeConfig:
        """The passive blade: [blade] with the [passive_blade] overrides applied."""
        overrides = {k: v for k, v in self.passive_blade.model_dump().items() if v is not None}
        return BladeConfig(**{**self.blade.model_dump(), **overrides})

    def to_params(self) -> RigParams:
        """The physics' view of this rig (:class:`rigtools.sim.params.RigParams`)."""
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


def _describe(error: ErrorDetails, data: dict[str, Any]) -> str:
    loc = [str(p) for p in error["loc"]]
    return describe_error(RigConfig, error, _raw_value(data, loc, error.get("input")))


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

    Parameters
    ----------
    path
        The rig file (TOML); ``None``: the calibrated default rig shipped with the package.

    Returns
    -------
    RigConfig
        The validated description, SI units throughout.

    Raises
    ------
    ConfigError
        If the file is missing, is not TOML, or does not validate.

    Examples
    --------
    >>> import rigtools
    >>> rig = rigtools.load_rig()
    >>> rig.contact.gap  # m
    0.0005
    >>> rigtools.load_rig("no-such-rig.toml")
    Traceback (most recent call last):
    rigtools.errors.ConfigError: cannot read rig file 'no-such-rig.toml': No such file or directory
    """
    if path is None:
        return parse_rig(tomllib.loads(default_rig_text()), "default rig")
    path = Path(path)
    data = tomllib.loads(read_rig_text(path))
    return parse_rig(data, f"rig file {path}")


MAX_RIG_FILE_BYTES = 1_000_000
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def read_rig_text(path: str | Path) -> str:
    """The text of a rig file, checked to be UTF-8 TOML.

    Raises
    ------
    ConfigError
        One line if the file is missing, a directory, unreadable, empty, too large, binary (an HDF5
        recording, for one), UTF-16, starts with a byte-order mark, is not UTF-8, or is not TOML.
    """
    path = Path(path)
    where = f"rig file {str(path)!r}"
    if path.is_dir():
        raise ConfigError(f"{where} is a directory; give a .toml file")
    try:
        with path.open("rb") as fh:
            raw = fh.read(MAX_RIG_FILE_BYTES + 1)
    except OSError as exc:
        raise ConfigError(f"cannot read {where}: {exc.strerror or exc}") from None
    if len(raw) > MAX_RIG_FILE_BYTES:
        raise ConfigError(f"{where} is larger than {MAX_RIG_FILE_BYTES // 1000} kB: not a rig file")
    if not raw.strip():
        raise ConfigError(
            f"{where} is empty; start from a copy of the default rig, rigtools/data/default_rig.toml"
        )
    if raw.startswith(_HDF5_SIGNATURE) or _HDF5_SIGNATURE in raw[:2056]:
        raise ConfigError(f"{where} is an HDF5 file (a recording?), not a TOML rig file")
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise ConfigError(f"{where} is UTF-16 text; save it as UTF-8 (without BOM)")
    if raw.startswith(b"\xef\xbb\xbf"):
        raise ConfigError(f"{where} starts with a byte-order mark (BOM); save it as UTF-8 without BOM")
    if b"\x00" in raw:
        raise ConfigError(f"{where} is a binary file, not TOML text")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise ConfigError(
            f"{where} is not UTF-8 text (byte 0x{raw[exc.start]:02x} on line {line}); save it as UTF-8"
        ) from None
    try:
        tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{where} is not valid TOML: {exc}") from None
    return text
