"""Units without traps: every SI prefix in both cases, one rule for plain numbers, Vpp versus peak,
non-finite values refused. References are the SI definitions (exact factors)."""

import math

import pytest

from rigtools.units import PREFIXES, parse_quantity, units_of, voltage_amplitude

# SI prefix factors by definition (the reference the table is checked against)
SI = {
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
BASES = [
    ("Pa", "pressure", 1.0),
    ("N", "force", 1.0),
    ("m", "length", 1.0),
    ("Hz", "frequency", 1.0),
    ("V", "voltage", 1.0),
    ("A", "current", 1.0),
    ("H", "inductance", 1.0),
    ("s", "time", 1.0),
    ("g", "mass", 1e-3),
    ("ohm", "resistance", 1.0),
]


def test_prefix_table_is_the_si_table():
    assert PREFIXES == SI


@pytest.mark.parametrize("base, dimension, factor", BASES)
@pytest.mark.parametrize("prefix", list(SI))
def test_every_prefix_in_its_own_case(prefix, base, dimension, factor):
    assert parse_quantity(f"3 {prefix}{base}", dimension) == pytest.approx(3 * SI[prefix] * factor, rel=1e-14)


@pytest.mark.parametrize("base, dimension, factor", BASES)
@pytest.mark.parametrize("prefix", list(SI))
def test_every_prefix_in_the_other_case(prefix, base, dimension, factor):
    """The other case is either another SI prefix (m/M) with its own factor, or refused, never
    folded to the prefix as written."""
    other = prefix.swapcase()
    if other == prefix:
        pytest.skip("no case")
    text = f"3 {other}{base}"
    if other in SI:
        assert parse_quantity(text, dimension) == pytest.approx(3 * SI[other] * factor, rel=1e-14)
    else:
        with pytest.raises(ValueError) as info:
            parse_quantity(text, dimension)
        message = str(info.value)
        assert repr(text) in message and "\n" not in message


@pytest.mark.parametrize(
    "text, si",
    [
        ("1 mPa", 1e-3),
        ("1 MPa", 1e6),
        ("2 mN", 2e-3),
        ("2 MN", 2e6),
        ("2 mN/m", 2e-3),
        ("2 MN/m", 2e6),
        ("1 mV", 1e-3),
        ("1 MV", 1e6),
        ("1 ms", 1e-3),
        ("1 Ms", 1e6),
        ("1 mHz", 1e-3),
        ("1 MHz", 1e6),
        ("1 mm", 1e-3),
        ("1 Mm", 1e6),
        ("1 kN/mm", 1e6),
        ("1 N/µm", 1e6),
        ("1 N/um", 1e6),
        ("1 mH", 1e-3),
        ("1 h", 3600.0),
        ("1 min", 60.0),
        ("1 kg", 1.0),
        ("1 Mg", 1e3),
        ("2 kN*m/rad", 2e3),
        ("2 N·m/rad", 2.0),
        ("3 N*s/m", 3.0),
        ("3 kg/s", 3.0),
        ("1 g/cm^3", 1e3),
        ("1 g*cm^2", 1e-7),
        ("1 kg*mm^2", 1e-6),
        ("1 mm/s^2", 1e-3),
        ("1 g0", 9.80665),
        ("10 mV/g", 1e-2 / 9.80665),
        ("10 mV/N", 1e-2),
        ("1 kΩ", 1e3),
        ("1 MΩ", 1e6),
        ("1 m\u2126", 1e-3),
    ],
)
def test_case_carries_the_prefix_in_compound_units(text, si):
    assert parse_quantity(text) == pytest.approx(si, rel=1e-14)


@pytest.mark.parametrize(
    "text, hint",
    [
        ("2 mn/m", "ambiguous: units are case-sensitive, write 'MN/m' or 'mN/m'"),
        ("60 hz", "write 'Hz'"),
        ("5 KHZ", "write 'kHz'"),
        ("1 mpa", "write 'MPa' or 'mPa'"),
        ("1 gpa", "write 'GPa'"),
        ("2 nm/rad", "write 'Nm/rad'"),
        ("0.5 mh", "write 'MH' or 'mH'"),
    ],
)
def test_wrong_case_is_refused_with_a_hint_never_guessed(text, hint):
    with pytest.raises(ValueError) as info:
        parse_quantity(text)
    assert hint in str(info.value) and repr(text) in str(info.value)


@pytest.mark.parametrize(
    "value, dimension, si",
    [
        (0.5, "length", 0.5),
        ("0.5", "length", 0.5),
        ("0.5 m", "length", 0.5),
        (60, "frequency", 60.0),
        ("60", "frequency", 60.0),
        (15, "force", 15.0),
        ("1", "voltage_amplitude", 1.0),
        (3, None, 3.0),
    ],
)
def test_a_plain_number_is_si(value, dimension, si):
    assert parse_quantity(value, dimension) == si


@pytest.mark.parametrize(
    "value", [math.inf, -math.inf, math.nan, "1e400", "1e400 mm", "-1e400 N", "1e300 TPa"]
)
def test_non_finite_is_refused(value):
    with pytest.raises(ValueError, match="not a finite number"):
        parse_quantity(value, "length" if "mm" in str(value) else None)


@pytest.mark.parametrize(
    "text, peak",
    [
        ("2 Vpp", 1.0),
        ("1 V", 1.0),
        (1, 1.0),
        ("1", 1.0),
        ("500 mV", 0.5),
        ("1 Vpk", 1.0),
        ("20 mVpp", 0.01),
        ("3 kVpp", 1500.0),
    ],
)
def test_voltage_amplitude_is_peak(text, peak):
    assert voltage_amplitude(text) == pytest.approx(peak, rel=1e-14)


def test_vpp_is_refused_where_a_plain_voltage_is_asked():
    with pytest.raises(ValueError, match="peak-to-peak"):
        parse_quantity("2 Vpp", "voltage")


def test_units_of_lists_accepted_units():
    assert {"V", "mV", "Vpp", "mVpp"} <= set(units_of("voltage_amplitude"))
    assert "Vpp" not in units_of("voltage")
    assert {"mm", "m", "um", "µm"} <= set(units_of("length"))


@pytest.mark.parametrize("value", [True, None, [1], "mm", "", "1 2 mm", "one mm"])
def test_not_a_quantity(value):
    with pytest.raises(ValueError):
        parse_quantity(value)
