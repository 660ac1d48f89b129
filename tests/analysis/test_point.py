"""Per-point entry points: a dwell (harmonics, relative phases, impacts) and an FRF test given
block by block (modes of the exact 2-DOF), against the same references as the module tests."""

import json

import numpy as np
import pytest
from _reference import modes as exact_modes
from _reference import periodic_response

from rigtools.analysis.frf import FRFMethod
from rigtools.analysis.point import analyze_dwell, analyze_frf_test


def test_dwell_harmonics_phases_and_no_impacts():
    fs, fe = 51200.0, 60.0
    t = 0.0137 + np.arange(int(fs * 0.5)) / fs
    w = 2 * np.pi * fe
    ch = {
        "force": 14.65 * np.cos(w * t + 0.4) + 5.9 * np.cos(5 * w * t - 1.0),
        "active_shroud_accel": 120 * np.cos(w * t + 0.1) + 34 * np.cos(6 * w * t + 2.0),
        "passive_shroud_accel": 50 * np.cos(w * t - 0.2),
    }
    res = analyze_dwell(ch, fs, fe)
    assert res.force_amplitude == pytest.approx(14.65, rel=1e-9)
    assert res.harmonics["force"].at(5) == pytest.approx(5.9, rel=1e-9)
    assert res.harmonics["active_shroud_accel"].at(6) == pytest.approx(34.0, rel=1e-9)
    # relative phase: phase_k - k phase_force1, with absolute phases measured from t[0]
    p6 = res.harmonics["active_shroud_accel"].phase[5] - 6 * res.harmonics["force"].phase[0]
    assert res.phases_to_force["active_shroud_accel"][5] == pytest.approx(np.angle(np.exp(1j * p6)), abs=1e-9)
    assert res.phases_to_force["force"][0] == pytest.approx(0.0, abs=1e-12)
    assert res.impacts.n_impacts == 0
    d = json.loads(json.dumps(res.to_dict()))
    assert d["amplitude"] == "peak" and len(d["channels"]["force"]["harmonics"]) == 30


def test_frf_test_blocks_give_the_two_dof_modes():
    fs = 512.0
    rng = np.random.default_rng(3)
    x = rng.standard_normal(2**18)
    y1 = periodic_response(x, fs, out=1, kind="accelerance")
    y0 = periodic_response(x, fs, out=0, kind="accelerance")
    blocks = (
        {"force": x[i : i + 10000], "a1": y1[i : i + 10000], "a0": y0[i : i + 10000]}
        for i in range(0, x.size, 10000)
    )
    res = analyze_frf_test(
        blocks, fs, frf_method=FRFMethod("random", 2048), responses=("a1", "a0"), f_min=10, f_max=250
    )
    fn, zeta = exact_modes()
    for name in ("a1", "a0"):
        got = res.modes[name].modes
        assert len(got) == 2
        np.testing.assert_allclose([m.frequency_hz for m in got], fn, rtol=5e-3)
        np.testing.assert_allclose([m.damping_ratio for m in got], zeta, rtol=0.05)
    assert res.estimate.h1.shape == (2, 1025)
    assert json.loads(json.dumps(res.to_dict()))["modes"]["a1"]["method"] == "lscf"
