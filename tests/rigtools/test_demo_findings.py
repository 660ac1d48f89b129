"""The findings are computed from the data: change the rig and the affected findings flip.

Evaluators run on FEM runs (the same lab quantities the demo computes from the simulated rig's
recordings: shroud accelerations, impacts per period from them), small settings to stay fast.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigtools.config import load_rig
from rigtools.demo import findings, steps
from rigtools.demo.settings import PAPER_FE, PAPER_FORCE
from rigtools.sim.studies import StudyPlan
from rigtools.simulation import RunSettings, iter_study_points, simulate_point

SETTINGS = RunSettings(duration=0.1, max_settle_time=5.0)


@pytest.fixture(scope="module")
def cfg():
    return load_rig(None)


@pytest.fixture(scope="module")
def points(cfg):
    paper, eq, info = steps.operating_points(cfg)
    return paper, eq, info


def _study(cfg, kind, values, **fixed):
    _, system = steps.load_system_cached(cfg, "fem")
    plan = StudyPlan(kind, tuple(values), "up", **fixed)
    out = []
    for planned, run in iter_study_points(system, plan, SETTINGS):
        q = steps.run_quantities(run)
        q["value"] = planned.value
        out.append(q)
    return out


def test_equivalent_point_keeps_the_free_amplitude(cfg, points):
    _paper, eq, info = points
    # independent check: the FEM harmonic response at both points (within 0.1 %)
    assert steps.free_amplitude(cfg, eq.fe, eq.force) == pytest.approx(info["free_amplitude_m"], rel=1e-3)
    assert eq.fe / info["f1_hz"] == pytest.approx(1.8)
    assert info["free_amplitude_m"] == pytest.approx(1.19e-3, rel=0.02)  # docs/calibration.md: ~1.2 mm


def test_gap_finding_flips_when_the_gap_exceeds_the_free_amplitude(cfg, points):
    _, eq, _info = points
    near = _study(cfg, "gap", (0.3e-3, 0.9e-3), fe=eq.fe, force=eq.force)
    v = findings.c4_gap(near, near)
    assert v.holds is True, v.why
    assert near[0]["impulse_level"] > near[1]["impulse_level"] > 0
    assert near[0]["peak_contact_force_n"] > near[1]["peak_contact_force_n"]  # the model agrees
    far = _study(cfg, "gap", (5e-3, 6e-3), fe=eq.fe, force=eq.force)  # > 4x the free amplitude
    assert all(p["impacts_per_period"] == 0 for p in far)
    v = findings.c4_gap(far, far)
    assert v.holds is False and "no impacts" in v.why


def test_force_finding_flips_with_a_wide_gap(cfg):
    near = _study(cfg, "force", (10.0, 25.0), fe=PAPER_FE, gap=0.7e-3)
    assert findings.c5_force(near).holds is True
    far = _study(cfg, "force", (10.0, 25.0), fe=PAPER_FE, gap=5e-3)
    assert findings.c5_force(far).holds is False


def test_gap_finding_reversed_at_the_papers_point(cfg):
    """docs/calibration.md: at 60 Hz = 1.13 f1 the impacts strengthen with the gap."""
    pts = _study(cfg, "gap", (0.3e-3, 0.9e-3), fe=PAPER_FE, force=PAPER_FORCE)
    assert pts[0]["peak_contact_force_n"] == pytest.approx(42.3, rel=0.03)
    assert pts[1]["peak_contact_force_n"] == pytest.approx(66.9, rel=0.03)
    assert findings.c4_gap(pts).holds is False


def _moved_sensor(cfg, position):
    fs = cfg.force_sensor.model_copy(update={"position": position})
    return cfg.model_copy(update={"force_sensor": fs})


def _active_f2(cfg):
    from rigtools.sim.modal import flexural_frequencies
    from rigtools.sim.rig_model import build_rig_model

    return float(flexural_frequencies(build_rig_model(cfg.to_params()).blade("active"), 2)[1])


def test_c7_flips_with_the_force_sensor_at_a_node_of_mode_2(cfg):
    _, system = steps.load_system_cached(cfg, "fem")
    run = simulate_point(system.with_contact(gap=0.5e-3), PAPER_FE, PAPER_FORCE, SETTINGS)
    v = findings.c7_harmonics(steps.run_quantities(run), PAPER_FE, _active_f2(cfg))
    assert v.why.startswith("largest active harmonic in 4-9 fe is 6 fe")
    # the node of the 2nd mode: where the sensor's mass lowers f2 least (f2 highest)
    positions = np.linspace(0.100, 0.140, 9)
    f2 = [_active_f2(_moved_sensor(cfg, x)) for x in positions]
    node = float(positions[int(np.argmax(f2))])
    moved = _moved_sensor(cfg, node)
    assert max(f2) > 440.0  # no longer 361.9 Hz: near the passive 481 Hz
    system2 = steps.load_system_cached(moved, "fem")[1]
    run2 = simulate_point(system2.with_contact(gap=0.5e-3), PAPER_FE, PAPER_FORCE, SETTINGS)
    q2 = steps.run_quantities(run2)
    v2 = findings.c7_harmonics(q2, PAPER_FE, max(f2))
    assert v2.holds is False
    a = np.asarray(q2["harmonics"]["active_shroud_accel"])
    assert 4 + int(np.argmax(a[3:9])) != 6, v2.why


def test_c6_needs_weakening_and_vanishing():
    def pt(v, s, n):
        return {"value": v, "impulse_level": s, "impacts_per_period": n}

    grows = [pt(60, 700, 1), pt(64, 800, 1), pt(68, 900, 1), pt(72, 0, 0)]
    assert findings.c6_frequency(grows).holds is False
    weakens = [pt(60, 900, 1), pt(64, 800, 1), pt(68, 500, 1), pt(72, 0, 0)]
    assert findings.c6_frequency(weakens).holds is True
    stays = [pt(60, 900, 1), pt(64, 800, 1), pt(68, 500, 1), pt(72, 400, 1)]
    assert findings.c6_frequency(stays).holds is False


def test_c1_and_c2_judge_the_numbers():
    fem = {"active": [53.2, 361.9, 1270.6], "passive": [54.9, 481.4, 1321.7]}
    am = {"active": [53.2, 361.9, 1271.2], "passive": [54.9, 481.5, 1322.3]}
    assert findings.c1_frequencies(fem, am, [52.0, 355.6, 1252.9]).holds is True
    assert findings.c1_frequencies(fem, am, [54.0, 355.6, 1252.9]).holds is False  # EM above the FEM
    assert findings.c1_frequencies(fem, am, [45.0, 355.6, 1252.9]).holds is False  # 15 % off
    curve = {"active_shroud": np.array([1.0, 2.0, 3.0])}
    assert findings.c2_harmonic(curve, {"active_shroud": curve["active_shroud"] * 1.01}).holds is True
    assert findings.c2_harmonic(curve, {"active_shroud": curve["active_shroud"] * 1.2}).holds is False
