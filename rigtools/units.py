"""Quantity strings at the edge: ``"0.5 mm"`` -> 0.0005 (SI).

Only the units a vibration lab writes in a rig file or on the command line are known; anything
else is refused with a message naming the unit. Plain numbers are taken as SI already.
"""

from __future__ import annotations

import re

# unit text -> (factor to SI, dimension)
_UNITS: dict[str, tuple[float, str]] = {
    "m": (1.0, "length"), "mm": (1e-3, "length"), "um": (1e-6, "length"), "µm": (1e-6, "length"),
    "cm": (1e-2, "length"),
    "kg": (1.0, "mass"), "g": (1e-3, "mass"),
    "s": (1.0, "time"), "ms": (1e-3, "time"), "us": (1e-6, "time"), "min": (60.0, "time"),
    "hz": (1.0, "frequency"), "khz": (1e3, "frequency"),
    "n": (1.0, "force"), "kn": (1e3, "force"),
    "pa": (1.0, "pressure"), "kpa": (1e3, "pressure"), "mpa": (1e6, "pressure"),
    "gpa": (1e9, "pressure"),
    "kg/m^3": (1.0, "density"), "kg/m3": (1.0, "density"), "g/cm^3": (1e3, "density"),
    "g/cm3": (1e3, "density"),
    "n/m": (1.0, "stiffness"), "n/mm": (1e3, "stiffness"), "kn/mm": (1e6, "stiffness"),
    "n*m/rad": (1.0, "rotational_stiffness"), "nm/rad": (1.0, "rotational_stiffness"),
    "n*s/m": (1.0, "damping"), "ns/m": (1.0, "damping"),
    "kg*m^2": (1.0, "inertia"), "kg*m2": (1.0, "inertia"), "g*mm^2": (1e-9, "inertia"),
    "kg*mm^2": (1e-6, "inertia"), "g*cm^2": (1e-7, "inertia"),
    "v": (1.0, "voltage"), "mv": (1e-3, "voltage"), "vpp": (1.0, "voltage"),
    "uv": (1e-6, "voltage"), "µv": (1e-6, "voltage"),
    "ohm": (1.0, "resistance"), "ω": (1.0, "resistance"),     # "Ω" (either code point), lower-cased
    "h": (1.0, "inductance"), "mh": (1e-3, "inductance"), "uh": (1e-6, "inductance"),
    "µh": (1e-6, "inductance"),
    "a": (1.0, "current"), "ma": (1e-3, "current"),              # IEPE excitation current
    "n/a": (1.0, "force_factor"),                               # Bl of a shaker, N/A = V*s/m
    "m/s^2": (1.0, "acceleration"), "g0": (9.80665, "acceleration"),
    "mv/g": (1e-3 / 9.80665, "sensitivity_accel"), "mv/n": (1e-3, "sensitivity_force"),
    "v/n": (1.0, "sensitivity_force"),
}

# Units whose case carries the prefix (milli vs mega): matched exactly, never lower-cased.
_CASE_SENSITIVE: dict[str, tuple[float, str]] = {
    "mN": (1e-3, "force"), "MN": (1e6, "force"),
    "mN/m": (1e-3, "stiffness"), "MN/m": (1e6, "stiffness"),
}
_AMBIGUOUS = {key.lower() for key in _CASE_SENSITIVE}

_PATTERN = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([^\s].*?)?\s*$")


def parse_quantity(value: float | int | str, dimension: str | None = None) -> float:
    """Convert a number or a quantity string to a float in SI units.

    Parameters
    ----------
    value
        A number (taken as SI) or a string such as ``"0.5 mm"``, ``"110 g"``, ``"200 GPa"``.
    dimension
        If given, the unit must be of this dimension (``"length"``, ``"mass"``, ...).

    Returns
    -------
    float
        The value in SI units.

    Raises
    ------
    ValueError
        With a one-line message if the text or the unit is not understood.
    """
    if isinstance(value, bool):
        raise ValueError(f"expected a number or a quantity, got {value!r}")
    if isinstance(value, (int, float)):
        return float(value)
    match = _PATTERN.match(str(value))
    if not match:
        raise ValueError(f"cannot read {value!r} as a quantity (e.g. '0.5 mm')")
    number, unit = float(match.group(1)), match.group(2)
    if unit is None:
        return number
    # "μ" (Greek mu) and "µ" (micro sign) are both written for micro
    exact = unit.replace(" ", "").replace("·", "*").replace("μ", "µ")
    key = exact.lower()
    if exact in _CASE_SENSITIVE:
        factor, dim = _CASE_SENSITIVE[exact]
    elif key in _AMBIGUOUS:
        raise ValueError(f"unit {unit!r} in {value!r} is ambiguous: write mN (milli) or MN (mega)")
    elif key in _UNITS:
        factor, dim = _UNITS[key]
    else:
        raise ValueError(f"unknown unit {unit!r} in {value!r}")
    if dimension is not None and dim != dimension:
        raise ValueError(f"{value!r} is a {dim}, expected a {dimension}")
    return number * factor
