"""[daq] and [safety] of the rig file: ranges and limits in their channel's units, IEPE excitation
only where a sensor needs it, every terminal used once. References: the SI definitions
(1 g0 = 9.80665 m/s^2 exactly, 1 mA = 1e-3 A); exact equality up to float rounding (rel 1e-12)."""

import copy
import tomllib

import pytest

from rigtools.config import default_rig_text, parse_rig
from rigtools.errors import ConfigError


def _rig(edit) -> dict:
    data = copy.deepcopy(tomllib.loads(default_rig_text()))
    edit(data)
    return data


def _monitor(**extra) -> dict:
    return {"physical_channel": "Dev1/ai3", "kind": "voltage", "sensitivity": 0.1, "range": "5 V", **extra}


def test_ranges_and_limits_take_their_channels_units():
    def edit(d):
        d["daq"]["channels"]["active_shroud_accel"]["range"] = "500 g0"
        d["daq"]["channels"]["force"]["excitation_current"] = "2 mA"
        d["safety"]["limits"]["active_shroud_accel"] = {"warning": "250 g0", "abort": "400 g0"}
        d["safety"]["limits"]["force"] = {"warning": "40 N", "abort": 60}  # plain number: SI

    cfg = parse_rig(_rig(edit))
    assert cfg.daq.channels["active_shroud_accel"].range == pytest.approx(500 * 9.80665, rel=1e-12)
    assert cfg.daq.channels["force"].excitation_current == pytest.approx(2e-3, rel=1e-12)
    assert cfg.safety.limits["active_shroud_accel"].abort == pytest.approx(400 * 9.80665, rel=1e-12)
    assert cfg.safety.limits["force"].abort == 60.0


@pytest.mark.parametrize(
    "edit, expected",
    [
        # "500 g" is grams: read as a mass it would have become a 0.5 m/s^2 range
        (
            lambda d: d["daq"]["channels"]["active_shroud_accel"].update(range="500 g"),
            "daq.channels.active_shroud_accel.range = '500 g': '500 g' is a mass, expected an acceleration",
        ),
        (
            lambda d: d["daq"]["channels"]["force"].update(range="200 m/s^2"),
            "daq.channels.force.range = '200 m/s^2'",
        ),
        (lambda d: d["daq"]["channels"]["force"].update(range="-5 N"), "must be > 0"),
        (
            lambda d: d["safety"]["limits"]["force"].update(warning="40 m/s^2"),
            "safety.limits.force.warning = '40 m/s^2': '40 m/s^2' is an acceleration, expected a force",
        ),
        (
            lambda d: d["safety"]["limits"]["passive_shroud_accel"].update(abort="400 g"),
            "safety.limits.passive_shroud_accel.abort = '400 g'",
        ),
        (lambda d: d["safety"]["limits"]["drive"].update(abort="6 N"), "safety.limits.drive.abort = '6 N'"),
        (
            lambda d: d["daq"]["channels"]["passive_shroud_accel"].update(physical_channel="Dev1/ai1"),
            "channels.passive_shroud_accel.physical_channel = 'Dev1/ai1' is already used by channels.active_shroud_accel",
        ),
        (
            lambda d: d["daq"]["channels"]["force"].update(physical_channel="Dev1/ao0"),
            "is already used by drive_channel",
        ),
        (
            lambda d: d["daq"]["channels"].update(monitor=_monitor(excitation_current="4 mA")),
            "daq.channels.monitor: a voltage channel takes no excitation current",
        ),
    ],
)
def test_bad_daq_or_safety_is_one_clear_line(edit, expected):
    with pytest.raises(ConfigError) as info:
        parse_rig(_rig(edit))
    assert expected in str(info.value)
    assert "\n" not in str(info.value) and "{" not in str(info.value)


def test_iepe_excitation_defaults_by_kind():
    cfg = parse_rig(
        _rig(
            lambda d: [
                d["daq"]["channels"]["force"].pop("excitation_current"),
                d["daq"]["channels"].update(monitor=_monitor()),
            ]
        )
    )
    assert cfg.daq.channels["force"].excitation_current == 0.004  # IEPE sensor: 4 mA
    assert cfg.daq.channels["monitor"].excitation_current == 0.0  # plain voltage: none
    spec = {s.name: s for s in cfg.daq.input_specs()}["monitor"]
    assert not spec.iepe and (spec.min_value, spec.max_value) == (-5.0, 5.0)
