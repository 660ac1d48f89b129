"""Quantity strings at the edge: ``"0.5 mm"`` -> 0.0005 (SI).

The rules, the same in a rig file and on every command line:

* **A plain number is SI.** ``0.5``, ``"0.5"`` and ``"0.5 m"`` are all half a metre; ``60`` is
  60 Hz for a frequency, ``15`` is 15 N for a force, ``1`` is 1 V (peak) for a voltage. Write
  small quantities with their unit (``"0.5 mm"``), never as a bare number in mm.
* **Units and SI prefixes are case-sensitive**, as SI writes them: ``mPa`` is milli, ``MPa`` mega;
  ``mN/m`` milli, ``MN/m`` mega; ``H`` is the henry and ``h`` the hour. A unit in the wrong case
  is refused with a hint (never guessed). Prefixes: p n u µ m c k M G T (``u`` and ``µ``/``μ``
  are both micro).
* **Voltage amplitudes are peak volts.** ``"2 Vpp"`` (peak-to-peak) is 1 V peak wherever an
  amplitude is asked for (``dimension="voltage_amplitude"``, :func:`voltage_amplitude`: the
  [signal_source] and [safety] drive limits, ``--drive``); ``"1 Vpk"`` is 1 V peak. Where a plain
  voltage is asked for (a noise level, a range) ``Vpp`` is refused rather than guessed.
* **Every value is finite**: ``1e400`` (which TOML reads as infinity), ``inf`` and ``nan`` are
  refused.
* Standard gravity is written ``g0`` (``"500 g0"``); ``g`` is the gram, except in a sensitivity
  (``"10 mV/g"``), as sensor sheets write it.

Only the units a vibration lab writes are known (a small explicit table); anything else is
refused with a one-line message naming the unit.
"""

from __future__ import annotations

import math
import numbers
import re

STANDARD_GRAVITY = 9.80665  # m/s^2

# The largest shroud gap accepted anywhere (rig file [contact] gap, every --gap and gap study):
# ten times what the largest lab blade could close, so "--gap 0.5" (0.5 m, a plain number is SI)
# is refused instead of silently simulating a rig that never touches. Up to it, a large gap is the
# way to run the rig linear (no impacts).
MAX_GAP = 0.05  # m
#: N: the largest force amplitude F0 of a run, measured (the procedures' ``le=1000``) or modelled
#: (rig simulate, rigtools.simulate_point): the shaker's range
MAX_FORCE = 1000.0

# SI prefixes, case-sensitive (m milli, M mega; "u" is accepted for micro)
PREFIXES: dict[str, float] = {
    "p": 1e-12,
    "n": 1e-9,
    "u": 1e-6,
    "µ": 1e-6,
    "m": 1e-3,
    "c": 1e-2,
    "k": 1e3,
    "M": 1e6,
    "G": 1e9,
    "T": 1e12,
}

# base symbols that take a prefix: symbol -> (factor to SI, dimension)
_PREFIXABLE: dict[str, tuple[float, str]] = {
    "m": (1.0, "length"),
    "g": (1e-3, "mass"),
    "s": (1.0, "time"),
    "Hz": (1.0, "frequency"),
    "N": (1.0, "force"),
    "Pa": (1.0, "pressure"),
    "V": (1.0, "voltage"),
    "A": (1.0, "current"),
    "Ω": (1.0, "resistance"),
    "ohm": (1.0, "resistance"),
    "H": (1.0, "inductance"),
    "Vpp": (0.5, "voltage_amplitude"),
    "Vpk": (1.0, "voltage_amplitude"),
}


def _prefixed(symbol: str, prefixes: str | tuple[str, ...] | None = None) -> dict[str, float]:
    """``symbol`` with each prefix: text -> factor relative to ``symbol``."""
    out = {symbol: 1.0}
    for p, f in PREFIXES.items():
        if prefixes is None or p in prefixes:
            out[p + symbol] = f
    return out


def _build_table() -> dict[str, tuple[float, str]]:
    table: dict[str, tuple[float, str]] = {}

    def add(text: str, factor: float, dimension: str) -> None:
        if text in table and table[text][1] != dimension:
            raise AssertionError(f"unit {text!r} defined twice")  # a programming error
        table[text] = (factor, dimension)

    for symbol, (factor, dim) in _PREFIXABLE.items():
        for text, f in _prefixed(symbol).items():
            add(text, f * factor, dim)
    add("min", 60.0, "time")
    add("h", 3600.0, "time")
    add("g0", STANDARD_GRAVITY, "acceleration")

    newtons = _prefixed("N", ("m", "k", "M", "G"))
    lengths = _prefixed("m", ("u", "µ", "m", "c"))
    for n, fn in newtons.items():
        for m, fm in lengths.items():
            add(f"{n}/{m}", fn / fm, "stiffness")
        for m, fm in _prefixed("m", ("m",)).items():
            for joint in ("*", ""):
                add(f"{n}{joint}{m}/rad", fn * fm, "rotational_stiffness")
                add(f"{n}{joint}s/{m}", fn / fm, "damping")
    add("kg/s", 1.0, "damping")
    # Hertz / Hunt-Crossley contact laws (f = k g^1.5, damping alpha*k): their own dimensions, so
    # "1e9 N/m^1.5" is refused where a linear stiffness is asked for, and vice versa
    for n, fn in newtons.items():
        for m, fm in lengths.items():
            add(f"{n}/{m}^1.5", fn / fm**1.5, "hertz_stiffness")
            for joint in ("*", ""):
                add(f"{n}{joint}s/{m}^2.5", fn / fm**2.5, "hertz_damping")
    for g, fg in _prefixed("g", ("k",)).items():
        for m, fm in _prefixed("m", ("c", "m")).items():
            for power in ("^2", "2", "²"):
                add(f"{g}*{m}{power}", 1e-3 * fg * fm**2, "inertia")
            for power in ("^3", "3", "³"):
                add(f"{g}/{m}{power}", 1e-3 * fg / fm**3, "density")
    for m, fm in _prefixed("m", ("m",)).items():
        for power in ("^2", "2", "²"):
            add(f"{m}/s{power}", fm, "acceleration")
    add("N/A", 1.0, "force_factor")
    add("V*s/m", 1.0, "force_factor")
    add("Vs/m", 1.0, "force_factor")
    for v, fv in _prefixed("V", ("m",)).items():
        for g in ("g", "g0"):
            add(f"{v}/{g}", fv / STANDARD_GRAVITY, "sensitivity_accel")
        add(f"{v}/(m/s^2)", fv, "sensitivity_accel")
        add(f"{v}/N", fv, "sensitivity_force")
    return table


_UNITS = _build_table()
_FOLDED: dict[str, list[str]] = {}
for _text in _UNITS:
    _FOLDED.setdefault(_text.casefold(), []).append(_text)

# dimension asked for -> dimensions of units it accepts
_ACCEPTS = {"voltage_amplitude": ("voltage_amplitude", "voltage")}

_EXAMPLES = {
    "length": "'0.5 mm'",
    "mass": "'110 g'",
    "time": "'2 s', '50 ms'",
    "frequency": "'60 Hz', '5 kHz'",
    "force": "'15 N'",
    "pressure": "'200 GPa'",
    "density": "'7850 kg/m^3'",
    "stiffness": "'1e6 N/m'",
    "rotational_stiffness": "'1.2e4 N*m/rad'",
    "damping": "'200 N*s/m'",
    "inertia": "'1e-5 kg*m^2'",
    "voltage": "'1 V', '500 mV'",
    "voltage_amplitude": "'1 V' (peak), '2 Vpp'",
    "current": "'4 mA'",
    "resistance": "'2.5 ohm'",
    "inductance": "'0.5 mH'",
    "force_factor": "'10 N/A'",
    "acceleration": "'4900 m/s^2', '500 g0'",
    "hertz_stiffness": "'1e9 N/m^1.5'",
    "hertz_damping": "'2e8 N*s/m^2.5'",
    "sensitivity_accel": "'10 mV/g'",
    "sensitivity_force": "'11.24 mV/N'",
}

_PATTERN = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([^\s].*?)?\s*$")


def _name(dimension: str) -> str:
    words = dimension.replace("_", " ")
    return ("an " if words[0] in "aeiou" else "a ") + words


def units_of(dimension: str) -> list[str]:
    """Every unit text accepted for ``dimension`` (for help texts and tests)."""
    accepted = _ACCEPTS.get(dimension, (dimension,))
    return [text for text, (_, dim) in _UNITS.items() if dim in accepted]


def parse_quantity(value: float | str, dimension: str | None = None) -> float:
    """Convert a number or a quantity string to a finite float in SI units.

    Parameters
    ----------
    value
        A number (taken as SI) or a string such as ``"0.5 mm"``, ``"110 g"``, ``"200 GPa"``; a
        string without a unit is SI too.
    dimension
        If given, the unit must be of this dimension (``"length"``, ``"mass"``, ...;
        ``"voltage_amplitude"`` takes volts as peak and ``Vpp`` as peak-to-peak).

    Returns
    -------
    float
        The value in SI units.

    Raises
    ------
    ValueError
        With a one-line message if the text or the unit is not understood, the unit is of another
        dimension, or the value is not finite.
    """
    if isinstance(value, bool) or type(value).__name__ == "bool_":  # numpy's bool too
        raise ValueError(f"expected a number or a quantity, got {value!r}")
    if isinstance(value, numbers.Real):  # numpy's integers and floats are Real (np.float64(60.0))
        number = float(value)
        if not math.isfinite(number):
            raise ValueError(f"{value!r} is not a finite number")
        return number
    if not isinstance(value, str):
        raise ValueError(f"expected a number or a quantity, got {value!r}")  # noqa: TRY004 - documented
    match = _PATTERN.match(value)
    if not match:
        example = f", e.g. {_EXAMPLES[dimension]}" if dimension in _EXAMPLES else " (e.g. '0.5 mm')"
        raise ValueError(f"cannot read {value!r} as a quantity{example}")
    number, unit = float(match.group(1)), match.group(2)
    if not math.isfinite(number):
        raise ValueError(f"{value!r} is not a finite number")
    if unit is None:
        return number
    # "μ" (Greek mu) / "µ" (micro sign), "Ω" / "Ω" (ohm sign), "·" / "*": same meaning
    text = unit.replace(" ", "").replace("·", "*").replace("μ", "µ").replace("\u2126", "Ω")
    if text not in _UNITS:
        candidates = sorted(_FOLDED.get(text.casefold(), []))
        if dimension is not None:
            fitting = [c for c in candidates if _UNITS[c][1] in _ACCEPTS.get(dimension, (dimension,))]
            candidates = fitting or candidates
        if len(candidates) > 1:
            raise ValueError(
                f"unit {unit!r} in {value!r} is ambiguous: units are case-sensitive, write "
                + " or ".join(repr(c) for c in candidates)
            )
        if candidates:
            raise ValueError(
                f"unknown unit {unit!r} in {value!r}: units are case-sensitive, write {candidates[0]!r}"
            )
        example = f" ({_name(dimension)}, e.g. {_EXAMPLES[dimension]})" if dimension in _EXAMPLES else ""
        if "," in unit:
            raise ValueError(f"one value here, not a list{example}")
        raise ValueError(f"unknown unit {unit!r} in {value!r}{example}")
    factor, dim = _UNITS[text]
    if dimension is not None and dim not in _ACCEPTS.get(dimension, (dimension,)):
        if dim == "voltage_amplitude":
            raise ValueError(
                f"{value!r} is a peak-to-peak or peak amplitude; give a voltage here, e.g. '1 V'"
            )
        raise ValueError(f"{value!r} is {_name(dim)}, expected {_name(dimension)}")
    result = number * factor
    if not math.isfinite(result):
        raise ValueError(f"{value!r} is not a finite number")
    return result


def voltage_amplitude(value: float | str) -> float:
    """A voltage amplitude in peak volts: ``"1 V"`` and ``1`` are 1 V peak, ``"2 Vpp"`` is 1 V peak.

    Raises
    ------
    ValueError
        One line, as :func:`parse_quantity`.
    """
    return parse_quantity(value, "voltage_amplitude")
