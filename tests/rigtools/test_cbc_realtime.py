"""Control-based continuation with the simulated rig's real-time inner loop (issue 33's must-show
"CBC with the simulated real-time loop"), held against the MODEL: the toolkit's own continuation
of the simulated rig's model at fe = 64 Hz, gap 0.5 mm (tests/rigtools/data/cbc_model_64hz.json:
its S-curve, and ``sheet_to_grazing`` by ``benchmarks/cbc_model_reference.py --sheet``; the
table's agreement with today's model is test_cbc.py's first test). A few points across the F1
minimum onto the unstable part, and twelve targets up the sheet (A 0.3996-0.4832 mm) where the gain
schedule and the output low-pass matter, keep the CPU small; the 26-point sweep A 0.30-0.49 mm is
``benchmarks/bench_cbc_realtime.py``."""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rigtools.acquisition import AcquisitionAborted
from rigtools.drivers.contracts import ConfigurationError
from rigtools.drivers.realtime import NO_REALTIME_LOOP
from rigtools.errors import UserError
from rigtools.procedures.cbc import CBCParameters, ControlBasedContinuation, cbc_point
from rigtools.procedures.cbc_door import control_based_continuation
from rigtools.procedures.cbc_iteration import FeedforwardSecant
from rigtools.procedures.cbc_loop import LoopMeasurement
from rigtools.procedures.cbc_realtime import (
    DRIVE_PROBE,
    MAX_RELEASE,
    OBSERVED,
    RealTimeHarmonicLoop,
    _release_periods,
)
from rigtools.recording import open_recording

ROOT = Path(__file__).resolve().parents[2]
TABLE = ROOT / "tests" / "rigtools" / "data" / "cbc_model_64hz.json"
F1_TOLERANCE = 0.02  # the issue's: F1 within 2 % of the model
MU_TOLERANCE = 0.10  # the issue's: measured multipliers within 10 % of the model's (|mu| <= 2)


@cache
def s_curve() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The model's impacting S-curve F1(A) with the largest |mu|, single-valued in A, from the
    F1 minimum's side (F1 < 6.2 N) and the unstable sheet up to grazing."""
    doc = json.loads(TABLE.read_text())
    rows = [r for r in doc["points"] if r["impacts_per_period"] > 0 and r["force_n"] < 6.2]
    rows += [r for r in doc["sheet_to_grazing"] if r["impacts_per_period"] > 0]
    rows.sort(key=lambda r: r["amplitude_m"])
    a = np.array([r["amplitude_m"] for r in rows])
    keep = np.concatenate([[True], np.diff(a) > 1e-12])
    f = np.array([r["force_n"] for r in rows])[keep]
    mu = np.array([r["max_multiplier"] for r in rows])[keep]
    return a[keep], f, mu


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """Five points A 0.330-0.360 mm (|mu| 0.82 to 1.17: stable, the loss of stability at
    0.3425 mm, unstable), the default inner loop of the simulated rig (its real-time loop)."""
    out = tmp_path_factory.mktemp("cbcrt") / "cbc.h5"
    result = control_based_continuation(
        "64 Hz", "0.330 mm:0.360 mm:0.0075 mm", out, gap="0.5 mm", backend="sim"
    )
    return result, out


def test_points_lie_on_the_model_curve(run):
    """Each point converged within 8 iterations, its drive's harmonics 2-10 (host plus loop) at
    most 1 % of its fundamental, F1 within 2 % of the model at its measured A."""
    result, _ = run
    assert result.summary["inner_loop"] == "realtime"
    assert len(result.points) == 5
    a, f, _mu = s_curve()
    for p in result.points:
        x = p.extra
        expected = float(np.interp(x["amplitude_m"], a, f))
        assert x["converged"] and x["iterations"] <= 8
        assert x["drive_harmonics_ratio"] <= 0.01
        assert abs(x["force_fundamental_n"] / expected - 1) <= F1_TOLERANCE, (x["amplitude_m"], expected)


def test_measured_multipliers_match_the_model(run):
    """At each point the largest measured multiplier (probe and release of the loop's target,
    rigtools.analysis.floquet) within 10 % of the model's at the measured A; stable points and
    unstable ones both among them (the model's |mu| from 0.82 to 1.17 here)."""
    result, _ = run
    a, _f, mu = s_curve()
    model = []
    for p in result.points:
        x = p.extra
        m = float(np.interp(x["amplitude_m"], a, mu))
        model.append(m)
        assert abs(x["max_multiplier"] / m - 1) <= MU_TOLERANCE, (x["amplitude_m"], x["max_multiplier"], m)
        assert x["multipliers"][0] == pytest.approx(x["max_multiplier"])
    assert min(model) < 1.0 < max(model)


def test_multipliers_are_in_the_recording(run):
    """Each recorded point carries its multipliers (moduli, largest first) and their angles."""
    _, out = run
    with open_recording(out) as rec:
        params = [p.params for p in rec.points]
    assert len(params) == 5
    for q in params:
        moduli = np.asarray(q["multipliers"])
        assert moduli.size >= 2 and np.all(np.diff(moduli) <= 0)
        assert len(np.atleast_1d(q["multipliers_phase_deg"])) == moduli.size


def test_the_measurement_leaves_the_rig_on_the_orbit(run):
    """Each point's releases (the drift bounded: 3 % of A since the release, the loop's target
    re-engaged in time) end with the loop's largest error from the orbit over a block back within
    1.5 times its level before the first probe, or 0.3 % of A (the measurement waits up to 2 s
    for it): the next point starts where the CBC left this one. Every release at most 20 periods."""
    _, out = run
    with open_recording(out) as rec:
        params = [p.params for p in rec.points]
    for q in params:
        assert q["multipliers_error_after"] <= max(1.5 * q["multipliers_error_before"], 0.003), q
        assert 3 <= q["multipliers_release_periods"] <= MAX_RELEASE


@pytest.fixture(scope="module")
def fold(tmp_path_factory) -> list[dict]:
    """Three targets up to the fold in the drive (A 0.3298, 0.3389, 0.3458 mm: the model's
    largest multiplier 0.80, 0.89, ~1.0, the fold's real multiplier rising to 1), each point's
    parameters. On this path the target's probe alone measured 0.831 at 0.3468 mm (model 0.998,
    -16.8 %): the fold's multiplier enters the differenced release weakened by |mu - 1|."""
    out = tmp_path_factory.mktemp("cbcrt_fold") / "fold.h5"
    control_based_continuation("64 Hz", "0.3298 mm,0.3389 mm,0.3458 mm", out, gap="0.5 mm", backend="sim")
    with open_recording(out) as rec:
        return [dict(p.params) for p in rec.points if "converged" in p.params]


def test_the_folds_multiplier_is_measured_with_a_drive_step(fold):
    """Next to the fold (the model's |mu| 0.89 and ~1.0 at two of the three points) the largest
    measured multiplier is within 10 % of the model's at every point (the issue's tolerance; on
    this path +2.0, +2.0, -1.0 %), each decaying fit having taken a release that stepped the
    drive by DRIVE_PROBE (``multipliers_drive_probe``)."""
    a, _f, mu = s_curve()
    assert len(fold) == 3 and all(x["converged"] for x in fold)
    near = 0
    for x in fold:
        m = float(np.interp(x["amplitude_m"], a, mu))
        assert abs(x["max_multiplier"] / m - 1) <= MU_TOLERANCE, (x["amplitude_m"], x["max_multiplier"], m)
        if x["max_multiplier"] < 1.0:
            assert x["multipliers_drive_probe"] == DRIVE_PROBE
        near += 0.85 < m
    assert near >= 2


def test_unknown_inner_loop_is_one_line():
    with pytest.raises(UserError, match="inner_loop = 'fast'"):
        ControlBasedContinuation(None, {"fe": 64.0, "amplitudes": [3e-4]}, "x.h5", inner_loop="fast")


def test_a_backend_without_a_realtime_loop_is_refused():
    """The real-time inner loop on a device without one: one line (the procedure then takes the
    buffered loop and says NO_REALTIME_LOOP, tests/rigtools/test_cbc.py's nidaq case)."""

    class NoLoop:
        backend = "nidaq"
        has_realtime_loop = False

    with pytest.raises(ConfigurationError, match="no real-time inner loop"):
        RealTimeHarmonicLoop(NoLoop(), None, None, None, 64.0, {})
    assert "real-time" in NO_REALTIME_LOOP and "\n" not in NO_REALTIME_LOOP


# 8 targets to 0.49 mm (the model's |mu| 1.69 to 5.6): the first three as fine as the sweep's
# (the multipliers' test), then steps of 0.015 mm (the law needs no finer path)
UPPER_GRID = "0.3996 mm,0.4072 mm,0.4148 mm,0.43 mm,0.445 mm,0.46 mm,0.475 mm,0.49 mm"


@pytest.fixture(scope="module")
def upper(tmp_path_factory) -> tuple[list[dict], str | None, dict]:
    """The targets of UPPER_GRID up the sheet, the default loop with its law scheduled (the plain
    PD with Kd 2 to 3.5 V s/m over A 0.40-0.43 mm; from 0.43 mm Kd 4 with the loop's 350 Hz
    output low-pass): the recorded points (each point's parameters), the abort's line if the run
    aborted (the points before it are kept in the recording), and the run's summary. One run
    shared by the tests below."""
    out = tmp_path_factory.mktemp("cbcrt_up") / "up.h5"
    aborted, summary = None, {}
    try:
        summary = control_based_continuation("64 Hz", UPPER_GRID, out, gap="0.5 mm", backend="sim").summary
    except AcquisitionAborted as exc:
        aborted = str(exc)
    with open_recording(out) as rec:
        points = [dict(p.params) for p in rec.points if "converged" in p.params]
    return points, aborted, summary


def test_the_sheet_is_held_past_mu_3(upper):
    """The first six targets (A 0.3996-0.46 mm, the model's |mu| 1.69 to 3.3, across the switch
    to the low-pass law at 0.43 mm; the plain PD alone lost the sheet's orbits near 0.44 mm,
    |mu| ~2.6) converged within 8 iterations, the drive's harmonics 2-10 at most 1 % of its
    fundamental and F1 within 2 % of the model at the measured A."""
    a, f, mu = s_curve()
    points, _aborted, _summary = upper
    assert len(points) >= 6
    for x in points[:6]:
        state = (x.get("amplitude_target"), x["amplitude_m"], x["iterations"], x["drive_harmonics_ratio"])
        assert x["converged"] and x["iterations"] <= 8 and x["drive_harmonics_ratio"] <= 0.01, state
        assert abs(x["force_fundamental_n"] / float(np.interp(x["amplitude_m"], a, f)) - 1) <= F1_TOLERANCE
    assert float(np.interp(points[5]["amplitude_m"], a, mu)) > 3.0


def test_measured_multipliers_up_to_mu_2(upper):
    """Where the model's |mu| <= 2 among these points the largest measured multiplier within 10 %
    of the model's at the measured A (the issue's tolerance), at least two such points (on this
    path A 0.3983, 0.4055, 0.4135 mm, |mu| 1.69-1.99: measured +0.7, -1.2, -1.7 %). The releases
    are short and pooled (cbc_realtime's module docstring): the fit no longer depends on the
    previous point's multiplier, which put the fit at -15 % at 0.4056 mm on this path before."""
    a, _f, mu = s_curve()
    checked = 0
    for x in upper[0]:
        m = float(np.interp(x["amplitude_m"], a, mu))
        if m <= 2.0:
            assert abs(x.get("max_multiplier", np.nan) / m - 1) <= MU_TOLERANCE, (
                x["amplitude_m"],
                x.get("max_multiplier"),
                m,
            )
            checked += 1
    assert checked >= 2


def test_a_lost_target_ends_its_leg_not_the_run(tmp_path):
    """A target past grazing (0.52 mm: no orbit of the sheet there, the loop loses it) ends its
    leg with one line naming it and why, not the run on the force's safety abort (60 N): the
    recorded point says ``lost`` and the summary has that line. Since the cut after a loss
    (rigtools.procedures.cbc_cut) its step is cut first, from 0.33 mm's orbit brought back (the
    points after it carry ``step_cut``): no cut converges, so the leg ends there."""
    out = tmp_path / "lost.h5"
    run = control_based_continuation(
        "64 Hz", "0.33 mm,0.52 mm", out, gap="0.5 mm", backend="sim", multipliers=False
    )
    lines = run.summary["lost"]
    assert len(lines) == 1 and "\n" not in lines[0]
    assert lines[0].startswith("target A = 0.52 mm lost (") and lines[0].endswith("): the leg ends there")
    with open_recording(out) as rec:
        points = [dict(p.params) for p in rec.points if "converged" in p.params]
    at = [i for i, x in enumerate(points) if x["amplitude_target"] == pytest.approx(0.52e-3)]
    assert len(at) == 1 and points[at[0]]["lost"] and not points[at[0]]["converged"]
    assert points[at[0] - 1]["converged"]
    cuts = points[at[0] + 1 :]
    assert cuts and all(x.get("step_cut", 0) >= 1 and not x["converged"] for x in cuts)


def test_a_target_lost_next_to_the_f1_minimum_is_reached_after_a_cut(tmp_path):
    """The breaker's case: targets 0.32, 0.33, 0.34 mm (the model's F1 minimum 4.656 N at
    0.328 mm), multipliers off to keep the CPU small (~7 s). The held orbit at 0.33 mm slides to
    the impact-limited one (0.3117 mm) and the loop lets go of it; the CBC brings the loop back
    to 0.32 mm's orbit, cuts the step (0.325 mm) and reaches 0.33 mm from there (before: the leg
    ended at 0.33 mm lost, 0.34 mm skipped). Each of the three targets converged as a target
    within 8 iterations, F1 within 2 % of the model at the measured A, nothing lost or skipped."""
    a, f, _mu = s_curve()
    out = tmp_path / "fmin.h5"
    run = control_based_continuation(
        "64 Hz", "0.32 mm,0.33 mm,0.34 mm", out, gap="0.5 mm", backend="sim", multipliers=False
    )
    assert run.summary["lost"] == [] and run.summary["skipped_amplitudes"] == []
    with open_recording(out) as rec:
        points = [dict(p.params) for p in rec.points if "converged" in p.params]
    for target in (0.32e-3, 0.33e-3, 0.34e-3):
        hits = [x for x in points if x["converged"] and x["amplitude_target"] == pytest.approx(target)]
        assert len(hits) == 1, (target, [(x["amplitude_target"], x["converged"]) for x in points])
        x = hits[0]
        assert x["iterations"] <= 8 and x["drive_harmonics_ratio"] <= 0.01
        assert abs(x["force_fundamental_n"] / float(np.interp(x["amplitude_m"], a, f)) - 1) <= F1_TOLERANCE


def test_the_upper_sheet_to_049_mm(upper):
    """Every target of UPPER_GRID (to 0.49 mm, the model's |mu| to 5.6) converged at its first
    attempt (no cut) within 8 iterations with F1 within 2 % of the model at the measured A and
    the drive's harmonics 2-10 at most 1 %, the run not aborted (benchmarks/bench_cbc_realtime.py measures the whole
    26-target sweep). From 0.475 mm each measurement spans two beats of the controlled orbit
    with the loop's ~72 Hz mode (16 periods): with 10 (1.25 beats) 0.49 mm was never steady; and
    a hold there waits up to 6 s for two windows that agree (``WIDE_WINDOW_MAX_WAIT``): with 3 s
    0.49 mm failed on this path (A 0.4800 mm held, errors 0.5-2.1 %, its cuts failing on
    steadiness alone), a strict xfail until then."""
    a, f, _mu = s_curve()
    points, aborted, _summary = upper
    assert aborted is None
    assert len(points) == 8
    for x in points:
        assert x["converged"] and x["iterations"] <= 8 and x["drive_harmonics_ratio"] <= 0.01
        assert abs(x["force_fundamental_n"] / float(np.interp(x["amplitude_m"], a, f)) - 1) <= F1_TOLERANCE


@cache
def linear_stiffness() -> float:
    """F1 / A of the model's orbits without contact at 64 Hz (N/m): the model below the turn."""
    doc = json.loads(TABLE.read_text())
    return float(
        np.median([r["force_n"] / r["amplitude_m"] for r in doc["points"] if r["impacts_per_period"] == 0])
    )


@pytest.fixture(scope="module")
def low(tmp_path_factory) -> list[dict]:
    """The down leg of the sweep's lowest targets: 0.3152 mm, 0.3076 mm (on the impacting
    branch's stable side, next to its turn in A at 0.3059 mm: the soft gains) and 0.300 mm (past
    the turn: the orbit without contact), without the multipliers (each point's parameters)."""
    out = tmp_path_factory.mktemp("cbcrt_low") / "low.h5"
    control_based_continuation(
        "64 Hz", "0.3152 mm,0.3076 mm,0.300 mm", out, gap="0.5 mm", backend="sim", multipliers=False
    )
    with open_recording(out) as rec:
        return [dict(p.params) for p in rec.points if "converged" in p.params]


def test_the_low_end_past_the_turn_in_a(low):
    """Each target converged within 8 iterations with the drive's harmonics 2-10 at most 1 %:
    0.3152 and 0.3076 mm on the impacting branch (F1 within 2 % of the model's S-curve at the
    measured A), 0.300 mm recorded as the orbit without contact with F1 within 2 % of the model's
    there (F1 / A of its orbits without contact, 22.5 kN/m: 6.75 N). (At 0.300 mm the A-step
    itself ends at the turn, A ~0.3065 mm, not converged: the point kept in the recording.)"""
    a, f, _mu = s_curve()
    good = {round(x["amplitude_target"] * 1e5): x for x in low if x["converged"]}
    assert set(good) == {32, 31, 30}, [(x["amplitude_target"], x["converged"]) for x in low]
    for x in good.values():
        assert x["iterations"] <= 8 and x["drive_harmonics_ratio"] <= 0.01
    for key in (32, 31):
        x = good[key]
        assert abs(x["force_fundamental_n"] / float(np.interp(x["amplitude_m"], a, f)) - 1) <= F1_TOLERANCE
    x = good[30]
    assert x["branch"] == "no contact"
    assert abs(x["force_fundamental_n"] / (linear_stiffness() * x["amplitude_m"]) - 1) <= F1_TOLERANCE


class _LosingLoop:
    """An inner loop whose second hold loses its target (as RealTimeHarmonicLoop says it)."""

    def __init__(self) -> None:
        self.holds = 0
        self.lost: str | None = None

    def hold(self, target, feedforward, **kwargs) -> LoopMeasurement:
        self.holds += 1
        self.lost = "A 0.4 mm held, 12% from the target" if self.holds == 2 else None
        h = np.zeros(10, complex)
        response, drive, force = h.copy(), h.copy(), h.copy()
        response[0], drive[0], force[0] = 1.01 * target[0], feedforward[0], 10.0
        return LoopMeasurement(response, drive, force, h.copy(), steady=True, start=0, samples=1)


def test_a_lost_hold_ends_the_point_at_once():
    """The outer iteration stops at the hold whose target the inner loop lost: the point not
    converged after 2 iterations (of 8), the loop's reason kept as the point's ``lost``."""
    loop = _LosingLoop()
    params = CBCParameters(fe=64.0, amplitudes=(4.5e-4,))
    target, ff = np.zeros(10, complex), np.zeros(10, complex)
    target[0], ff[0] = 4.5e-4, 0.9
    pt = cbc_point(loop, params, target, ff, FeedforwardSecant(np.eye(2) * 1e-3))
    assert (loop.holds, pt.point.iterations, pt.point.converged) == (2, 2, False)
    assert pt.lost == "A 0.4 mm held, 12% from the target"
    assert pt.attrs()["lost"] == pt.lost


@settings(max_examples=80, deadline=None)
@given(
    growth=st.floats(0.5, 6.0),
    first=st.floats(1e-9, 1e-6),
    limit=st.floats(1e-6, 1e-4),
    known=st.booleans(),
)
def test_a_release_stays_within_its_limit_at_the_growth_it_shows(growth, first, limit, known):
    """A released transient whose period-to-period step (a fixed shape) grows by ``growth`` a
    period: the extension ``_release_periods`` gives after the periods seen keeps the deviation
    since the release within ``limit`` over the whole release (reference: the geometric sum
    itself), the growth estimated from the periods seen (model-free) or given (an earlier fit of
    the same orbit, here the true one); none once the periods seen are past a third of the
    limit; at most MAX_RELEASE periods in all."""
    shape = np.sin(2 * np.pi * np.arange(64) / 64) + 0.3 * np.cos(6 * np.pi * np.arange(64) / 64)

    def free(periods: int) -> np.ndarray:
        since = [first * sum(growth**i for i in range(k)) for k in range(periods)]
        return np.outer(since, shape)

    seen = free(OBSERVED)
    more = _release_periods(seen, limit, growth if known else None)
    assert OBSERVED + more <= MAX_RELEASE
    if np.abs(seen[-1] - seen[0]).max() >= limit / 3:
        assert more == 0
    else:
        whole = free(OBSERVED + more)
        assert np.abs(whole[-1] - whole[0]).max() <= limit


def test_the_models_multiplier_without_contact_is_the_passive_blades_free_mode():
    """Why points without contact are not held against the model's largest multiplier (the
    benchmark's note): the table's orbits without contact all have |mu| = exp(-zeta w / fe) of the
    passive blade's (blade 1: the shaker drives blade 0) first mode, 53.69 Hz, zeta 1.2 %, to 1e-6
    (the continuation's Floquet solve against the closed form of an uncoupled damped mode). Without
    contact that mode is decoupled from the drive and from the active shroud's displacement, so no
    measurement there can see it (the loop measures 0.70, the active blade's with the shaker)."""
    from rigtools.branches import simulated_rig_model

    _cfg, system, _shaker = simulated_rig_model(None)
    passive = np.flatnonzero(np.asarray(system.blade) == 1)
    first = passive[np.argmin(np.asarray(system.frequencies_hz)[passive])]
    w, zeta = 2 * np.pi * float(system.frequencies_hz[first]), float(system.zeta[first])
    closed_form = np.exp(-zeta * w / 64.0)
    rows = [r for r in json.loads(TABLE.read_text())["points"] if r["impacts_per_period"] == 0]
    assert rows
    for r in rows:
        assert r["max_multiplier"] == pytest.approx(closed_form, rel=1e-6)
