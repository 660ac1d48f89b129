"""Control-based continuation on the simulated rig, held against the MODEL: the toolkit's own
continuation of the simulated rig's model (test article plus shaker, force fundamental held) at
fe = 64 Hz, gap 0.5 mm, computed by ``benchmarks/cbc_model_reference.py`` into
``tests/rigtools/data/cbc_model_64hz.json`` (F1, A, largest Floquet multiplier per point). The
first test re-solves one orbit of that table with Newton from its stored state, so the table is
today's model; the CBC runs are short (a few points, seconds of CPU); the full sweep of the
issue's must-show is ``benchmarks/bench_cbc.py``."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_cli

ROOT = Path(__file__).resolve().parents[2]
TABLE = ROOT / "tests" / "rigtools" / "data" / "cbc_model_64hz.json"
FE, GAP = 64.0, 0.5e-3
F1_TOLERANCE = 0.02  # the issue's: F1 within 2 % of the model
PASSIVE_IMPACTING = 1.0  # m/s^2: the passive shroud's fundamental above this, the shrouds impact


@cache
def model() -> dict:
    return json.loads(TABLE.read_text())


@cache
def s_curve() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The impacting branch's S-curve F1(A) (single-valued in A), with |mu|: the model's impacting
    orbits whose F1 stays below 6.2 N (the other impacting family at the same A needs 7-13 N)."""
    pts = [r for r in model()["points"] if r["impacts_per_period"] > 0 and r["force_n"] < 6.2]
    pts.sort(key=lambda r: r["amplitude_m"])
    a = np.array([r["amplitude_m"] for r in pts])
    keep = np.concatenate([[True], np.diff(a) > 0])
    f = np.array([r["force_n"] for r in pts])[keep]
    mu = np.array([r["max_multiplier"] for r in pts])[keep]
    return a[keep], f, mu


def model_force(amplitude: float, impacting: bool) -> float:
    """The model's F1 at A on the branch of the same contact state: the S-curve, or the orbit
    without contact (F1 linear in A: the table's no-contact points)."""
    if impacting:
        a, f, _ = s_curve()
        return float(np.interp(amplitude, a, f, left=math.nan, right=math.nan))
    lin = [r for r in model()["points"] if r["impacts_per_period"] == 0]
    ratio = np.median([r["force_n"] / r["amplitude_m"] for r in lin])
    return float(ratio * amplitude)


def test_model_table_is_todays_model():
    """Newton from the stored state of the unstable 5 N orbit converges to the same orbit: A within
    1e-6 relative, |mu| within 1e-4 (Newton's tolerance and the eigenvalue's round-off)."""
    from rigtools.branches import simulated_rig_model
    from rigtools.sim.continuation import Forcing, PeriodMap, solve_orbit

    _cfg, system, shaker = simulated_rig_model(None)
    ref = model()["unstable_5n"]
    pmap = PeriodMap(system, model()["steps_per_period"], 1, shaker)
    orbit = solve_orbit(pmap, Forcing(FE, 5.0, GAP), np.array(ref["state_scaled"]))
    amplitude = orbit.measures.accel_harmonics_active[0] / (2 * math.pi * FE) ** 2
    assert abs(amplitude / ref["amplitude_m"] - 1) < 1e-6
    assert abs(orbit.max_multiplier - ref["max_multiplier"]) < 1e-4
    _a, f, _mu = s_curve()
    i = int(np.argmin(f))  # the issue's figures: minimum 4.656 N, unstable from A ~ 0.3425 mm
    assert abs(f[i] / 4.656 - 1) < 0.002


@pytest.fixture(scope="module")
def sheet_run(tmp_path_factory):
    """Eight points through the F1 minimum and over the unstable part (the delay-aware law), then
    the gains at zero for 2 s at the last one."""
    from rigtools.procedures.cbc_door import control_based_continuation

    out = tmp_path_factory.mktemp("cbc") / "cbc.h5"
    run = control_based_continuation(
        "64 Hz",
        "0.325 mm:0.360 mm:0.005 mm",
        out,
        gap="0.5 mm",
        backend="sim",
        release_seconds=2.0,
        inner_loop="buffered",
    )
    return run, out


def test_cbc_points_lie_on_the_model_curve(sheet_run):
    """Each point: converged, F1 within 2 % of the model at its measured A (the S-curve: the
    shrouds impact), drive harmonics 2-10 at most 1 % of the fundamental, at most 8 iterations,
    A within the target's tolerance (0.5 %)."""
    run, _ = sheet_run
    assert run.status == "finished"
    assert len(run.points) == 8
    for p in run.points:
        x = p.extra
        impacting = x["passive_shroud_accel_harmonic_amplitude"][0] > PASSIVE_IMPACTING
        assert impacting
        expected = model_force(x["amplitude_m"], impacting)
        assert abs(x["force_fundamental_n"] / expected - 1) <= F1_TOLERANCE, (x["amplitude_m"], expected)
        assert x["converged"] and x["iterations"] <= 8
        assert x["drive_harmonics_ratio"] <= 0.01
        assert abs(x["amplitude_m"] / x["amplitude_target"] - 1) <= 0.005


def test_f1_minimum_as_the_issue_states_it(sheet_run):
    """The smallest F1 measured within 2 % of the model's 4.656 N, at A 0.328 +- 0.005 mm in the
    issue's measure of A (half the peak-to-peak displacement: the model's minimum is at 0.3277 mm
    there, at 0.3333 mm in the fundamental's amplitude)."""
    run, _ = sheet_run
    best = min(run.points, key=lambda p: p.extra["force_fundamental_n"])
    assert abs(best.extra["force_fundamental_n"] / 4.656 - 1) <= 0.02
    assert abs(best.extra["tip_amplitude_active"] - 0.328e-3) <= 0.005e-3


def test_release_leaves_at_the_floquet_rate(sheet_run):
    """Gains at zero at the last (unstable) point: the response's departure grows at fe ln|mu|
    of the model's largest multiplier at the measured A, within the issue's 25 %, fitted over the
    departure's linear range (0.5-5 % of A). Measured (seed 0): 11.95 1/s at A 0.3602 mm against
    10.05 1/s (|mu| 1.170), +19 % (the full sweep of bench_cbc.py: 9.26 against 10.2, -9 %); the
    table's |mu| scatters by +-0.02 there (its time step), +-1.2 1/s in fe ln|mu|."""
    run, _ = sheet_run
    last = run.points[-1].extra
    a, _f, mu = s_curve()
    m = float(np.interp(last["amplitude_m"], a, mu))
    assert m > 1.0
    assert abs(last["release_growth_rate"] / (FE * math.log(m)) - 1) <= 0.25


def test_three_unstable_points_held(sheet_run):
    """At least three converged points where the model's orbit is unstable (A 0.3425-0.360 mm as
    half the peak-to-peak; |mu| > 1 in the table), each within 2 % of the model's F1: the buffered
    loop with the delay-aware law (rigtools.procedures.cbc_delay) for the queue's two blocks."""
    run, _ = sheet_run
    a, _f, mu = s_curve()
    held = [
        p
        for p in run.points
        if p.extra["converged"]
        and float(np.interp(p.extra["amplitude_m"], a, mu)) > 1.0
        and abs(p.extra["force_fundamental_n"] / model_force(p.extra["amplitude_m"], True) - 1)
        <= F1_TOLERANCE
    ]
    assert len(held) >= 3


def test_cbc_recording_is_checked_and_read(sheet_run):
    """rig check passes the file; the reader gives each point's ControlledPoint fields."""
    from rigtools.recording import open_recording
    from rigtools.recording.validate import check_recording

    _, out = sheet_run
    report = check_recording(out)
    assert report.valid, report.problems
    with open_recording(out) as rec:
        names = [p.params.get("amplitude_target") for p in rec.points]
        attrs = rec.points[0].params
    assert names == pytest.approx([0.325e-3 + 0.005e-3 * i for i in range(8)])
    for key in ("fe_hz", "amplitude_m", "force_fundamental_n", "phase_deg", "converged", "iterations"):
        assert key in attrs
    assert "control_effort" in attrs and "drive_harmonics_ratio" in attrs


def test_rig_info_gives_the_target_and_response_harmonics_their_units(sheet_run, monkeypatch):
    """The harmonics table's target and response rows (the active shroud's displacement) had an
    empty units cell; the target's fundamental reads as the point's target amplitude in m."""
    _, out = sheet_run
    monkeypatch.setenv("COLUMNS", "200")
    code, stdout, err = run_cli(["info", out])
    assert code == 0, err
    rows = {}  # channel -> (units, 1xfe) of the harmonics table's rows (the last point's win)
    for line in stdout.splitlines():
        cells = [c.strip() for c in line.split("│") if c.strip()]
        for name in ("target", "response"):
            if name in cells[:2] and len(cells) >= cells.index(name) + 3:
                rows[name] = cells[cells.index(name) + 1 : cells.index(name) + 3]
    assert rows["target"][0] == "m" and rows["response"][0] == "m", rows
    assert float(rows["target"][1]) == pytest.approx(0.325e-3 + 0.005e-3 * 7, rel=1e-3)  # the last point's


def test_cbc_points_state_their_record_window(sheet_run):
    """Each point's record_start/record_samples (the window its harmonics come from, as sine and
    PLL points state it): whole periods inside the point, and the force fundamental fitted anew
    on those samples of the file (rigtools.analysis.harmonics, a second fit) equals the point's
    F1 to 1e-6 relative (the same samples: only round-off differs)."""
    from rigtools.analysis.harmonics import harmonic_amplitudes
    from rigtools.recording import open_recording

    _, out = sheet_run
    with open_recording(out) as rec:
        for p in rec.points:
            start, count = p.record_window
            assert {"record_start", "record_samples"} <= set(p.params)
            assert count == p.params["record_samples"] and start + count <= p.n_samples
            assert count * FE / p.sample_rate == pytest.approx(round(count * FE / p.sample_rate), abs=0.02)
            fit = harmonic_amplitudes(p.settled("force"), p.sample_rate, FE, 10)
            assert fit.amplitude[0] == pytest.approx(p.params["force_fundamental_n"], rel=1e-6)


def test_cli_json_lists_each_point(tmp_path):
    """rig acquire cbc --json: each point with the issue's keys; --backend nidaq says in one line
    that the full sheet needs a real-time inner loop before it looks for the hardware."""
    out = tmp_path / "c.h5"
    cmd = [sys.executable, "-m", "rigtools.cli", "acquire", "cbc", "--fe", "64 Hz", "--gap", "0.5 mm"]
    res = subprocess.run(
        [*cmd, "--backend", "sim", "--amplitude", "0.32 mm", "--inner-loop", "buffered", "--out", str(out)]
        + ["--json"],
        capture_output=True,
        check=False,
        text=True,
        cwd=ROOT,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout)
    keys = {"fe_hz", "amplitude_m", "force_fundamental_n", "phase_deg", "converged", "iterations"}
    assert keys | {"drive_harmonics_ratio"} <= set(doc["points"][0])
    assert doc["procedure"] == "cbc" and doc["inner_loop"] == "buffered"
    ni = subprocess.run(
        [*cmd, "--backend", "nidaq", "--amplitude", "0.32 mm", "--out", str(tmp_path / "n.h5")],
        capture_output=True,
        check=False,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert "real-time inner loop" in ni.stderr
    assert "Traceback" not in ni.stderr


def test_bad_amplitude_is_one_line(tmp_path):
    res = subprocess.run(
        [sys.executable, "-m", "rigtools.cli", "acquire", "cbc", "--backend", "sim", "--fe", "64 Hz"]
        + ["--amplitude", "0.3 mm:0.2 mm:0.01 mm", "--out", str(tmp_path / "x.h5")],
        capture_output=True,
        check=False,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert "--amplitude" in res.stderr


def test_a_fault_before_the_first_point_claims_no_samples_kept(tmp_path):
    """A fault during the approach (before any point; the CBC records only its points' windows):
    exit 4, the one line says the points recorded before are kept, not '102400 samples per channel
    (2.000 s) kept' (the file holds no sample: the approach is not recorded), drive at rest."""
    from cli_helpers import run_cli

    from rigtools.recording import check_recording

    out = tmp_path / "c.h5"
    args = [
        "acquire",
        "cbc",
        "--backend",
        "sim",
        "--gap",
        "0.5 mm",
        "--fe",
        "64 Hz",
        "--amplitude",
        "0.32 mm",
    ]
    code, _, err = run_cli([*args, "--inner-loop", "buffered", "--fault", "nan-samples@1", "--out", out])
    (line,) = err.strip().splitlines()
    assert code == 4
    assert line.endswith("drive brought to zero; the points recorded before are kept")
    assert "samples per channel" not in line
    checked = check_recording(out)
    assert checked.valid and checked.n_points == 0 and checked.status == "aborted"
