"""The result of a continuation: :class:`Branch`, its :class:`BranchPoint` orbits and their labels.

A point carries labels (:data:`BIFURCATIONS` and ``start``, ``end``, ``failed``,
``branch-switch``); a branch records its bifurcations (:class:`rigtools.sim.bifurcations.Bifurcation`)
and how it ended (``status``, ``message``). Built by :mod:`rigtools.sim.continuation`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from rigtools.sim.bifurcations import FOLD, NEIMARK_SACKER, PERIOD_DOUBLING, Bifurcation
from rigtools.sim.contact_events import CONTACT_SPLIT, GRAZING, STICKING, ContactStructure
from rigtools.sim.orbit_map import Forcing, OrbitMeasures

# labels a point may carry: the smooth bifurcations (rigtools.sim.bifurcations), the non-smooth
# events (rigtools.sim.contact_events: grazing, contact-split, sticking) and these
START, END, FAILED, SWITCH = "start", "end", "failed", "branch-switch"
BIFURCATIONS = (FOLD, PERIOD_DOUBLING, NEIMARK_SACKER, GRAZING, CONTACT_SPLIT, STICKING)


@dataclass(frozen=True)
class BranchPoint:
    """One periodic orbit on a branch.

    Attributes
    ----------
    param, value
        The continued parameter (``"fe"``, ``"force"``, ``"gap"``) and its value (Hz, N or V, m).
    forcing
        All three quantities at this point.
    periods
        Forcing periods of the orbit (1, or 2 on a period-2 branch).
    state
        ``(q, v)`` (plus the coil current with a shaker, and the drive amplitude under force
        control) at force phase zero, modal coordinates of :attr:`rigtools.sim.orbit_map.PeriodMap.system`.
    multipliers
        Floquet multipliers (eigenvalues of the monodromy matrix), sorted by decreasing modulus.
    stable
        Every multiplier has modulus below 1.
    labels
        ``start``, ``end``, ``failed`` (last good point before a failure), ``branch-switch``, the
        smooth bifurcations (``fold``, ``period-doubling``, ``neimark-sacker``) and the non-smooth
        events (``grazing``, ``contact-split``, ``sticking``), see :data:`BIFURCATIONS`.
    measures
        :class:`OrbitMeasures`.
    tangent_param
        Parameter component of the unit tangent (scaled), which changes sign at a fold.
    newton_iterations
        Corrector iterations it took.
    contact
        The orbit's contact-event structure (:class:`rigtools.sim.contact_events.ContactStructure`).
    """

    param: str
    value: float
    forcing: Forcing
    periods: int
    state: np.ndarray = field(repr=False)
    multipliers: np.ndarray = field(repr=False)
    stable: bool
    labels: tuple[str, ...]
    measures: OrbitMeasures = field(repr=False)
    tangent_param: float = 0.0
    newton_iterations: int = 0
    contact: ContactStructure = field(default=ContactStructure(), repr=False)

    @property
    def max_multiplier(self) -> float:
        return float(np.max(np.abs(self.multipliers))) if self.multipliers.size else 0.0


@dataclass
class Branch:
    """A continued branch: points in arclength order, how it ended.

    ``status`` is ``"complete"`` (reached the end value; a switched branch: left the range for the
    last time, after coming back into it if it went out), ``"failed"`` (a point did not converge;
    ``message`` says where and why, the last point is the last good one), ``"left range"`` (the
    branch turned back out of the range; a switched branch: went out and did not come back where
    it is followed, see :func:`rigtools.sim.branch_switching.switch_period_doubling`), ``"max points"``, ``"merged"`` (a period-2
    branch returned onto the period-1 branch), ``"closed"`` (the branch came back to its first
    point: a closed loop, its last point that first orbit again) or ``"interrupted"``
    (:class:`KeyboardInterrupt` while it was followed: its points so far). A failure inside the
    tracer (a diverged integration, a singular matrix) is ``"failed"`` too, with its reason.

    ``bifurcations`` holds one :class:`rigtools.sim.bifurcations.Bifurcation` per labelled
    bifurcation or event, in branch order, with its critical multiplier and its location refined
    to a converged time step (:mod:`rigtools.sim.bifurcation_refine`).
    """

    param: str
    periods: int
    points: list[BranchPoint] = field(default_factory=list)
    status: str = "complete"
    message: str = ""
    steps_per_period: int = 0
    bifurcations: list[Bifurcation] = field(default_factory=list)

    def values(self) -> np.ndarray:
        return np.array([p.value for p in self.points])

    def stable(self) -> np.ndarray:
        return np.array([p.stable for p in self.points], dtype=bool)

    def measure(self, name: str) -> np.ndarray:
        """One :class:`OrbitMeasures` field per point (arrays stack, e.g. ``(n, 10)`` harmonics)."""
        return np.array([getattr(p.measures, name) for p in self.points])

    def labelled(self, label: str | None = None) -> list[BranchPoint]:
        """The points carrying ``label`` (any bifurcation label if ``None``)."""
        want = BIFURCATIONS if label is None else (label,)
        return [p for p in self.points if any(lab in want for lab in p.labels)]


def relabel(branch: Branch, index: int, label: str) -> None:
    p = branch.points[index]
    if label not in p.labels:
        branch.points[index] = replace(p, labels=(*p.labels, label))


def unlabel(branch: Branch, index: int, label: str) -> None:
    p = branch.points[index]
    branch.points[index] = replace(p, labels=tuple(lab for lab in p.labels if lab != label))
