"""Units of the shaker section (resistance, inductance, force factor) and small forces/voltages,
against their SI definitions; the [shaker] section reads them with their dimension checked."""

import pytest

from rigtools.config import load_rig, parse_rig
from rigtools.errors import ConfigError
from rigtools.units import parse_quantity


@pytest.mark.parametrize(
    "text, dimension, si",
    [
        ("2.5 ohm", "resistance", 2.5),
        ("2.5 Ω", "resistance", 2.5),  # U+03A9 Greek capital omega
        ("2.5 \u2126", "resistance", 2.5),  # U+2126 ohm sign
        ("1 H", "inductance", 1.0),
        ("0.5 mH", "inductance", 5e-4),
        ("500 uH", "inductance", 5e-4),
        ("500 µH", "inductance", 5e-4),  # micro sign
        ("500 μH", "inductance", 5e-4),  # Greek mu
        ("10 N/A", "force_factor", 10.0),
        ("5 mN", "force", 5e-3),
        ("20 uV", "voltage", 20e-6),
        ("20 µV", "voltage", 20e-6),
    ],
)
def test_units(text, dimension, si):
    assert parse_quantity(text, dimension) == pytest.approx(si, rel=1e-15)


def test_wrong_dimension_is_refused():
    with pytest.raises(ValueError, match="is an inductance, expected a resistance"):
        parse_quantity("2 mH", "resistance")


def test_shaker_section_takes_quantities():
    cfg = load_rig()
    assert (cfg.shaker.force_factor, cfg.shaker.coil_resistance, cfg.shaker.coil_inductance) == (
        10.0,
        2.5,
        5e-4,
    )
    data = {
        "blade": {
            "length": 0.155,
            "width": 0.04,
            "thickness": 0.0032,
            "youngs_modulus": 2e11,
            "density": 7850,
        },
        "shroud": {"mass": 0.11},
        "force_sensor": {"mass": 0.066, "position": 0.085},
        "contact": {"gap": 5e-4, "stiffness": 1e6},
        "shaker": {"coil_inductance": "250 µH", "coil_resistance": "4 Ω", "force_factor": "12 N/A"},
    }
    shaker = parse_rig(data).shaker
    assert (shaker.coil_inductance, shaker.coil_resistance, shaker.force_factor) == (
        pytest.approx(2.5e-4),
        4.0,
        12.0,
    )
    data["shaker"] = {"coil_resistance": "4 mH"}
    with pytest.raises(ConfigError, match="shaker.coil_resistance = '4 mH'"):
        parse_rig(data)
