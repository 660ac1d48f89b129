"""Pseudo-arclength for control-based continuation: past a turn of the branch in A.

The continuation parameter of :mod:`rigtools.procedures.cbc` is the target's fundamental
amplitude ``A``: fine while the branch is a graph over A. At the grazing hairpin of the impacting
branch (at 64 Hz, gap 0.5 mm: A turns at 0.3059 mm, F1 7.0 N, drive 0.554 V) the branch folds back
in A and a target beyond the turn has no orbit there: the A-step fails. From there the points are
placed by pseudo-arclength in the plane of ``A`` and the drive's fundamental ``U = |U1|`` (each
relative to the last converged point): the predictor steps ``h`` along the secant ``t`` of the
last two converged points; the corrector keeps the point on the line through the predictor normal
to ``t``. The loop only sets ``A``, so each outer iteration moves ``A`` along ``t`` by the
constraint's residual ``r = t . (P - P_pred)``: ``A <- A - a0 t_A r`` (the branch is locally along
``t``). Where the tangent is closer to the U axis (:attr:`ArcStep.by_drive`: about the turn in A,
where the Jacobian of the response to the feedforward is singular) the drive is set instead:
``U`` on the corrector's line at the measured A, the target following the measured response (a
Picard step on every harmonic), as at a fixed drive.

Not every failed A-step is a turn. Where the last secant has A rising with the drive (at 64 Hz,
gap 0.5 mm the unstable sheet from the F1 minimum up to grazing, a graph over A) the branch has no
turn in A between the last point and the target (:func:`rises_with_drive`); the CBC then cuts the
step in half instead (:data:`STEP_CUTS` at most) and goes on along the leg; so it does where A
rises as the drive falls (up the stable side towards the F1 minimum, away from the turn:
:func:`no_turn_ahead`). The turn at the grazing hairpin is approached where A falls as the drive
rises (down the stable side below the F1 minimum), and a failed A-step there goes on by
pseudo-arclength.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The corrector is done when the constraint's residual is below this share of the step.
ARC_TOLERANCE = 0.1
#: Halvings of a failed A-step where the branch has no turn in A (:func:`rises_with_drive`).
STEP_CUTS = 2


@dataclass(frozen=True)
class ArcStep:
    """One pseudo-arclength step in the plane (A / a0 - 1, U / u0 - 1).

    Attributes
    ----------
    a0, u0
        The last converged point's A (m) and drive fundamental (V): the origin and the scales.
    tangent
        The unit secant direction (scaled plane) through the last two converged points.
    h
        The step along it (scaled).
    """

    a0: float
    u0: float
    tangent: tuple[float, float]
    h: float

    @classmethod
    def through(
        cls, previous: tuple[float, float], last: tuple[float, float], h: float | None = None
    ) -> ArcStep:
        """The step after the converged points ``previous`` and ``last`` (each ``(A, U)``), of
        ``h`` (default: their own distance in the scaled plane).

        Raises
        ------
        ValueError
            If the two points coincide.
        """
        a0, u0 = last
        d = np.array([previous[0] / a0 - 1, previous[1] / u0 - 1])
        size = float(np.hypot(*d))
        if size == 0:
            raise ValueError("two distinct converged points are needed for a secant")
        t = -d / size
        return cls(float(a0), float(u0), (float(t[0]), float(t[1])), size if h is None else float(h))

    def predictor(self) -> tuple[float, float]:
        """``(A, U)`` one step ``h`` along the tangent."""
        return self.a0 * (1 + self.h * self.tangent[0]), self.u0 * (1 + self.h * self.tangent[1])

    def residual(self, a: float, u: float) -> float:
        """``t . (P - P_pred)`` in the scaled plane (0 on the corrector's line)."""
        p = np.array([a / self.a0 - 1, u / self.u0 - 1])
        return float(np.dot(self.tangent, p) - self.h)

    def satisfied(self, a: float, u: float) -> bool:
        return abs(self.residual(a, u)) <= ARC_TOLERANCE * self.h

    def next_amplitude(self, a: float, u: float) -> float:
        """The target's A for the next outer iteration, from the present ``(A, U)``."""
        return a - self.a0 * self.tangent[0] * self.residual(a, u)

    @property
    def by_drive(self) -> bool:
        """Whether the drive is the better handle: the tangent closer to the U axis than to the
        A axis (near the turn in A, where the feedforward's secant meets the fold's singular
        Jacobian, the drive is set and the target follows the response)."""
        return abs(self.tangent[1]) > abs(self.tangent[0])

    def drive_for(self, a: float) -> float:
        """The drive's fundamental (V) on the corrector's line at amplitude ``a``."""
        return self.u0 * (1 + (self.h - self.tangent[0] * (a / self.a0 - 1)) / self.tangent[1])


def extrapolate(states: list[np.ndarray], points: list[tuple[float, float]], step: ArcStep) -> np.ndarray:
    """The state vector (target and feedforward harmonics) at the predictor: the last two
    converged states extrapolated by the step over their own distance."""
    (a1, u1), (a2, u2) = points[-2], points[-1]
    d = float(np.hypot(a1 / a2 - 1, u1 / u2 - 1))
    s = step.h / d if d > 0 else 0.0
    return np.asarray(states[-1]) + s * (np.asarray(states[-1]) - np.asarray(states[-2]))


def rises_with_drive(previous: tuple[float, float], last: tuple[float, float]) -> bool:
    """Whether the secant through two converged points ``(A, U)`` has A and the drive's
    fundamental moving the same way. On the rig's S-curve at a fixed fe the turn in A (the
    impacting branch's grazing hairpin) is approached where A falls as the drive rises; where
    both rise (the sheet from the F1 minimum up to grazing) a failed A-step is taken for a step
    too long, not a turn (see the module docstring)."""
    return (last[0] - previous[0]) * (last[1] - previous[1]) > 0


def no_turn_ahead(previous: tuple[float, float], last: tuple[float, float]) -> bool:
    """Whether a failed A-step after the converged points ``previous`` then ``last`` (each
    ``(A, U)``, in the order measured) is a step too long rather than a turn in A: A rising with
    the drive (:func:`rises_with_drive`), or A rising as the drive falls (up the stable side
    towards the F1 minimum: away from the grazing hairpin's turn, which is approached with A
    falling as the drive rises). A that did not move: no secant, ``False``."""
    return rises_with_drive(previous, last) or (last[0] > previous[0] and last[1] < previous[1])


__all__ = ["ARC_TOLERANCE", "STEP_CUTS", "ArcStep", "extrapolate", "no_turn_ahead", "rises_with_drive"]
