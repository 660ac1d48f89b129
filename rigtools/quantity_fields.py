"""Quantity fields of the pydantic parameter models (rig file sections and procedure parameters).

A field typed :data:`Frequency`, :data:`Length`, ... takes a number (SI) or a quantity string
(``"60 Hz"``, ``"0.5 mm"``; the rules of :mod:`rigtools.units`) and holds the SI float. The same
field metadata gives the one-line error text (:func:`describe_error`: the parameter, the value as
written, the allowed range in SI units) and the reference tables (:func:`field_unit`,
:func:`field_bounds`).

Examples
--------
>>> from pydantic import BaseModel, Field
>>> class Point(BaseModel):
...     fe: Frequency = Field(gt=0, le=25000)
>>> Point(fe="5 kHz").fe
5000.0
>>> field_unit(Point.model_fields["fe"]), field_bounds(Point.model_fields["fe"])
('Hz', '(0, 25000]')
"""

from __future__ import annotations

import types
import typing
from dataclasses import dataclass
from typing import Annotated, Any

from pydantic import BaseModel, BeforeValidator

from rigtools.units import parse_quantity

# SI unit of each dimension of rigtools.units, as messages and reference tables write it
SI_UNIT = {
    "length": "m",
    "mass": "kg",
    "time": "s",
    "frequency": "Hz",
    "force": "N",
    "pressure": "Pa",
    "density": "kg/m^3",
    "stiffness": "N/m",
    "rotational_stiffness": "N*m/rad",
    "damping": "N*s/m",
    "inertia": "kg*m^2",
    "voltage": "V",
    "voltage_amplitude": "V peak",
    "current": "A",
    "resistance": "ohm",
    "inductance": "H",
    "force_factor": "N/A",
    "acceleration": "m/s^2",
}


@dataclass(frozen=True)
class QuantityParser:
    """Reads a number (SI) or a quantity text (``"0.5 mm"``) of ``dimension`` as an SI float
    (:func:`rigtools.units.parse_quantity`); ``None`` (an optional field left unset) stays
    ``None``. The dimension also gives the SI unit in messages and reference tables."""

    dimension: str

    def __call__(self, value: Any) -> Any:
        if value is None:
            return None
        return parse_quantity(value, self.dimension)


def quantity_validator(dimension: str) -> BeforeValidator:
    """A pydantic ``BeforeValidator`` reading a number or a quantity string of ``dimension``
    as an SI float (:class:`QuantityParser`)."""
    return BeforeValidator(QuantityParser(dimension))


Length = Annotated[float, quantity_validator("length")]
Mass = Annotated[float, quantity_validator("mass")]
Time = Annotated[float, quantity_validator("time")]
Frequency = Annotated[float, quantity_validator("frequency")]
Force = Annotated[float, quantity_validator("force")]
Pressure = Annotated[float, quantity_validator("pressure")]
Density = Annotated[float, quantity_validator("density")]
Stiffness = Annotated[float, quantity_validator("stiffness")]
RotStiffness = Annotated[float, quantity_validator("rotational_stiffness")]
Damping = Annotated[float, quantity_validator("damping")]
Inertia = Annotated[float, quantity_validator("inertia")]
Voltage = Annotated[float, quantity_validator("voltage")]
VoltageAmplitude = Annotated[float, quantity_validator("voltage_amplitude")]  # peak V; "2 Vpp" = 1 V
Current = Annotated[float, quantity_validator("current")]
Acceleration = Annotated[float, quantity_validator("acceleration")]
ForceFactor = Annotated[float, quantity_validator("force_factor")]
Resistance = Annotated[float, quantity_validator("resistance")]
Inductance = Annotated[float, quantity_validator("inductance")]


def _metadata(field: Any) -> tuple[list[Any], type[BaseModel] | None]:
    """Validation metadata (bounds, unit parser) of a pydantic field, and the model it nests."""
    items, nested = list(field.metadata), None
    stack = [field.annotation]
    while stack:
        ann = stack.pop()
        origin = typing.get_origin(ann)
        if origin is Annotated:
            stack.append(typing.get_args(ann)[0])
            for meta in ann.__metadata__:
                items.extend(getattr(meta, "metadata", None) or [meta])
        elif origin in (typing.Union, types.UnionType, tuple):
            stack.extend(a for a in typing.get_args(ann) if a is not Ellipsis)
        elif isinstance(ann, type) and issubclass(ann, BaseModel):
            nested = ann
    return items, nested


def field_metadata(model: type[BaseModel], loc: typing.Sequence[str | int]) -> list[Any]:
    """The validation metadata of the field at ``loc`` (names of nested fields) in ``model``;
    ``[]`` if there is no such field."""
    cls: type[BaseModel] | None = model
    items: list[Any] = []
    for part in loc:
        if isinstance(part, int):  # an item of a tuple field: the field's own metadata
            continue
        fields = getattr(cls, "model_fields", None)
        if not fields or part not in fields:
            return []
        items, cls = _metadata(fields[part])
    return items


def _dimension(items: list[Any]) -> str | None:
    for meta in items:
        parser = getattr(meta, "func", None)
        if isinstance(parser, QuantityParser):
            return parser.dimension
    return None


def _bounds(items: list[Any]) -> str | None:
    low = high = None
    low_open = high_open = False
    for meta in items:
        for attr, is_low, is_open in (
            ("gt", True, True),
            ("ge", True, False),
            ("lt", False, True),
            ("le", False, False),
        ):
            bound = getattr(meta, attr, None)
            if isinstance(bound, (int, float)) and not isinstance(bound, bool):
                if is_low:
                    low, low_open = bound, is_open
                else:
                    high, high_open = bound, is_open
    if low is None and high is None:
        return None
    left = "-inf" if low is None else f"{low:g}"
    right = "inf" if high is None else f"{high:g}"
    return (
        f"{'(' if low_open or low is None else '['}{left}, {right}{')' if high_open or high is None else ']'}"
    )


def field_unit(field: Any) -> str:
    """SI unit of a pydantic field typed with a quantity (``"Hz"``, ``"m"``), ``""`` otherwise."""
    return SI_UNIT.get(_dimension(_metadata(field)[0]) or "", "")


def field_bounds(field: Any) -> str:
    """Allowed range of a pydantic field in SI units (``"(0, 25000]"``), ``""`` if unbounded."""
    return _bounds(_metadata(field)[0]) or ""


def allowed_range(
    model: type[BaseModel], loc: typing.Sequence[str | int]
) -> tuple[str, str, str | None] | None:
    """(``"[1e-05, 0.5]"``, ``"m"``, ``"length"``) for the field at ``loc`` of ``model`` (SI), or
    None if it has no bounds."""
    items = field_metadata(model, loc)
    allowed = _bounds(items)
    if allowed is None:
        return None
    dimension = _dimension(items)
    return allowed, SI_UNIT.get(dimension or "", ""), dimension


_RANGE_ERRORS = ("greater_than", "greater_than_equal", "less_than", "less_than_equal")


def describe_error(model: type[BaseModel], error: Any, value: Any) -> str:
    """One line for a pydantic error of ``model``: ``"key = value: what is allowed"``.

    Parameters
    ----------
    model
        The model validated.
    error
        One item of ``ValidationError.errors()``.
    value
        The value as the user wrote it (before unit conversion).
    """
    loc = [str(p) for p in error["loc"]]
    key = ".".join(loc) if loc else model.__name__
    if error["type"] == "extra_forbidden":
        return f"unknown key '{key}'"
    if error["type"] == "missing":
        return f"missing key '{key}'"
    message = error["msg"].removeprefix("Value error, ")
    if error["type"] == "too_short":  # pydantic: "Tuple should have at least 2 items after validation, not 1"
        n = error["ctx"]["min_length"]
        message = "give at least one value" if n == 1 else f"give at least {n} values"
    if error["type"] in _RANGE_ERRORS:
        found = allowed_range(model, error["loc"])
        if found:
            allowed, unit, dimension = found
            si = error.get("input")
            if isinstance(si, str) and dimension:  # an optional field reports the raw text
                si = parse_quantity(si, dimension)
            if isinstance(value, str) and isinstance(si, (int, float)):
                note = f" (= {si:g} {unit})".replace(" )", ")")
            elif unit and isinstance(value, (int, float)):
                note = (
                    f" (a plain number is in {unit}; write units, e.g. '0.5 mm')"
                    if unit == "m"
                    else f" (a plain number is in {unit})"
                )
            else:
                note = ""
            message = f"outside the allowed range {allowed} {unit}".rstrip() + note
    if not loc:
        return message
    if isinstance(value, dict):  # a check of a whole table: its message names the keys
        return f"{key}: {message}"
    return f"{key} = {value!r}: {message}"
