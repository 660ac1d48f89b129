"""Continuation of periodic orbits (rigtools.sim.continuation) against independent references.

* no contact: the linear harmonic response of the full FE model (modal superposition over all
  modes, rigtools.sim.harmonic), 0.1 %; multipliers exp(lambda T) of the modes;
* one-mode piecewise-linear impact oscillator: its exact solution (matrix exponentials of the two
  linear pieces, switching instants by root finding, monodromy as the product of the pieces'
  transition matrices, exact for a continuous force law): amplitude 1e-4, period-doubling
  boundary 1e-4 relative;
* FEM at 15 N, gap 0.7 mm, 55-80 Hz: settled time integrations of an up/down frequency study
  (0.5 Hz steps) on the stable parts, 0.5 % in the first ten harmonics; the upper fold inside the
  up sweep's jump interval; the lower turning point one step below the down sweep's (a run
  started on the orbit stays, a sweep in 0.05 Hz steps brackets it);
* the simulated rig's model (test article + shaker + amplifier, force control): without contact
  the blade's receptance and the shaker's closed-form force per drive volt (all FE modes), 0.1 %;
  with contact, settled time integrations of the same coupled model at the branch's drive, 0.5 %
  in the first ten harmonics;
* gap 0.5-2 mm at 60 Hz, 15 N: the period doubling, the period-2 branch (out of the range, round
  its grazing hairpin, 0.152 mm at a converged step, and back), and the settled time integration at 1.8 mm (peak
  contact forces 106.7 / 98.9 N), 1 %.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize

from rigtools.sim import continuation as C
from rigtools.sim.contact_events import ContactStructure
from rigtools.sim.orbit_tracer import BranchTracer
from rigtools.sim.params import ContactParams, DampingParams
from rigtools.sim.reduction import ReducedSystem
from rigtools.sim.vibro_impact import OUT_COLUMNS, run_harmonic


@pytest.fixture(scope="module")
def fem(fem_model):
    """``(rig model, FEM reduced system)`` (tests/conftest.py)."""
    return fem_model[1], fem_model[2]


# ----------------------------------------------------------------------------- (a) no contact


def test_no_contact_branch_is_the_linear_harmonic_response(fem):
    from rigtools.sim.harmonic import fem_harmonic_response

    rig, system = fem
    branch = C.continue_orbits(system, "fe", 55.0, 80.0, force=15.0, gap=5e-3)
    assert branch.status == "complete"
    assert branch.values()[-1] == pytest.approx(80.0)
    assert np.all(branch.measure("min_gap") > 0.4e-3)  # no orbit closes the 5 mm gap
    fe = branch.values()
    lin = fem_harmonic_response(rig, fe, 15.0)
    amp = branch.measure("tip_amplitude_active")
    np.testing.assert_allclose(amp, lin.displacement_amplitude("active_shroud"), rtol=1e-3)
    acc = branch.measure("accel_harmonics_active")[:, 0]
    np.testing.assert_allclose(acc, lin.acceleration_amplitude("active_shroud"), rtol=1e-3)
    assert np.all(branch.measure("tip_amplitude_passive") == 0.0)  # blades uncoupled
    # every multiplier inside the unit circle, and they are exp(lambda T) of the modes: the
    # largest is the slowest-decaying mode's exp(-zeta w T) (forward differences: 1e-6)
    assert not any(p.labels for p in branch.points[1:-1])
    decay = np.exp(-np.min(system.zeta * system.omega) / fe)
    biggest = np.array([p.max_multiplier for p in branch.points])
    assert np.all(biggest < 1.0)
    np.testing.assert_allclose(biggest, decay, atol=1e-6)
    assert all(p.stable for p in branch.points)


# ----------------------------------------------------------------------------- (b) one mode

M1, F1, Z1 = 1.0, 10.0, 0.02  # kg, Hz, damping ratio
W1 = 2 * np.pi * F1
K1 = M1 * W1**2
KC, GAP, F0 = 9.0 * K1, 1e-3, 10.0  # contact 9x the spring, 1 mm gap, 10 N


def _one_mode() -> ReducedSystem:
    return ReducedSystem(
        omega=np.array([W1]),
        zeta=np.array([Z1]),
        shapes=np.array([[1 / np.sqrt(M1)], [0.0], [1 / np.sqrt(M1)]]),  # no passive blade: a stop
        blade=np.array([0]),
        contact=ContactParams(gap=GAP, stiffness=KC, damping=0.0),
        damping=DampingParams(Z1),
        pseudo=np.array([False]),
    )


class ExactImpactOscillator:
    """``m x'' + c x' + k x + kc (x - g)_+ = F0 sin(W t)`` solved piece by piece in closed form."""

    def __init__(self, fe: float):
        self.W = 2 * np.pi * fe
        self.T = 1.0 / fe
        c = 2 * Z1 * W1 * M1
        self.pieces = []
        for kk, const in ((K1, 0.0), (K1 + KC, KC * GAP)):
            a = np.array([[0.0, 1.0], [-kk / M1, -c / M1]])
            amp = (F0 / M1) / (kk / M1 - self.W**2 + 1j * self.W * c / M1)  # particular: Im(amp e^iWt)
            self.pieces.append((a, amp, const / kk))

    def particular(self, piece: int, t: float) -> np.ndarray:
        _, amp, offset = self.pieces[piece]
        e = amp * np.exp(1j * self.W * t)
        return np.array([e.imag + offset, (1j * self.W * e).imag])

    def state(self, piece: int, z0: np.ndarray, t0: float, t: float) -> np.ndarray:
        a = self.pieces[piece][0]
        return self.particular(piece, t) + scipy.linalg.expm(a * (t - t0)) @ (z0 - self.particular(piece, t0))

    def period(self, z0: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """``(z(T), monodromy, max x)``; switching where ``x = g`` (bracketed on a fine grid)."""
        t0, z, mono, xmax = 0.0, np.asarray(z0, float), np.eye(2), -np.inf
        grid = np.linspace(0.0, self.T, 801)
        piece = int(z[0] > GAP)
        while t0 < self.T:
            ts = grid[grid > t0]
            xs = np.array([self.state(piece, z, t0, t)[0] for t in ts]) - GAP
            cross = np.flatnonzero(np.sign(xs) != (1 if piece else -1))
            if cross.size == 0:
                t1 = self.T
            else:
                i = cross[0]
                lo = t0 if i == 0 else ts[i - 1]
                t1 = scipy.optimize.brentq(
                    lambda t, pc=piece, zz=z, tt=t0: self.state(pc, zz, tt, t)[0] - GAP, lo, ts[i], xtol=1e-15
                )
            valid = xs[ts <= t1]
            xmax = max(xmax, valid.max() + GAP if valid.size else -np.inf, z[0])
            mono = scipy.linalg.expm(self.pieces[piece][0] * (t1 - t0)) @ mono  # continuous law: no jump
            z = self.state(piece, z, t0, t1)
            t0, piece = t1, 1 - piece
        return z, mono, xmax

    def orbit(self, z_guess: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        z = scipy.optimize.fsolve(lambda z: self.period(z)[0] - z, z_guess, xtol=1e-13)
        _, mono, xmax = self.period(z)
        return z, np.linalg.eigvals(mono), xmax


@pytest.fixture(scope="module")
def one_mode_branches():
    """The period-1 branch, 8-10 Hz, and the period-2 branch of its period doublings."""
    settings = C.ContinuationSettings(steps_per_period=2000)
    return C.trace(_one_mode(), "fe", 8.0, 10.0, force=F0, gap=GAP, settings=settings)


def test_one_mode_impact_oscillator_matches_its_exact_solution(one_mode_branches):
    branch = one_mode_branches[0]
    assert branch.status == "complete"
    # amplitude and multipliers at a few points against the exact orbit
    for p in branch.points[:: max(1, len(branch.points) // 3)]:
        exact = ExactImpactOscillator(p.value)
        z, mu, xmax = exact.orbit(p.state)
        # min_gap = gap - max x (the grid of the reference resolves the peak to ~1e-6)
        assert GAP - p.measures.min_gap == pytest.approx(xmax, rel=1e-4)
        np.testing.assert_allclose(p.state, z, rtol=1e-4, atol=1e-4 * np.abs(z).max())
        np.testing.assert_allclose(np.sort_complex(p.multipliers), np.sort_complex(mu), atol=1e-4)
    # the stability boundary: the two period doublings where the exact multiplier is -1
    pds = branch.labelled(C.PERIOD_DOUBLING)
    assert len(pds) == 2
    for p in pds:

        def det_plus_one(fe, guess=p.state):
            ex = ExactImpactOscillator(fe)
            _, mu, _ = ex.orbit(guess)
            return float(np.prod(1 + mu).real)

        fe_exact = scipy.optimize.brentq(det_plus_one, p.value - 0.05, p.value + 0.05, xtol=1e-10)
        assert p.value == pytest.approx(fe_exact, rel=1e-4)
        assert np.min(np.abs(p.multipliers + 1)) < 1e-4
    # unstable between them, stable outside
    v, stable = branch.values(), branch.stable()
    inside = (v > pds[0].value + 0.01) & (v < pds[1].value - 0.01)
    assert not stable[inside].any() and stable[(v < pds[0].value - 0.01)].all()


def test_one_mode_period_two_branch_merges_at_the_other_period_doubling(one_mode_branches):
    """The period-2 branch born at the lower period doubling is an exact period-2 orbit along its
    way (two periods of the exact solution: 1e-4) and returns onto the period-1 branch at the
    upper one: status "merged", its last point that period doubling (1e-4 Hz)."""
    main, p2 = one_mode_branches
    low, high = main.labelled(C.PERIOD_DOUBLING)
    assert p2.periods == 2 and p2.points[0].labels == (C.SWITCH,)
    assert p2.points[0].value == pytest.approx(low.value, abs=1e-3)
    assert p2.status == "merged" and C.END in p2.points[-1].labels
    assert p2.points[-1].value == pytest.approx(high.value, abs=1e-4)  # 9.5137 Hz
    a, b = p2.points[-1].measures.peak_contact_force_per_period
    assert a == pytest.approx(b, rel=5e-3)  # both periods alike again (the last point before the crossing)
    p = min(p2.points, key=lambda q: abs(q.value - 8.8))
    exact = ExactImpactOscillator(p.value)

    def two_periods(z):
        z1, m1, x1 = exact.period(z)
        z2, m2, x2 = exact.period(z1)
        return z2, m2 @ m1, max(x1, x2)

    z = scipy.optimize.fsolve(lambda z: two_periods(z)[0] - z, p.state, xtol=1e-13, full_output=True)[0]
    z2, mono, xmax = two_periods(z)
    assert np.max(np.abs(z2 - z)) < 1e-10 * np.max(np.abs(z))  # (fsolve's progress check aside)
    assert np.max(np.abs(exact.period(z)[0] - z)) > 1e-2 * np.max(np.abs(z))  # not period 1
    np.testing.assert_allclose(p.state, z, rtol=1e-4, atol=1e-4 * np.abs(z).max())
    assert GAP - p.measures.min_gap == pytest.approx(xmax, rel=1e-4)
    # an unstable orbit (a multiplier -4.18): 1e-4 relative
    mu = np.sort_complex(np.linalg.eigvals(mono))
    np.testing.assert_allclose(np.sort_complex(p.multipliers), mu, rtol=1e-4, atol=1e-4)


class _CircleMap(C.PeriodMap):
    """A stand-in for the shooting map whose fixed points form the closed curve
    ``(fe - 5)^2 + y0^2 = 1, y1 = 0`` (an isola; no reduced system has one this cheaply): the
    tracer's loop logic on its own, with folds at 4 and 6 Hz (multiplier ``1 - y0`` there 1)."""

    def __init__(self):  # no reduced system: only what the tracer reads
        self.periods, self.steps_per_period, self.scale, self.evaluations = 1, 64, np.ones(2), 0
        self.n_physical, self.shaker, self.force_control = 2, None, False
        self._data = np.zeros((64, len(OUT_COLUMNS)))

    def flow(self, y, p):
        g = (p.fe - 5.0) ** 2 + y[0] ** 2 - 1.0
        return np.array([y[0] - 0.5 * g, 0.5 * y[1]]), self._data

    def contact_structure(self, data, p):
        return ContactStructure()


def test_closed_loop_is_reported_closed():
    pmap = _CircleMap()
    tracer = BranchTracer(
        pmap, "fe", C.Forcing(5.0, 1.0, 1e-3), 7.0, 4.0, C.ContinuationSettings(), None, (3.0, 7.0)
    )
    tracer.solver.Y, tracer.y_floor = 1.0, 0.1
    sol = tracer.solver.finish(np.array([1.0, 0.0]), 5.0, 0)
    first = tracer.entry(sol, tracer.solver.tangent(sol, None, 1.0), (C.START,))
    branch = tracer.run(first, C.Branch("fe", 1), 1.0)
    assert branch.status == "closed" and "closed on itself" in branch.message
    assert branch.points[-1].labels == (C.END,) and branch.points[-1].value == 5.0
    v = branch.values()
    y0 = np.array([p.state[0] for p in branch.points])
    np.testing.assert_allclose((v - 5.0) ** 2 + y0**2, 1.0, atol=1e-9)  # every point on the loop
    assert v.min() == pytest.approx(4.0, abs=1e-6) and v.max() == pytest.approx(6.0, abs=1e-6)
    folds = sorted(p.value for p in branch.labelled(C.FOLD))
    np.testing.assert_allclose(folds, [4.0, 6.0], atol=1e-6)
    # the lower half (y0 < 0, multiplier 1 - y0 > 1) unstable, the upper half stable
    st = branch.stable()
    assert np.all(st[y0 > 1e-3]) and not np.any(st[y0 < -1e-3])


# ----------------------------------------------------------------------------- (c) FEM frequency


@pytest.fixture(scope="module")
def frequency_branch(fem_frequency_branch):
    """55-80 Hz, 15 N, 0.7 mm (tests/conftest.py: shared with the report's browser test)."""
    return fem_frequency_branch


@pytest.fixture(scope="module")
def frequency_study(fem):
    from rigtools.sim.studies import run_study

    return run_study(fem[1], "frequency", np.arange(55.0, 80.01, 0.5), direction="both")


def test_fem_frequency_branch_equals_settled_runs_on_its_stable_parts(fem, frequency_branch, frequency_study):
    from rigtools.simulation import harmonics_of

    system = fem[1]
    assert frequency_branch.status == "complete"
    compared = 0
    for sp in frequency_study.points:
        run = sp.run
        if not (run.steady_state and run.period_multiple == 1):
            continue
        ref = np.array([h["amplitude"] for h in harmonics_of(run)["active_shroud_accel"][:10]])
        orbits = [o for o in C.orbit_at(system, frequency_branch, sp.value) if o.stable]
        assert orbits, f"no stable orbit on the branch at {sp.value} Hz where the run settles"
        best = min(orbits, key=lambda o: abs(o.measures.accel_harmonics_active[0] - ref[0]))
        got = best.measures.accel_harmonics_active
        # each harmonic within 0.5 % of itself, or of 1 % of the fundamental when smaller
        np.testing.assert_array_less(np.abs(got - ref), 5e-3 * np.maximum(ref, 0.01 * ref[0]))
        compared += 1
    assert compared >= 80


def _jumps(study, direction: str) -> list[tuple[float, float]]:
    """Intervals between consecutive points of a sweep where the contact appears or vanishes."""
    pts = [p for p in study.points if p.direction == direction]
    out = []
    for a, b in itertools.pairwise(pts):
        fa, fb = a.run.peak_contact_force, b.run.peak_contact_force
        if abs(fa - fb) > 0.5 * max(fa, fb):
            out.append((min(a.value, b.value), max(a.value, b.value)))
    return out


def test_fem_frequency_folds_and_the_study_jumps(fem, frequency_branch, frequency_study):
    """The upper fold (71.64 Hz) lies in the up sweep's jump (71.5, 72) Hz. The lower turning point
    (64.405 Hz) is a grazing hairpin, where the unstable impacting sheet meets the stable
    non-impacting orbit: it lies 0.1 Hz below the down sweep's jump (64.5, 65) Hz, inside that
    interval widened by one 0.5 Hz step, because the sweep leaves a stable orbit early: 65 ->
    64.5 Hz is a transient larger than the orbit's 6.3 um margin to the gap. Started on the orbit
    at 64.5 Hz a run stays; swept down in 0.05 Hz steps it meets contact within (64.40, 64.45)."""
    from rigtools.sim.studies import StudyPlan, iter_study

    system = fem[1]
    upper, lower = frequency_branch.labelled(C.FOLD)
    ((lo, hi),) = _jumps(frequency_study, "up")
    assert lo <= upper.value <= hi  # 71.64 Hz in (71.5, 72)
    assert C.GRAZING in lower.labels and lower.value == pytest.approx(64.405, abs=2e-3)
    ((dlo, dhi),) = _jumps(frequency_study, "down")
    assert (dlo, dhi) == (64.5, 65.0)
    assert dlo - 0.5 < lower.value < dlo
    # the middle part, from the fold back to the hairpin, is unstable (a saddle); from the hairpin
    # up past the down sweep's jump the orbit does not touch and is stable
    pts = frequency_branch.points
    i_up, i_low = pts.index(upper), pts.index(lower)
    # (the last 0.01 Hz before the tip aside: there the grazing impact is shorter than a step and
    # the integrator sees none, a step artefact; the tip and the sampled grazing refine to one
    # location, 64.406 Hz)
    middle = [p for p in pts[i_up + 1 : i_low] if p.value > lower.value + 0.01]
    assert i_low > i_up + 10 and not any(p.stable for p in middle)
    after = [p for p in pts[i_low + 1 :] if p.value <= dhi]
    assert len(after) > 5 and all(p.stable and p.measures.peak_contact_force == 0 for p in after)
    assert max(p.max_multiplier for p in after) < 0.951  # the linear modes' exp(-zeta w T)
    n = frequency_branch.steps_per_period

    def free(fe):
        (o,) = [o for o in C.orbit_at(system, frequency_branch, fe) if o.measures.peak_contact_force == 0]
        return o

    on = free(dlo)
    assert on.measures.min_gap == pytest.approx(6.3e-6, abs=0.3e-6)
    run = run_harmonic(
        system.with_contact(gap=0.7e-3),
        dlo,
        15.0,
        initial=C.initial_state(system, on),
        steps_per_period=n,
        min_settle_periods=200,
    )
    assert run.steady_state and run.period_multiple == 1 and run.outputs["contact_force"].max() == 0.0
    tip = 0.5 * np.ptp(run.outputs["active_tip_displacement"])
    assert tip == pytest.approx(on.measures.tip_amplitude_active, rel=1e-6)
    # smaller steps leave it later: from the orbit at 65 Hz in 0.05 Hz steps the first point
    # with contact is the first below the turning point
    plan = StudyPlan(
        "frequency", tuple(np.round(np.arange(64.0, 65.001, 0.05), 2)), "down", force=15.0, gap=0.7e-3
    )
    swept = [
        (p.value, r.peak_contact_force)
        for p, r in iter_study(system, plan, initial=C.initial_state(system, free(65.0)), steps_per_period=n)
    ]
    first = next(i for i, (_, f) in enumerate(swept) if f > 0)
    assert swept[first][0] < lower.value < swept[first - 1][0]  # 64.40 < 64.405 < 64.45


@pytest.mark.xfail(
    strict=True,
    reason="issue 22's wording, 'each fold lies inside the jump interval of a model up/down "
    "frequency study with 0.5 Hz steps', is not met by the lower turning point: the grazing hairpin "
    "at 64.405 Hz lies 0.095 Hz below the down sweep's jump (64.5, 65) Hz. Physics, not a defect: "
    "the orbit there is stable and a run started on it stays (test above); the 0.5 Hz step's "
    "transient exceeds its 6.3 um margin to the gap, and finer steps jump ever closer to it",
)
def test_lower_turning_point_inside_the_half_hertz_down_jump(frequency_branch, frequency_study):
    """The literal statement for the lower turning point (the upper fold meets it)."""
    _, lower = frequency_branch.labelled(C.FOLD)
    ((dlo, dhi),) = _jumps(frequency_study, "down")
    assert dlo <= lower.value <= dhi


# ----------------------------------------------------------------------------- (d) gap, period 2


def test_gap_continuation_switches_to_the_period_two_branch(fem):
    """The issue's statement, 0.5-2 mm at 60 Hz, 15 N. The period doubling (1.559 mm at a
    converged step) is subcritical: its period-2 branch leaves the range downwards (unstable, one
    real multiplier from 1.1 to 6.4), turns at 0.152 mm (converged), where a small second impact
    of the unstable sheet grazes (a hairpin: the two sheets meet there, none continues below),
    and comes back stable through 1.8 mm, where a settled run from rest lands on it."""
    system = fem[1]
    branches = C.trace(system, "gap", 0.5e-3, 2.0e-3, fe=60.0, force=15.0)
    main, *period2 = branches
    (pd,) = main.labelled(C.PERIOD_DOUBLING)
    assert np.min(np.abs(pd.multipliers + 1)) < 1e-3  # located: a multiplier at -1
    # its location at a converged time step (tests/sim/test_bifurcation_labels.py holds it against
    # brute force); at the branch's own 328 steps per period it lies 1.7 % lower
    (rec,) = [r for r in main.bifurcations if r.label == C.PERIOD_DOUBLING]
    assert rec.converged_ok and rec.converged == pytest.approx(1.5591e-3, rel=1e-3)
    (p2,) = period2
    assert p2.periods == 2 and p2.points[0].labels == (C.SWITCH,)
    assert abs(p2.points[0].value - pd.value) < 0.02e-3
    # its path: out of the range at 0.5 mm, the hairpin, back in at 0.5 mm, out at 2 mm
    assert p2.status == "complete" and "came back" in p2.message
    values = p2.values()
    assert sum(v == pytest.approx(0.5e-3) for v in values) == 2 and values[-1] == pytest.approx(2e-3)
    (fold,) = p2.labelled(C.FOLD)
    assert C.GRAZING in fold.labels
    # the hairpin's location moves with the step (issue 29: 0.1436, 0.1501, 0.1516 mm at 1x, 2x,
    # 4x the 328 steps per period); refined to 16x it is 0.1521 mm, its last change 0.06 %
    # (above the 0.05 % asked, within 0.1 %: kept unconverged, said so)
    (hp,) = [r for r in p2.bifurcations if r.label == C.FOLD]
    assert [n for n, _ in hp.refinements] == [328, 656, 1312, 2624, 5248]
    assert hp.converged == pytest.approx(0.1521e-3, rel=1e-3) and abs(hp.change) < 1e-3 * hp.converged
    i_fold = p2.points.index(fold)
    assert values[:i_fold].min() > fold.value and values[i_fold + 1 :].min() > fold.value
    # unstable up to the tip, the points below the converged hairpin aside (at the converged step
    # no orbit exists there: at 328 steps per period the grazing second impact is not resolved)
    assert not any(p.stable for p in p2.points[:i_fold] if p.value >= hp.converged)
    assert all(p.stable for p in p2.points[i_fold + 1 :])
    impacts = p2.measure("impacts_per_period")
    # the grazing second impact: on the last orbit before the tip above the converged hairpin
    approach = [k for k, p in enumerate(p2.points[:i_fold]) if p.value >= hp.converged]
    assert impacts[approach[-1]] == 1.5 and impacts[i_fold + 1] == 1.0
    # the stable period-2 orbit at 1.8 mm against a settled time integration from rest
    run = run_harmonic(system.with_contact(gap=1.8e-3), 60.0, 15.0)
    assert run.steady_state and run.period_multiple == 2
    n = run.steps_per_period
    c = run.outputs["contact_force"]
    ref = sorted(c[i * n : (i + 1) * n].max() for i in range(2))
    assert ref == pytest.approx([98.9, 106.7], rel=5e-3)  # the numbers
    (at,) = C.orbit_at(system, p2, 1.8e-3)
    assert at.stable
    got = sorted(at.measures.peak_contact_force_per_period)
    np.testing.assert_allclose(got, ref, rtol=1e-2)


# ----------------------------------------------------------------------------- (e) the rig's model


@pytest.fixture(scope="module")
def rig_model():
    """The simulated rig's model (the default rig's test article through its shaker) and the
    test article's FE model."""
    from rigtools.branches import simulated_rig_model
    from rigtools.sim.rig_model import build_rig_model

    cfg, system, drive = simulated_rig_model(None)
    article = build_rig_model(cfg.test_article.to_params().apply(cfg.to_params()))
    return cfg, system, drive, article


def test_rig_model_without_contact_is_the_coupled_linear_response(rig_model):
    """Force control at 15 N, 5 mm gap: the shroud moves as F0 times the blade's receptance, and
    the drive is F0 over the shaker's closed-form force per drive volt (``ShakerParams.
    sensor_force_per_drive`` with the driving-point receptance over all FE modes of the test
    article): 0.1 % (measured 1e-4 and 3e-4: the reduction and the armature on the reduced
    modes). A held drive of 0.5 V gives that force per volt, 0.1 %."""
    from dataclasses import replace

    from rigtools.sim.harmonic import fem_harmonic_response

    cfg, system, drive, article = rig_model
    branch = C.continue_orbits(system, "fe", 55.0, 58.0, force=15.0, gap=5e-3, shaker=drive)
    assert branch.status == "complete" and np.all(branch.measure("peak_contact_force") == 0)
    fe = branch.values()
    lin = fem_harmonic_response(article, fe, 1.0)
    per_volt = np.abs(
        cfg.shaker.to_params().sensor_force_per_drive(fe, lin.displacement["active_force_point"])
    )
    np.testing.assert_allclose(branch.measure("force_fundamental"), 15.0, rtol=1e-9)
    np.testing.assert_allclose(
        branch.measure("tip_amplitude_active"), 15.0 * lin.displacement_amplitude("active_shroud"), rtol=1e-3
    )
    np.testing.assert_allclose(branch.measure("drive_amplitude"), 15.0 / per_volt, rtol=1e-3)
    assert all(p.stable and p.multipliers.size == 2 * system.n_modes + 1 for p in branch.points)
    held = C.continue_orbits(
        system, "fe", 55.0, 58.0, force=0.5, gap=5e-3, shaker=replace(drive, force_control=False)
    )
    per_volt = np.abs(
        cfg.shaker.to_params().sensor_force_per_drive(held.values(), _receptance(article, held))
    )
    np.testing.assert_allclose(held.measure("force_fundamental"), 0.5 * per_volt, rtol=1e-3)
    np.testing.assert_allclose(held.measure("drive_amplitude"), 0.5)


def _receptance(article, branch):
    from rigtools.sim.harmonic import fem_harmonic_response

    return fem_harmonic_response(article, branch.values(), 1.0).displacement["active_force_point"]


def test_rig_model_with_contact_equals_settled_coupled_runs(rig_model):
    """Force control at 15 N, 0.7 mm gap, 58-62 Hz (impacting, stable, below the range where
    the free orbit coexists): at 58.5, 60 and 61.5 Hz a time integration of the same coupled
    model (``VibroImpactStepper`` with the shaker, twice the branch's steps per period) from
    rest at the branch's drive amplitude settles onto the branch's orbit: each of the first ten
    harmonics of the active shroud acceleration within 0.5 % of itself (or of 1 % of the
    fundamental; measured 0.08 %), the force fundamental 15 N within 0.5 % (0.03 %)."""
    from rigtools.sim.vibro_impact import OUT_COLUMNS, VibroImpactStepper

    _, system, drive, _ = rig_model
    branch = C.continue_orbits(system, "fe", 58.0, 62.0, force=15.0, gap=0.7e-3, shaker=drive)
    assert branch.status == "complete" and branch.stable().all()
    assert np.all(branch.measure("peak_contact_force") > 50.0)
    n = 2 * branch.steps_per_period
    col = {c: i for i, c in enumerate(OUT_COLUMNS)}
    k = np.arange(1, 11)
    for fe in (58.5, 60.0, 61.5):
        (orbit,) = C.orbit_at(system, branch, fe, shaker=drive)
        stepper = VibroImpactStepper(system.with_contact(gap=0.7e-3), 1.0 / (fe * n), drive.coupling)
        u = (
            drive.amplifier_gain
            * orbit.measures.drive_amplitude
            * np.sin(2 * np.pi * np.arange(1, n + 1) / n)
        )
        out = stepper.step(np.tile(u, 120)).data
        last, before = out[-n:], out[-2 * n : -n]
        assert np.max(np.abs(last[:, :2] - before[:, :2])) < 1e-7 * np.max(np.abs(last[:, :2]))  # settled
        v = np.fft.rfft(last[:, col["active_tip_velocity"]]) * 2.0 / n
        ref = k * 2 * np.pi * fe * np.abs(v[k])
        got = orbit.measures.accel_harmonics_active
        np.testing.assert_array_less(np.abs(got - ref), 5e-3 * np.maximum(ref, 0.01 * ref[0]))
        f1 = np.abs(np.fft.rfft(last[:, col["excitation_force"]])[1]) * 2.0 / n
        assert f1 == pytest.approx(15.0, rel=5e-3)
