"""Bad rig files, one class at a time: every value bounded and finite, rig files that are not UTF-8
TOML, channel names a recording cannot store, gaps no blade could close. Each case asserts one
line (a ConfigError) naming the key and the value as written."""

import copy
import math
import tomllib

import h5py
import numpy as np
import pytest

from rigtools.config import (
    MAX_CONTACT_DAMPING_RATIO,
    RigConfig,
    ShakerConfig,
    default_rig_text,
    load_rig,
    parse_rig,
)
from rigtools.drivers.shaker import ShakerParams
from rigtools.errors import ConfigError, UserError
from rigtools.options import gap as gap_option
from rigtools.sim.params import SimulationInputError
from rigtools.sim.shaker_params import SHAKER_BOUNDS
from rigtools.sim.vibro_impact import ShakerCoupling
from rigtools.units import MAX_GAP

DEFAULT = tomllib.loads(default_rig_text())


def _one_line(data: dict) -> str:
    with pytest.raises(ConfigError) as info:
        parse_rig(data)
    message = str(info.value)
    assert "\n" not in message and "Traceback" not in message
    return message


def _edited(section: str, **values) -> dict:
    data = copy.deepcopy(DEFAULT)
    data.setdefault(section, {}).update(values)
    return data


# ------------------------------------------------------------------ [passive_blade] bounds
@pytest.mark.parametrize(
    "key, value",
    [
        ("length", "-1 mm"),
        ("length", "0.1 mm"),
        ("length", "10 m"),
        ("width", 0),
        ("width", "2 m"),
        ("thickness", "0 mm"),
        ("thickness", "1 m"),
        ("youngs_modulus", "1 kPa"),
        ("youngs_modulus", "1e14 Pa"),
        ("density", 1.0),
        ("density", "1e6 kg/m^3"),
        ("poisson", 0.5),
        ("poisson", -0.1),
        ("elements", 1),
        ("elements", 100000),
        ("theory", "rubber"),
        ("length", "3 g"),
    ],
)
def test_passive_blade_values_are_bounded(key, value):
    message = _one_line(_edited("passive_blade", **{key: value}))
    assert f"passive_blade.{key} = {value!r}" in message


@pytest.mark.parametrize(
    "key", ["length", "width", "thickness", "youngs_modulus", "density", "poisson", "elements"]
)
def test_passive_blade_has_the_same_ranges_as_blade(key):
    """A value refused in [blade] is refused in [passive_blade] with the same range text."""
    bad = {
        "length": "10 m",
        "width": "2 m",
        "thickness": "1 m",
        "youngs_modulus": "1e14 Pa",
        "density": 1.0,
        "poisson": 0.6,
        "elements": 1,
    }[key]
    active = _one_line(_edited("blade", **{key: bad})).split(": ", 2)[-1]
    passive = _one_line(_edited("passive_blade", **{key: bad})).split(": ", 2)[-1]
    assert active == passive


def test_range_message_states_range_and_si_value():
    message = _one_line(_edited("passive_blade", thickness="0 mm"))
    assert message.endswith(
        "passive_blade.thickness = '0 mm': outside the allowed range [1e-05, 0.5] m (= 0 m)"
    )


# ------------------------------------------------------------------ non-finite numbers
NON_FINITE_TOML = [
    ("blade", "length", "1e400"),  # TOML reads 1e400 as inf
    ("blade", "youngs_modulus", "inf"),
    ("blade", "poisson", "nan"),
    ("passive_blade", "density", "-inf"),
    ("damping", "alpha", "inf"),
    ("contact", "damping", "nan"),
    ("contact", "stiffness", '"1e400 N/m"'),
    ("root", "rotational_stiffness", "inf"),
    ("shroud", "mass", "nan"),
    ("shaker", "force_factor", "inf"),
    ("shaker", "amplifier_gain", "nan"),
    ("test_article", "force_noise", "inf"),
    ("test_article", "damping_ratio", "nan"),
    ("daq", "sample_rate", "inf"),
    ("safety", "max_drive", "inf"),
    ("signal_source", "max_amplitude", '"1e400 Vpp"'),
]


@pytest.mark.parametrize("section, key, toml_value", NON_FINITE_TOML)
def test_non_finite_values_are_refused(tmp_path, section, key, toml_value):
    data = copy.deepcopy(DEFAULT)
    data.setdefault(section, {})
    text = default_rig_text()
    # append/replace the key in its table as TOML text, so the file path is what a user would hit
    lines, out, in_section, done = text.splitlines(), [], False, False
    for line in lines:
        stripped = line.strip()
        if stripped.startswith("["):
            if in_section and not done:
                out.append(f"{key} = {toml_value}")
                done = True
            in_section = stripped.split("#")[0].strip() == f"[{section}]"
        if in_section and stripped.split("=")[0].strip() == key:
            continue
        out.append(line)
    if not done:
        if not in_section:
            out.append(f"[{section}]")
        out.append(f"{key} = {toml_value}")
    if section == "damping" and key == "alpha":
        out = [ln for ln in out if not ln.startswith("ratio")]
    if section == "root":
        out = [ln.replace('kind = "clamped"', 'kind = "springs"') for ln in out]
    path = tmp_path / "rig.toml"
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_rig(path)
    message = str(info.value)
    assert "\n" not in message
    assert f"{section}.{key} = " in message
    assert "finite" in message


# ------------------------------------------------------------------ absurd values
@pytest.mark.parametrize(
    "section, values, expected",
    [
        (
            "root",
            {"kind": "springs", "rotational_stiffness": 1e12, "translational_stiffness": 1e8},
            "root.rotational_stiffness = 1000000000000.0: outside the allowed range [0, 1e+07] N*m/rad",
        ),
        (
            "root",
            {"kind": "springs", "rotational_stiffness": 1e4, "translational_stiffness": "1e16 N/m"},
            "root.translational_stiffness = '1e16 N/m'",
        ),
        (
            "test_article",
            {"root_rotational_stiffness": "1e15 N*m/rad"},
            "test_article.root_rotational_stiffness",
        ),
        ("contact", {"damping": "1e5 N*s/m"}, "contact.damping = 100000 N*s/m: at most 2 x the critical"),
        (
            "contact",
            {"gap": 0.5},
            "contact.gap = 0.5: outside the allowed range [0, 0.05] m (a plain number is in m",
        ),
        ("contact", {"gap": "60 mm"}, "contact.gap = '60 mm'"),
        ("contact", {"stiffness": "1e13 N/m"}, "contact.stiffness = '1e13 N/m'"),
        ("damping", {"ratio": None, "alpha": 1e6}, "damping.alpha = 1000000.0"),
        ("damping", {"beta": 1.0, "ratio": None}, "damping.beta = 1.0"),
        ("shroud", {"mass": "100 kg"}, "shroud.mass = '100 kg'"),
        ("blade", {"youngs_modulus": "1e14 Pa"}, "blade.youngs_modulus = '1e14 Pa'"),
        (
            "signal_source",
            {"max_amplitude": "30 Vpp"},
            "signal_source.max_amplitude = '30 Vpp': outside the allowed range (0, 10] V peak (= 15 V peak)",
        ),
        ("shaker", {"armature_mass": "20 kg"}, "shaker.armature_mass = '20 kg'"),
        ("shaker", {"coil_resistance": 0}, "shaker.coil_resistance = 0"),
    ],
)
def test_absurd_values_are_refused(section, values, expected):
    data = copy.deepcopy(DEFAULT)
    table = data.setdefault(section, {})
    for k, v in values.items():
        if v is None:
            table.pop(k, None)
        else:
            table[k] = v
    assert expected in _one_line(data)


def test_contact_damping_limit_is_relative_to_critical():
    """2 x critical of the shroud on the contact spring: accepted at the limit, refused just above."""
    k, m = 1e6, parse_rig(DEFAULT).shroud.mass
    limit = MAX_CONTACT_DAMPING_RATIO * 2.0 * math.sqrt(k * m)
    assert limit == pytest.approx(4.0 * math.sqrt(0.11e6), rel=1e-12)  # 1326.6 N*s/m
    assert parse_rig(_edited("contact", damping=limit * (1 - 1e-9))).contact.damping < limit
    _one_line(_edited("contact", damping=limit * (1 + 1e-9)))


# ------------------------------------------------------------------ one maximum gap
def test_gap_maximum_is_shared_by_config_and_cli():
    assert parse_rig(_edited("contact", gap=MAX_GAP)).contact.gap == MAX_GAP
    assert gap_option(f"{MAX_GAP * 1e3:g} mm") == pytest.approx(MAX_GAP, rel=1e-12)
    too_far = MAX_GAP * 1.001
    _one_line(_edited("contact", gap=too_far))
    with pytest.raises(UserError, match=r"--gap = .*between 0 and 50 mm"):
        gap_option(repr(too_far))


# ------------------------------------------------------------------ channel names
@pytest.mark.parametrize(
    "name, why",
    [
        ("drive", "reserved"),
        ("Drive", "reserved"),
        ("bad name", "cannot store"),
        (".hidden", "cannot store"),
        ("-x", "cannot store"),
        ("a/b", "cannot store"),
        ("schwingung_ä", "cannot store"),
        ("", "cannot store"),
        ("tab\there", "cannot store"),
    ],
)
def test_channel_names_the_recording_cannot_store_are_refused(name, why):
    data = copy.deepcopy(DEFAULT)
    channels = data["daq"]["channels"]
    channels[name] = {"physical_channel": "Dev1/ai5", "kind": "voltage", "sensitivity": 1.0, "range": "10 V"}
    message = _one_line(data)
    assert f"channel name {name!r}" in message and why in message


def test_storable_channel_names_are_accepted():
    data = copy.deepcopy(DEFAULT)
    data["daq"]["channels"]["mic_1.left-side"] = {
        "physical_channel": "Dev1/ai5",
        "kind": "voltage",
        "sensitivity": 1.0,
        "range": "10 V",
    }
    assert "mic_1.left-side" in parse_rig(data).daq.channels


# ------------------------------------------------------------------ files that are not UTF-8 TOML
def _write_hdf5(path):
    with h5py.File(path, "w") as f:
        f["x"] = np.arange(3.0)


@pytest.mark.parametrize(
    "case, expected",
    [
        ("latin1", "is not UTF-8 text (byte 0xe9 on line 1)"),
        ("utf16", "is UTF-16 text; save it as UTF-8"),
        ("bom", "starts with a byte-order mark"),
        ("hdf5", "is an HDF5 file (a recording?)"),
        ("directory", "is a directory"),
        ("missing", "cannot read rig file"),
        ("empty", "is empty"),
        ("blank", "is empty"),
        ("binary", "is a binary file"),
        ("not_toml", "is not valid TOML"),
        ("huge", "is larger than 1000 kB"),
    ],
)
def test_rig_files_that_are_not_utf8_toml(tmp_path, case, expected):
    path = tmp_path / "rig.toml"
    text = default_rig_text()
    if case == "latin1":
        path.write_bytes('name = "Prüfstand é"\n'.encode("latin-1").replace(b"\xfc", b"\xe9"))
    elif case == "utf16":
        path.write_bytes(text.encode("utf-16"))
    elif case == "bom":
        path.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    elif case == "hdf5":
        _write_hdf5(path)
    elif case == "directory":
        path.mkdir()
    elif case == "empty":
        path.write_bytes(b"")
    elif case == "blank":
        path.write_text("\n  \n", encoding="utf-8")
    elif case == "binary":
        path.write_bytes(b"name = \x00\x01\x02")
    elif case == "not_toml":
        path.write_text("[blade\nlength = 3", encoding="utf-8")
    elif case == "huge":
        path.write_text("# " + "x" * 1_100_000, encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_rig(path)
    message = str(info.value)
    assert expected in message and "\n" not in message
    if case != "missing":
        assert str(path) in message


def test_utf8_rig_file_with_non_ascii_text_loads(tmp_path):
    path = tmp_path / "rig.toml"
    path.write_text(
        default_rig_text().replace('name = "default steel rig"', 'name = "Prüfstand µ"'), encoding="utf-8"
    )
    assert load_rig(path).name == "Prüfstand µ"


# ------------------------------------------------------------------ the shaker, defined once
def test_shaker_defaults_and_ranges_come_from_one_place():
    assert list(ShakerConfig.model_fields) == list(SHAKER_BOUNDS)
    params = ShakerParams()
    for name, bound in SHAKER_BOUNDS.items():
        assert ShakerConfig.model_fields[name].default == bound.default == getattr(params, name)
    assert RigConfig.model_validate(DEFAULT).shaker.to_params() == ShakerParams(
        armature_mass=0.1,
        suspension_stiffness=2e4,
        suspension_damping=5.0,
        force_factor=10.0,
        coil_resistance=2.5,
        coil_inductance=5e-4,
        amplifier_gain=4.0,
    )


@pytest.mark.parametrize("name", list(SHAKER_BOUNDS))
@pytest.mark.parametrize("where", ["low", "high", "inf"])
def test_shaker_bounds_hold_in_config_and_params(name, where):
    bound = SHAKER_BOUNDS[name]
    value = {"low": bound.low - (0.0 if bound.low_open else 1.0), "high": bound.high * 2.0, "inf": math.inf}[
        where
    ]
    message = _one_line(_edited("shaker", **{name: value}))
    assert f"shaker.{name} = {value!r}" in message
    with pytest.raises(ValueError, match=f"shaker.{name} = "):
        ShakerParams(**{name: value})
    if name != "amplifier_gain":  # the model's coupling holds the same bounds (no amplifier in it)
        with pytest.raises(SimulationInputError, match=f"shaker.{name} = "):
            ShakerCoupling(
                **{**{n: b.default for n, b in SHAKER_BOUNDS.items() if n != "amplifier_gain"}, name: value}
            )
    # the edges themselves are accepted by both
    edge = bound.high if where == "high" else (bound.low if not bound.low_open else bound.low + 1e-9)
    assert getattr(parse_rig(_edited("shaker", **{name: edge})).shaker.to_params(), name) == edge


def test_a_shaker_without_force_factor_is_refused_everywhere():
    """force_factor = 0 was accepted by the model's coupling and refused by the rig file: one bound now."""
    with pytest.raises(SimulationInputError, match="shaker.force_factor = 0.0"):
        ShakerCoupling(
            **{
                **{n: b.default for n, b in SHAKER_BOUNDS.items() if n != "amplifier_gain"},
                "force_factor": 0.0,
            }
        )
    with pytest.raises(ValueError, match="shaker.force_factor = 0.0"):
        ShakerParams(force_factor=0.0)


def test_shaker_coupling_is_built_from_the_params():
    coupling = ShakerParams(armature_mass=0.2).coupling()
    assert (
        coupling.armature_mass == 0.2 and coupling.coil_resistance == SHAKER_BOUNDS["coil_resistance"].default
    )


@pytest.mark.parametrize(
    "path, value",
    [
        ("daq.channels.force.sensitivity", math.inf),
        ("daq.channels.force.range", math.nan),
        ("daq.channels.active_shroud_accel.range", "1e400 m/s^2"),
        ("safety.limits.force.warning", math.inf),
        ("safety.limits.drive.abort", math.nan),
        ("daq.block_duration", "1e400 s"),
        ("blade.elements", math.inf),
        ("force_sensor.position", -math.inf),
        ("shroud.rotary_inertia", math.nan),
        ("daq.channels.force.excitation_current", math.inf),
    ],
)
def test_non_finite_values_in_nested_tables_name_the_key(path, value):
    data = copy.deepcopy(DEFAULT)
    *head, last = path.split(".")
    table = data
    for part in head:
        table = table[part]
    table[last] = value
    message = _one_line(data)
    assert f"{path} = {value!r}" in message and "finite number" in message and "(and" not in message


def test_root_springs_at_their_limits_still_model_a_clamp():
    """The largest root springs accepted give the clamped rig's natural frequencies (the reference:
    the clamped model) within 0.01 %: the limits sit inside the range the model handles."""
    from rigtools.config import MAX_ROOT_ROTATIONAL_STIFFNESS, MAX_ROOT_TRANSLATIONAL_STIFFNESS
    from rigtools.sim.reduction import reduced_system

    clamped = parse_rig(DEFAULT)
    springs = parse_rig(
        _edited(
            "root",
            kind="springs",
            rotational_stiffness=MAX_ROOT_ROTATIONAL_STIFFNESS,
            translational_stiffness=MAX_ROOT_TRANSLATIONAL_STIFFNESS,
        )
    )
    f_clamped = np.sort(reduced_system(clamped.to_params(), "fem").frequencies_hz)[:4]
    f_springs = np.sort(reduced_system(springs.to_params(), "fem").frequencies_hz)[:4]
    assert f_clamped[0] == pytest.approx(53.2, abs=0.05)
    np.testing.assert_allclose(f_springs, f_clamped, rtol=1e-4)
