"""A failed A-step where the branch has no turn in A is cut in half (rigtools.procedures.cbc,
``_cut_step``): the order of the targets measured and what each point records, on a stand-in
rig whose orbits lie on a known curve U(A) and whose outer iteration converges only within a
basin of the last converged point (a step too long fails, as at the top of the sheet); a branch
whose A falls as the drive rises goes on by pseudo-arclength as before. The simulated rig's case
(the 26-target sweep: 0.4824 mm fails, 0.4786 mm and then 0.4824 mm converge on the model's
curve) is ``benchmarks/bench_cbc_realtime.py``."""

from __future__ import annotations

import numpy as np
import pytest

from rigtools.controlled_point import ControlledPoint
from rigtools.procedures.cbc import CBCParameters, CBCPoint, ControlBasedContinuation
from rigtools.procedures.cbc_arclength import STEP_CUTS, rises_with_drive
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
    return pt


def _run(
    grid: list[float], rig: _Rig, start: float, lose_cuts: bool = False
) -> tuple[list[tuple[float, bool, int]], list[str]]:
    """The procedure's sweep (``execute``) on the stand-in: each measured target, whether it
    converged and its ``step_cut``; and which fallbacks ran. ``lose_cuts``: the loop loses every
    cut step's target."""
    proc = ControlBasedContinuation(None, CBCParameters(fe=64.0, amplitudes=tuple(grid)), "unused.h5")
    calls: list[str] = []

    def first_state() -> tuple[np.ndarray, np.ndarray]:
        h = np.zeros(10, complex)
        t, f = h.copy(), h.copy()
        t[0], f[0] = start, rig.drive(start)
        return t, f

    def measure(loop, gap, amplitude, target, ff, secant, *, release=False, arc=None, branch="", cut=0):
        good = [q for q in proc._leg if q.point.converged]
        last = abs(good[-1].target[0]) if good else start
        lost = "A held 12% from the target" if lose_cuts and cut else ""
        ok = not lost and abs(amplitude - last) <= BASIN * (1 + 1e-9)
        pt = _point(amplitude, rig.drive(amplitude), ok, lost)
        pt.step_cut = cut
        proc.points.append(pt)
        proc._leg.append(pt)
        return pt

    class Loop:
        name = "stand-in"

        def finish(self) -> None:
            calls.append("finish")

    secant = FeedforwardSecant(np.eye(2))
    proc.loop = Loop()  # type: ignore[assignment]  # only finish() is called outside the stubs
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


def test_two_cuts_at_most_then_the_leg_ends():
    """A step of four basins (0.404 -> 0.42 mm): the first cut (0.412 mm) fails too, the second
    (0.408 mm, halfway to it) converges, then 0.412 mm and 0.42 mm are tried again from there:
    0.42 mm is still two basins away and fails; no third cut (STEP_CUTS), no arclength, the rest
    of the leg skipped."""
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
    ]
    assert "arclength" not in calls


def test_a_cut_step_that_is_lost_ends_the_leg():
    """A cut whose target the loop loses ends the leg there (the lost line, the drive to rest):
    no second cut, no arclength, the rest of the leg skipped."""
    measured, calls = _run([0.4e-3, 0.404e-3, 0.412e-3, 0.416e-3], _Rig(slope=800.0), 0.4e-3, True)
    assert measured == [(400.0, True, 0), (404.0, True, 0), (412.0, False, 0), (408.0, False, 1)]
    assert calls == ["lost cut step", "finish"]


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
