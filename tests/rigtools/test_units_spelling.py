"""The unit spelling must not change the SI value (issue 29, item 7).

Two homes read units: :func:`rigtools.units.parse_quantity` (config, CLI, the front door: a
quantity string, case-sensitive prefixes) and :func:`rigtools.interop.channels.si_units` (the
units a foreign file declares for a channel, or ``--units``). Property-based tests (hypothesis)
write one value in each accepted spelling and assert the same SI value; the two homes agree on
every unit both read with the same meaning; and a prefix whose case changes its meaning (m milli,
M mega) is never read in the other case.
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rigtools.interop.channels import UNITS, si_units
from rigtools.units import PREFIXES, parse_quantity, units_of

FAST = settings(max_examples=40, deadline=None)

# values a user writes: positive and negative, 1e-9 .. 1e9 in magnitude
values = st.floats(min_value=1e-9, max_value=1e9, allow_nan=False, allow_infinity=False) | st.floats(
    min_value=-1e9, max_value=-1e-9
)

# 1 ulp of the value written as a decimal in another prefix, times the factor: a few ulps at most
ROUND_OFF = 1e-14

LENGTH_PREFIXES = {"": 1.0, "m": 1e-3, "u": 1e-6, "µ": 1e-6, "μ": 1e-6, "c": 1e-2, "n": 1e-9, "k": 1e3}


@FAST
@given(value=values, prefix=st.sampled_from(sorted(LENGTH_PREFIXES)), space=st.sampled_from(["", " ", "  "]))
def test_a_length_in_any_prefix_and_spacing_is_the_same_si_value(value, prefix, space):
    """``value`` m written as ``value / f`` in the prefixed unit (``0.0005 m`` = ``0.5 mm`` =
    ``500 um`` = ``500 µm`` = ``500 μm``), with or without spaces: the same SI value within
    round-off (1e-14 relative: the decimal written and the factor each round once)."""
    text = f"{value / LENGTH_PREFIXES[prefix]!r}{space}{prefix}m"
    assert parse_quantity(text, "length") == pytest.approx(value, rel=ROUND_OFF)
    assert parse_quantity(f"  {text}  ", "length") == pytest.approx(value, rel=ROUND_OFF)


def test_the_issue_example_half_a_millimetre():
    """The example of the issue, exactly: "0.5 mm", "500 um", "500 µm", "0.0005 m", "5e-4 m"."""
    for text in ("0.5 mm", "500 um", "500 µm", "500 μm", "0.0005 m", "5e-4 m", "0.05 cm", "0.5mm"):
        assert parse_quantity(text, "length") == pytest.approx(5e-4, rel=ROUND_OFF), text


@FAST
@given(value=values, spelling=st.sampled_from(["m/s^2", "m/s2", "m/s²", "mm/s^2", "mm/s2", "mm/s²", "g0"]))
def test_an_acceleration_in_any_spelling_is_the_same_si_value(value, spelling):
    """m/s^2 = m/s2 = m/s² (the toolkit prints m/s²: a value copied from its output reads back);
    mm/s^2 = 1e-3 of it; g0 = 9.80665 m/s^2 (standard gravity)."""
    factor = {
        "m/s^2": 1.0,
        "m/s2": 1.0,
        "m/s²": 1.0,
        "mm/s^2": 1e-3,
        "mm/s2": 1e-3,
        "mm/s²": 1e-3,
        "g0": 9.80665,
    }[spelling]
    assert parse_quantity(f"{value / factor!r} {spelling}", "acceleration") == pytest.approx(
        value, rel=ROUND_OFF
    )


@FAST
@given(value=values, spelling=st.sampled_from(["N*s/m", "Ns/m", "N·s/m", "N s/m", "N * s / m", "kg/s"]))
def test_a_product_unit_in_any_spelling_is_the_same_si_value(value, spelling):
    """A damping written with ``*``, ``·``, a space or nothing between N and s, or as kg/s."""
    assert parse_quantity(f"{value!r} {spelling}", "damping") == pytest.approx(value, rel=ROUND_OFF)


@FAST
@given(value=values, prefix=st.sampled_from(sorted(PREFIXES)))
def test_every_prefix_of_a_force_is_its_factor(value, prefix):
    """``x kN`` = 1e3 x N, ``x mN`` = 1e-3 x N, ``x MN`` = 1e6 x N: the case of m/M decides."""
    assert parse_quantity(f"{value!r} {prefix}N", "force") == pytest.approx(
        value * PREFIXES[prefix], rel=ROUND_OFF
    )


# -- the units a file declares (rig import) ---------------------------------------------------------
SPELLINGS = [
    # (spellings of one unit a file may declare, SI units, factor)
    (
        ["m/s^2", "m/s2", "m/s²", "M/S^2", " m/s^2 ", "m / s^2", "meterspersecondsquared", "m/s/s"],
        "m/s^2",
        1.0,
    ),
    (["g", "G", "g0", "gn", "g's", "Gs"], "m/s^2", 9.80665),
    (["mm/s^2", "mm/s2"], "m/s^2", 1e-3),
    (["um", "µm", "μm", "micron", "UM"], "m", 1e-6),
    (["mm"], "m", 1e-3),
    (["N", "n", "Newton", "newtons", "NEWTONS"], "N", 1.0),
    (["kN", "KN", "kn"], "N", 1e3),
    (["mV", "millivolts", "MILLIVOLTS"], "V", 1e-3),
    (["MPa"], "Pa", 1e6),
    (["°C", "degC", "deg C", "celsius", "℃"], "K", 1.0),
]


@pytest.mark.parametrize(
    ("spellings", "units", "factor"), SPELLINGS, ids=[s[1] + "-" + s[0][0] for s in SPELLINGS]
)
def test_a_declared_unit_in_any_spelling_converts_alike(spellings, units, factor):
    """Every spelling of one unit that a file may declare (case, spaces, ², long names) reads as
    the same SI units and factor: the samples of a channel do not depend on how the file spells
    its units."""
    for text in spellings:
        si = si_units(text)
        assert si is not None, text
        assert (si.units, si.factor) == (units, factor), text


@pytest.mark.parametrize(
    ("text", "meaning"),
    [
        ("MV", "megavolt"),
        ("MA", "megaampere"),
        ("Mm", "megametre"),
        ("mPa", "millipascal"),
        ("MM/S^2", "Mm/s^2"),
    ],
)
def test_a_prefix_whose_case_matters_is_never_read_in_the_other_case(text, meaning):
    """``MV`` is not millivolt and ``mPa`` not megapascal (they were: 10^9 off, without a word);
    the file's label is refused as unknown (the channel skipped, ``--units`` says what it is)."""
    assert si_units(text) is None, meaning


def test_the_two_unit_homes_agree_on_every_unit_both_read():
    """Every unit the import table holds that ``parse_quantity`` also reads (in the import's
    spelling or with a capital first letter) with the same dimension has the same SI factor there:
    a quantity typed on the command line and a channel label of the same text mean the same."""
    same_dimension = {
        "displacement": "length",
        "acceleration": "acceleration",
        "force": "force",
        "voltage": "voltage",
        "current": "current",
        "pressure": "pressure",
        "frequency": "frequency",
        "time": "time",
        "velocity": "velocity",
    }
    compared = 0
    for key in UNITS:
        for text in {key, key.capitalize(), key.upper(), key[:1].upper() + key[1:]}:
            si = si_units(text)
            dimension = same_dimension.get(si.quantity) if si is not None else None
            if dimension is None or text not in units_of(dimension):
                continue
            assert parse_quantity(f"1 {text}", dimension) == pytest.approx(si.factor, rel=1e-15), text
            compared += 1
    assert compared >= 15  # N, kN, m, mm, um, m/s^2, mm/s^2, V, mV, A, mA, Pa, kPa, MPa, Hz, s, ...
