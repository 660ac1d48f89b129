"""The CBC's step cut after a failed or lost A-step: back to the last converged orbit first.

Where the branch has no turn in A ahead (:func:`~rigtools.procedures.cbc_arclength.no_turn_ahead`)
a target that failed (not converged within ``max_iterations``) or was lost (the real-time loop let
go of it) is taken for a step too long, and the step is cut in half
(:data:`~rigtools.procedures.cbc_arclength.STEP_CUTS` times at most, see
``ControlBasedContinuation._cut_step`` in :mod:`rigtools.procedures.cbc`). An attempt that failed leaves
the rig on whatever orbit it slid to (on the sheet at the top, an orbit beating with the loop's
~72 Hz mode 1 % above its target; next to the F1 minimum, the impact-limited orbit 5 % below),
and the real-time loop's target above H (its ``orbit_shape``) learnt from it. Each attempt after
a failed one therefore starts from the leg's last converged orbit, restored (:func:`restore_orbit`):
its target, its feedforward and its shape, held until steady. Once the cuts have moved the leg
closer to the failed target, the leg goes on towards its remaining targets from there (each again
from the restored orbit), within :data:`CUT_ATTEMPTS` extra attempts per leg.
"""

from __future__ import annotations

from typing import Any

from rigtools.procedures.cbc_loop import LoopMeasurement

#: Attempts per leg beyond its own targets: the cut steps' targets and the failed targets tried
#: again after a cut (each at most ``max_iterations`` outer iterations, about 3-10 s of the rig).
#: When they are spent, the leg's next failed target ends it. Eight give two failed targets a
#: round of two cuts each (the half, the quarter, the half again, the target). At the top of the
#: sheet (abs(mu) 4-6) whether an attempt converges within 8 iterations depends on the path (the
#: orbit beats with the loop's ~72 Hz mode); twelve were tried: on the sweep from 0.2995 mm they
#: added a third round at 0.4895 mm that failed too (24 s more CPU), on the other paths nothing.
CUT_ATTEMPTS = 8
#: The ramp from the failed attempt's target and feedforward back to the converged point's, s
#: (0.3 s is the outer iteration's own; a lost target's orbit can be 10 % away).
RESTORE_RAMP = 0.6
#: Holds of the restored orbit at most, each until two windows agree (the loop's ``hold``).
RESTORE_HOLDS = 2


def restore_orbit(loop: Any, point: Any, params: Any) -> LoopMeasurement:
    """Bring ``loop`` back to a converged point's orbit and hold it until steady; the last hold's
    measurement (its ``steady`` says whether the orbit settled; the loop's ``lost`` whether it
    was lost again on the way).

    A loop that let go of a lost target (its ``lost`` set: output zero, the host's drive held) is
    engaged again on the orbit it holds now (target the measured response, drive as played: no
    kick). Then its target above H and mean go back to the point's ``shape`` (the loop's
    ``orbit_shape`` at the point; ``None``: nothing to restore) and the target and feedforward
    ramp to the point's over :data:`RESTORE_RAMP`, held up to :data:`RESTORE_HOLDS` times until
    the window is steady and its fundamental within twice ``amplitude_tolerance`` of the target's.

    Parameters
    ----------
    loop
        The inner loop (:class:`~rigtools.procedures.cbc_loop.InnerLoop`).
    point
        The converged :class:`~rigtools.procedures.cbc.CBCPoint` (``target``, ``feedforward``,
        ``shape``).
    params
        The CBC's :class:`~rigtools.procedures.cbc.CBCParameters` (gains, settle time, periods
        measured, amplitude tolerance).
    """
    if getattr(loop, "lost", None):  # let go: engage again on the present orbit first
        now = loop.hold(
            loop.target,
            loop.feedforward,
            ramp_time=0.0,
            settle_time=0.1,
            measure_periods=params.measure_periods,
        )
        loop.set_point(now.response, loop.feedforward, ramp_time=0.0)
        loop.set_gains(params.gains())
    restore = getattr(loop, "restore_shape", None)
    if point.shape is not None and callable(restore):
        restore(point.shape)
    a = abs(complex(point.target[0]))
    m: LoopMeasurement | None = None
    for _ in range(RESTORE_HOLDS):
        m = loop.hold(
            point.target,
            point.feedforward,
            ramp_time=RESTORE_RAMP if m is None else 0.0,
            settle_time=params.settle_time,
            measure_periods=params.measure_periods,
        )
        near = abs(complex(m.response[0]) - complex(point.target[0])) <= 2 * params.amplitude_tolerance * a
        if getattr(loop, "lost", None) or (m.steady and near):
            break
    assert m is not None
    return m


__all__ = ["CUT_ATTEMPTS", "RESTORE_HOLDS", "RESTORE_RAMP", "restore_orbit"]
