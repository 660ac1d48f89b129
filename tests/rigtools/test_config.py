"""Rig file validation: defaults, unit strings, and one clear line for each kind of bad input."""

import copy
import tomllib

import pytest

from rigtools.config import default_rig_text, load_rig, parse_rig
from rigtools.errors import ConfigError
from rigtools.units import parse_quantity


def _default() -> dict:
    return tomllib.loads(default_rig_text())


def test_default_rig_loads_in_si_units():
    rig = load_rig()
    params = rig.to_params()
    assert params.active.length == pytest.approx(parse_quantity(_default()["blade"]["length"]))
    assert 0 < params.force_sensor.position < params.active.length
    assert params.shroud.position == params.active.length


@pytest.mark.parametrize(
    "text, si",
    [
        ("0.5 mm", 5e-4),
        ("110 g", 0.11),
        ("200 GPa", 2e11),
        ("7.85 g/cm^3", 7850.0),
        (3, 3.0),
        ("1e6 N/m", 1e6),
    ],
)
def test_quantity_strings(text, si):
    assert parse_quantity(text) == pytest.approx(si, rel=1e-12)


def test_quantity_wrong_dimension():
    with pytest.raises(ValueError, match="expected a length"):
        parse_quantity("3 g", "length")


def test_passive_blade_overrides_only_given_keys():
    data = _default()
    data["passive_blade"] = {"length": "150 mm"}
    params = parse_rig(data).to_params()
    assert params.passive.length == pytest.approx(0.15)
    assert params.passive.thickness == params.active.thickness


@pytest.mark.parametrize(
    "edit, expected",
    [
        (lambda d: d["blade"].update(colour="red"), "unknown key 'blade.colour'"),
        (lambda d: d["blade"].update(thickness="-3 mm"), "blade.thickness = '-3 mm'"),
        (lambda d: d["force_sensor"].update(position="250 mm"), "beyond the blade"),
        (lambda d: d.pop("contact"), "missing key 'contact'"),
        (lambda d: d["root"].update(kind="glued"), "root.kind"),
    ],
)
def test_bad_rig_is_one_clear_line(edit, expected):
    data = copy.deepcopy(_default())
    edit(data)
    with pytest.raises(ConfigError) as info:
        parse_rig(data)
    message = str(info.value)
    assert expected in message
    assert "\n" not in message


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="cannot read rig file"):
        load_rig(tmp_path / "nope.toml")


@pytest.mark.parametrize("text, si", [("2 mN", 2e-3), ("2 MN/m", 2e6), ("3 mN/m", 3e-3), ("1 MPa", 1e6)])
def test_milli_and_mega_prefixes_keep_their_case(text, si):
    assert parse_quantity(text) == pytest.approx(si, rel=1e-12)


def test_prefix_in_the_wrong_case_is_refused_not_guessed():
    with pytest.raises(ValueError, match="ambiguous"):
        parse_quantity("2 mn/m")
