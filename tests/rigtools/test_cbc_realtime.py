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
from rigtools.procedures.cbc import ControlBasedContinuation, control_based_continuation
from rigtools.procedures.cbc_realtime import MAX_RELEASE, OBSERVED, RealTimeHarmonicLoop, _release_periods
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


def test_unknown_inner_loop_is_one_line():
    with pytest.raises(UserError, match="inner loop 'fast'"):
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


UPPER_GRID = "0.3996 mm:0.49 mm:0.0076 mm"  # 12 targets to 0.4832 mm (|mu| 1.69 to 4.7)


@pytest.fixture(scope="module")
def upper(tmp_path_factory) -> tuple[list[dict], str | None]:
    """The targets of UPPER_GRID up the sheet, the default loop with its law scheduled (the plain
    PD with Kd 2 to 3.5 V s/m over A 0.40-0.43 mm; from 0.43 mm Kd 4 with the loop's 350 Hz
    output low-pass): the recorded points (each point's parameters) and the abort's line, if
    the run aborted (the points before it are kept in the recording)."""
    out = tmp_path_factory.mktemp("cbcrt_up") / "up.h5"
    aborted = None
    try:
        control_based_continuation("64 Hz", UPPER_GRID, out, gap="0.5 mm", backend="sim")
    except AcquisitionAborted as exc:
        aborted = str(exc)
    with open_recording(out) as rec:
        points = [dict(p.params) for p in rec.points if "converged" in p.params]
    return points, aborted


@pytest.mark.xfail(
    strict=True,
    reason="measured (h-rtmu, session 9): with the multipliers measured by short pooled releases the "
    "CBC on this path converges six targets (A 0.3983-0.4388 mm, |mu| to 2.6) and loses the 0.4448 mm "
    "target (0.4322 mm, not converged), then the force's safety abort; with the single release "
    "before, nine to 0.4620 mm. Each measurement leaves the loop's error from the orbit at "
    "0.04-0.10 % of A, below its 0.76-2.6 % before the probe, and the benchmark's grid loses targets "
    "without any measurement too (17 points, lost at 0.4528 mm): the scheduled law's path "
    "sensitivity (h-rtlaw), not the state the measurement leaves. Goal: nine targets held to |mu| 3.4",
)
def test_the_sheet_is_held_past_mu_3(upper):
    """The first nine targets (A 0.3996-0.4604 mm, the model's |mu| 1.69 to 3.4, across the
    switch to the low-pass law at 0.43 mm; the plain PD alone lost the sheet's orbits near
    0.44 mm, |mu| ~2.6) converged within 8 iterations, the drive's harmonics 2-10 at most 1 % of
    its fundamental and F1 within 2 % of the model at the measured A."""
    a, f, mu = s_curve()
    points, _aborted = upper
    assert len(points) >= 9
    for x in points[:9]:
        state = (x.get("amplitude_target"), x["amplitude_m"], x["iterations"], x["drive_harmonics_ratio"])
        assert x["converged"] and x["iterations"] <= 8 and x["drive_harmonics_ratio"] <= 0.01, state
        assert abs(x["force_fundamental_n"] / float(np.interp(x["amplitude_m"], a, f)) - 1) <= F1_TOLERANCE
    assert float(np.interp(points[8]["amplitude_m"], a, mu)) > 3.0


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


@pytest.mark.xfail(
    strict=True,
    reason="measured (benchmarks/bench_cbc_realtime.py): with the scheduled law (plain PD to 0.43 mm, "
    "then Kd 4 with the 350 Hz output low-pass) 22 of 26 targets of A 0.30-0.49 mm converge, A "
    "0.3158-0.4771 mm (|mu| to 4.3): 0.4827 mm not steady in 8 iterations, 0.49 mm not reached, "
    "0.3084 mm (next to the branch's turn in A, 0.3059 mm) drive harmonics 1.3 %. On this test's "
    "path six converge to 0.4388 mm, the 0.4448 mm target is lost (0.4322 mm) and the run then "
    "ends on the force's safety abort. The low-pass law's working "
    "range is narrow (the model's orbits held to 0.4951 mm only near Kp 2000, Kd 4, 350 Hz) and "
    "the CBC's moving target upsets it path by path. Goal: every target to 0.49 mm",
)
def test_the_upper_sheet_to_049_mm(upper):
    """Every target of UPPER_GRID (to 0.4832 mm, the issue's sheet to 0.49 mm) converged with F1
    within 2 % of the model, the run not aborted (benchmarks/bench_cbc_realtime.py measures the
    whole 26-point sweep)."""
    a, f, _mu = s_curve()
    points, aborted = upper
    assert aborted is None
    assert len(points) == 12
    for x in points:
        assert x["converged"]
        assert abs(x["force_fundamental_n"] / float(np.interp(x["amplitude_m"], a, f)) - 1) <= F1_TOLERANCE


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
