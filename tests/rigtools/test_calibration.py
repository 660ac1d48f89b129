"""The shipped default rig meets the calibration targets of docs/calibration.md, read from
``rig modal --json`` as a user would."""

import json

import numpy as np
import pytest

from rigtools.cli import main
from rigtools.config import load_rig
from rigtools.sim.modal import blade_modes
from rigtools.sim.rig_model import build_rig_model


@pytest.fixture
def modal_json(capsys):
    assert main(["modal", "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def _flexural(entries):
    return np.array([e["frequency_hz"] for e in entries if e["kind"] == "flexural"])


def test_active_second_flexural_is_361_9_hz(modal_json):
    f = _flexural(modal_json["fem"]["active"])
    assert f[1] == pytest.approx(361.9, rel=5e-3)  # target +-0.5 %


def test_passive_second_and_third_flexural_near_8fe_and_22fe(modal_json):
    f = _flexural(modal_json["fem"]["passive"])
    assert f[1] == pytest.approx(480.0, rel=0.08)
    assert f[2] == pytest.approx(1320.0, rel=0.08)


def test_first_flexural_below_60_hz(modal_json):
    for blade in ("active", "passive"):
        assert _flexural(modal_json["fem"][blade])[0] < 60.0


def test_fem_and_am_agree_within_half_a_percent(modal_json):
    for blade in ("active", "passive"):
        fem = _flexural(modal_json["fem"][blade])[:3]
        am = _flexural(modal_json["am"][blade])[:3]
        assert np.abs(fem / am - 1).max() < 5e-3


def test_masses_realistic_and_force_at_the_second_mode_antinode():
    """m1 (shroud + accelerometer) and m2 (force sensor) are real lab masses (10 g - 300 g), and
    the force acts where the active blade's 2nd flexural mode has >= 95 % of its largest
    amplitude."""
    params = load_rig().to_params()
    assert 0.010 <= params.shroud.mass <= 0.300 and params.shroud.rotary_inertia > 0
    assert 0.010 <= params.force_sensor.mass <= 0.300
    rig = build_rig_model(params)
    blade = rig.active
    mode2 = blade_modes(blade).of_kind("flexural").shapes[:, 1]
    uy = np.array([blade.dof(n, 1) for n in range(1, len(blade.node_x))])
    amp = np.abs(mode2[uy])
    assert amp[blade.sensor_node - 1] >= 0.95 * amp.max()
