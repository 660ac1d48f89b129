"""A failed or lost A-step where the branch has no turn in A is cut in half (rigtools.procedures.cbc,
``_cut_step``): the order of the targets measured and what each point records, on a stand-in
rig whose orbits lie on a known curve U(A) and whose outer iteration converges only within a
basin of the last converged point (a step too long fails, as at the top of the sheet); every
attempt after a failed one starts from the leg's last converged orbit, restored
(rigtools.procedures.cbc_cut); a leg whose cuts advanced goes on to its remaining targets, within
CUT_ATTEMPTS extra attempts; a branch whose A falls as the drive rises goes on by
pseudo-arclength as before. The simulated rig's case (the 26-target sweep to 0.49 mm) is
``benchmarks/bench_cbc_realtime.py``."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rigtools.controlled_point import ControlledPoint
from rigtools.procedures.cbc import CBCParameters, CBCPoint, ControlBasedContinuation
from rigtools.procedures.cbc_arclength import STEP_CUTS, no_turn_ahead, rises_with_drive
from rigtools.procedures.cbc_cut import CUT_ATTEMPTS, RESTORE_HOLDS, RESTORE_RAMP, restore_orbit
from rigtools.procedures.cbc_iteration import FeedforwardSecant
from rigtools.procedures.cbc_loop import LoopMeasurement

BASIN = 0.005e-3  # m: the stand-in's iteration converges only this close to the last converged A


class _Rig:
    """The stand-in's orbits: the drive's fundamental on the curve ``U(A)`` (V, A in m)."""

    def __init__(self, slope: float) -> None:
        self.slope = slope  # V/m: > 0 A rises with the drive (the sheet), < 0 it falls (below the F1 minimum)

    def drive(self, a: float) -> float:
        return 0.4 + self.slope * (a - 0.4e-3)


def _point(a: float, u: float, converged: bool, lost: str = "") -> CBCPoint:
    h = np.zeros(10, complex)
    target, ff, response, force = h.copy(), h.copy(), h.copy(), h.copy()
    target[0], ff[0], response[0], force[0] = a, u, a, 20.0 * u
    m = LoopMeasurement(response, ff.copy(), force, h.copy(), steady=converged, start=0, samples=1)
    q = ControlledPoint(
        64.0, a, abs(force[0]), 0.0, converged, 1 if converged else 8, 0.0 if converged else 0.02
    )
    pt = CBCPoint(q, 0.0, target, ff, m, a)
    pt.lost = lost
    pt.shape = ("shape at", a)  # the real-time loop's orbit_shape(): here a label of the point
    return pt


class _Loop:
    """The stand-in inner loop the restore talks to: what it holds (target, feedforward, shape),
    each hold's response the target (steady), as the orbit of a converged point held again."""

    name = "stand-in"
    lost: str | None = None

    def __init__(self, calls: list[str]) -> None:
        self.calls = calls
        self.held: tuple[np.ndarray, np.ndarray] | None = None
        self.shape: object = None
        self.holds = 0

    def hold(self, target, feedforward, **kwargs) -> LoopMeasurement:
        self.held = (np.array(target), np.array(feedforward))
        self.holds += 1
        h = np.zeros(10, complex)
        return LoopMeasurement(np.array(target), np.array(feedforward), h, h, steady=True, start=0, samples=1)

    def restore_shape(self, shape) -> None:
        self.shape = shape

    def finish(self) -> None:
        self.calls.append("finish")


def _run(
    grid: list[float], rig: _Rig, start: float, lose_cuts: bool = False, starts: list | None = None
) -> tuple[list[tuple[float, bool, int]], list[str]]:
    """The procedure's sweep (``execute``) on the stand-in: each measured target, whether it
    converged and its ``step_cut``; and which fallbacks ran. ``lose_cuts``: the loop loses every
    cut step's target. ``starts``: filled with, per measured point, the loop's state at its
    start (what it held, its shape) and the leg's last converged point then."""
    proc = ControlBasedContinuation(None, CBCParameters(fe=64.0, amplitudes=tuple(grid)), "unused.h5")
    calls: list[str] = []
    loop = _Loop(calls)

    def first_state() -> tuple[np.ndarray, np.ndarray]:
        h = np.zeros(10, complex)
        t, f = h.copy(), h.copy()
        t[0], f[0] = start, rig.drive(start)
        return t, f

    def measure(loop, gap, amplitude, target, ff, secant, *, release=False, arc=None, branch="", cut=0):
        good = [q for q in proc._leg if q.point.converged]
        last = abs(good[-1].target[0]) if good else start
        if starts is not None:
            after_failure = bool(proc._leg) and not proc._leg[-1].point.converged
            starts.append((loop.held, loop.shape, good[-1] if good else None, after_failure))
        lost = "A held 12% from the target" if lose_cuts and cut else ""
        ok = not lost and abs(amplitude - last) <= BASIN * (1 + 1e-9)
        pt = _point(amplitude, rig.drive(amplitude), ok, lost)
        pt.step_cut = cut
        proc.points.append(pt)
        proc._leg.append(pt)
        return pt

    secant = FeedforwardSecant(np.eye(2))
    proc.loop = loop  # type: ignore[assignment]  # hold, restore_shape and finish: the rest stubbed
    proc.set_gap = lambda gap: 5e-4  # type: ignore[method-assign]
    proc._approach = lambda loop, p: first_state()  # type: ignore[method-assign]
    proc._probe = lambda loop, p, t, f: secant  # type: ignore[method-assign]
    proc._walk = lambda loop, p, first, a, s: s  # type: ignore[method-assign]
    proc._measure = measure  # type: ignore[method-assign]
    proc._end_leg_lost = lambda loop, pt, a, kind="target": calls.append(f"lost {kind}")  # type: ignore[method-assign]
    proc._arclength = lambda loop, gap, s: calls.append("arclength") or []  # type: ignore[method-assign]
    proc.emit = lambda *args, **kwargs: None  # type: ignore[method-assign]
    proc.execute()
    return [(round(abs(p.target[0]) * 1e6, 3), p.point.converged, p.step_cut) for p in proc.points], calls


def test_a_step_too_long_is_cut_and_the_leg_goes_on():
    """On a branch where A rises with the drive, 0.404 -> 0.412 mm (twice the basin) fails; the
    cut step 0.408 mm (halfway) converges, then 0.412 mm itself from there, and the leg goes on
    to 0.416 mm: the targets in that order, the cut ones recorded with ``step_cut`` 1."""
    measured, calls = _run([0.4e-3, 0.404e-3, 0.412e-3, 0.416e-3], _Rig(slope=800.0), 0.4e-3)
    assert measured == [
        (400.0, True, 0),
        (404.0, True, 0),
        (412.0, False, 0),
        (408.0, True, 1),
        (412.0, True, 1),
        (416.0, True, 0),
    ]
    assert "arclength" not in calls


def test_two_cuts_a_round_then_another_round_from_the_nearer_orbit():
    """A step of four basins (0.404 -> 0.42 mm): the first cut (0.412 mm) fails too, the second
    (0.408 mm, halfway to it) converges, then 0.412 mm and 0.42 mm are tried again from there:
    0.42 mm is still two basins away and fails; no third cut in the round (STEP_CUTS). The round
    came nearer (to 0.412 mm), so another starts from there: its cut 0.416 mm converges, then
    0.42 mm; the leg goes on to 0.424 mm (before this change the leg ended at 0.42 mm, 0.424 mm
    skipped); no arclength."""
    assert STEP_CUTS == 2
    measured, calls = _run([0.4e-3, 0.404e-3, 0.42e-3, 0.424e-3], _Rig(slope=800.0), 0.4e-3)
    assert measured == [
        (400.0, True, 0),
        (404.0, True, 0),
        (420.0, False, 0),
        (412.0, False, 1),
        (408.0, True, 2),
        (412.0, True, 2),
        (420.0, False, 2),
        (416.0, True, 1),
        (420.0, True, 1),
        (424.0, True, 0),
    ]
    assert "arclength" not in calls


def test_a_leg_that_came_nearer_goes_on_to_its_next_targets(monkeypatch):
    """With a budget of 8 extra attempts (``CUT_ATTEMPTS`` set so), steps of four basins: 0.424 mm takes two rounds (0.414 mm fails, 0.409, 0.414 converge,
    0.424 fails; then 0.419, 0.424 converge: six attempts); 0.444 mm spends the last two
    (0.434 mm fails, 0.429 mm converges) unreached. The cuts came nearer, so the leg goes on:
    0.454 mm is measured (not skipped); it fails with no attempt left and ends the leg."""
    monkeypatch.setattr("rigtools.procedures.cbc.CUT_ATTEMPTS", 8)
    measured, _calls = _run([0.4e-3, 0.404e-3, 0.424e-3, 0.444e-3, 0.454e-3], _Rig(slope=800.0), 0.4e-3)
    assert sum(1 for m in measured if m[2]) == 8
    assert measured[-4:] == [(444.0, False, 0), (434.0, False, 1), (429.0, True, 2), (454.0, False, 0)]


def test_each_attempt_after_a_failed_one_starts_from_the_last_converged_orbit():
    """At the start of every point measured after a failed one (the cut steps, the failed
    target again, the leg's next target) the loop holds the leg's last converged point's target
    and feedforward and has its shape back (exactly: the stand-in hands on the same arrays, so
    the tolerance is zero); after a converged one nothing is restored (the loop is on it)."""
    starts: list = []
    measured, _calls = _run([0.4e-3, 0.404e-3, 0.42e-3, 0.424e-3], _Rig(slope=800.0), 0.4e-3, starts=starts)
    after = [s for s in starts if s[3]]
    assert len(after) == sum(1 for i in range(1, len(measured)) if not measured[i - 1][1]) == 3
    for held, shape, last, _ in after:
        assert held is not None and last is not None
        np.testing.assert_array_equal(held[0], last.target)
        np.testing.assert_array_equal(held[1], last.feedforward)
        assert shape == last.shape
    # the first start after a failure: back at 0.404 mm (the first cut's), not at 0.42 mm
    assert abs(after[0][0][0][0]) == pytest.approx(0.404e-3)


def test_a_lost_cut_step_is_restored_from_then_a_leg_that_did_not_advance_ends():
    """The loop loses every cut step's target: each cut starts again from the last converged
    orbit (0.404 mm), the second cut (0.406 mm) is lost too; the leg advanced nowhere, so it ends
    there with the lost line (the drive to rest): no arclength, the rest of the leg skipped.
    (Before the restore, the first lost cut ended the leg at once.)"""
    measured, calls = _run([0.4e-3, 0.404e-3, 0.412e-3, 0.416e-3], _Rig(slope=800.0), 0.4e-3, True)
    assert measured == [
        (400.0, True, 0),
        (404.0, True, 0),
        (412.0, False, 0),
        (408.0, False, 1),
        (406.0, False, 2),
    ]
    assert calls == ["lost cut step", "finish"]


@settings(max_examples=25, deadline=None)
@given(steps=st.lists(st.integers(min_value=1, max_value=24), min_size=2, max_size=12))
def test_the_extra_attempts_per_leg_are_bounded(steps):
    """Whatever the grid (steps of 0.1 to 2.4 basins, up the sheet), a leg measures at most CUT_ATTEMPTS points beyond its own targets (cut steps and
    failed targets tried again), each of its targets at most once as a target of its own, and
    no more than STEP_CUTS halvings per failed target."""
    grid = list(np.cumsum([0.4e-3] + [k * BASIN / 10 for k in steps]))
    measured, _calls = _run(grid, _Rig(slope=800.0), 0.4e-3)
    extra = [m for m in measured if m[2]]
    assert len(extra) <= CUT_ATTEMPTS
    assert len(measured) - len(extra) <= len(grid)
    assert all(m[2] <= STEP_CUTS for m in extra)


def test_when_the_extra_attempts_are_spent_the_next_failed_target_ends_the_leg():
    """Steps of two basins from 0.404 mm: each target fails, its cut (one basin) converges and
    it converges from there: two extra attempts each, so CUT_ATTEMPTS carry the leg over
    CUT_ATTEMPTS / 2 such targets; the next fails with none left and the leg ends (the one after
    it skipped)."""
    n = CUT_ATTEMPTS // 2
    grid = [0.4e-3, 0.404e-3] + [0.404e-3 + k * 2 * BASIN for k in range(1, n + 3)]
    measured, _calls = _run(grid, _Rig(slope=800.0), 0.4e-3)
    assert sum(1 for m in measured if m[2]) == 2 * n == CUT_ATTEMPTS
    assert measured[-1] == (round(grid[-2] * 1e6, 3), False, 0)  # the failed target, not cut
    assert all(abs(m[0] - grid[-1] * 1e6) > 1e-6 for m in measured)  # the last not measured


def test_where_a_falls_as_the_drive_rises_the_failed_step_goes_on_by_arclength():
    """Below the F1 minimum (A falls as the drive rises: the turn in A ahead), the failed A-step
    is not cut: pseudo-arclength as before (the buffered sweep's figures unchanged)."""
    measured, calls = _run([0.30e-3, 0.31e-3, 0.314e-3], _Rig(slope=-800.0), 0.314e-3)
    assert measured == [(314.0, True, 0), (310.0, True, 0), (300.0, False, 0)]
    assert calls.count("arclength") == 1


@pytest.mark.parametrize(
    "previous, last, expected",
    [
        ((0.40e-3, 0.50), (0.41e-3, 0.55), True),  # both rise (the sheet, up the leg)
        ((0.41e-3, 0.55), (0.40e-3, 0.50), True),  # both fall (the sheet, down the leg)
        ((0.315e-3, 0.43), (0.310e-3, 0.47), False),  # A falls, the drive rises (towards the turn)
        ((0.40e-3, 0.50), (0.40e-3, 0.55), False),  # A still: no secant in A
    ],
)
def test_rises_with_drive(previous, last, expected):
    assert rises_with_drive(previous, last) is expected


@pytest.mark.parametrize(
    "previous, last, expected",
    [
        ((0.40e-3, 0.50), (0.41e-3, 0.55), True),  # both rise (the sheet, up the leg)
        ((0.41e-3, 0.55), (0.40e-3, 0.50), True),  # both fall (the sheet, down the leg)
        ((0.315e-3, 0.45), (0.320e-3, 0.43), True),  # A rises as the drive falls (to the F1 minimum)
        ((0.315e-3, 0.43), (0.310e-3, 0.47), False),  # A falls as the drive rises (towards the turn)
        ((0.40e-3, 0.50), (0.40e-3, 0.55), False),  # A still: no secant in A
    ],
)
def test_no_turn_ahead(previous, last, expected):
    assert no_turn_ahead(previous, last) is expected


def test_a_sweep_without_a_converged_target_ends_failed():
    """Every target out of reach (the stand-in's basin never holds the first one: a target past
    grazing, as ``--amplitude "1 mm"`` at 64 Hz, gap 0.5 mm): the run ends with
    TargetNotReached (exit 5, status failed, the file kept) naming why, after the drive came to
    rest (``finish``), instead of ending 'finished' with exit 0 and no point."""
    from rigtools.errors import EXIT_NOT_REACHED, TargetNotReached

    with pytest.raises(TargetNotReached) as info:
        _run([0.45e-3, 0.46e-3], _Rig(slope=800.0), 0.4e-3)
    assert info.value.exit_code == EXIT_NOT_REACHED == 5
    assert (
        str(info.value) == "no target converged (none within 8 iterations); the 1 point(s) measured are kept"
    )


class _LetGoLoop:
    """A stand-in real-time loop that let go of a lost target (``lost`` set: its output zero,
    the host's drive ``feedforward`` held) and slid to the orbit ``now``; each hold's response:
    ``now`` while not engaged, then the target held, steady only from the ``steady_from``-th hold
    of it on. Every call is logged in order."""

    def __init__(self, now: np.ndarray, steady_from: int) -> None:
        self.lost: str | None = "A 0.3117 mm held, 10% from the target"
        self.target = np.full(10, 0.33e-3, complex)
        self.feedforward = np.full(10, 0.4, complex)
        self.now, self.steady_from = now, steady_from
        self.engaged = False
        self.log: list[tuple] = []
        self.held = 0

    def hold(self, target, feedforward, **kwargs) -> LoopMeasurement:
        self.lost = None  # as the real-time loop's hold: cleared, set again if lost
        self.log.append(("hold", np.array(target), np.array(feedforward), kwargs["ramp_time"]))
        if self.engaged:
            self.held += 1
        x = np.array(target) if self.engaged else self.now
        steady = self.engaged and self.held >= self.steady_from
        return LoopMeasurement(x, np.array(feedforward), x, x, steady=steady, start=0, samples=1)

    def set_point(self, target, feedforward, ramp_time) -> None:
        self.log.append(("set_point", np.array(target), np.array(feedforward), ramp_time))

    def set_gains(self, gains) -> None:
        self.engaged = not gains.zero
        self.log.append(("set_gains", gains))

    def restore_shape(self, shape) -> None:
        self.log.append(("restore_shape", shape))


@pytest.mark.parametrize("steady_from, holds", [(1, 1), (2, 2), (5, RESTORE_HOLDS)])
def test_a_loop_that_let_go_is_engaged_again_without_a_kick_then_restored(steady_from, holds):
    """After a lost target (the breaker's 0.33 mm: the orbit slid to 0.3117 mm, the loop let
    go) the restore first engages the loop on the orbit it holds now (its target that orbit's
    response, its feedforward the drive as played: the control error zero, no kick), then gives
    the loop the converged point's shape and ramps to its target and feedforward over
    RESTORE_RAMP, held until steady: at most RESTORE_HOLDS holds. Compared exactly (the same
    arrays are handed on)."""
    now = np.full(10, 0.3117e-3 + 1e-6j)
    loop = _LetGoLoop(now, steady_from)
    point = _point(0.32e-3, 0.45, True)
    params = CBCParameters(fe=64.0, amplitudes=(0.32e-3,))
    m = restore_orbit(loop, point, params)
    kinds = [e[0] for e in loop.log]
    assert kinds == ["hold", "set_point", "set_gains", "restore_shape"] + ["hold"] * holds
    _, t0, f0, ramp0 = loop.log[0]  # the present orbit measured, nothing changed (no ramp)
    assert ramp0 == 0.0 and t0[0] == 0.33e-3 and f0[0] == 0.4
    _, t1, f1, _ = loop.log[1]
    np.testing.assert_array_equal(t1, now)  # engaged on the orbit it holds
    np.testing.assert_array_equal(f1, loop.feedforward)  # with the drive it plays
    assert loop.log[2][1] == params.gains()
    assert loop.log[3][1] == point.shape
    _, t4, f4, ramp4 = loop.log[4]
    np.testing.assert_array_equal(t4, point.target)
    np.testing.assert_array_equal(f4, point.feedforward)
    assert ramp4 == RESTORE_RAMP
    assert m.steady is (steady_from <= RESTORE_HOLDS)


def test_a_target_given_twice_is_measured_once_and_the_failed_step_after_it_is_cut():
    """``--amplitude "0.33 mm,0.32 mm,0.32 mm"`` measured 0.32 mm twice, and the two converged
    points at one A gave no secant (:func:`no_turn_ahead` is ``False`` for an A that did not
    move), so the failed step to 0.33 mm was not cut: the leg ended, lost. A target given twice
    is measured once; the grid then runs as without the repeat (the first test's targets)."""
    grid = [0.4e-3, 0.404e-3, 0.404e-3, 0.412e-3, 0.416e-3]
    measured, calls = _run(grid, _Rig(slope=800.0), 0.4e-3)
    assert measured == [
        (400.0, True, 0),
        (404.0, True, 0),
        (412.0, False, 0),
        (408.0, True, 1),
        (412.0, True, 1),
        (416.0, True, 0),
    ]
    assert "arclength" not in calls
