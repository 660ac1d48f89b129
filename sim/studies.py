"""Parameter studies of the vibro-impact response (the paper's Figures 10-16).

* gap study: gap varies, F0 = 15 N, fe = 60 Hz;
* force study: F0 varies, gap = 0.7 mm, fe = 60 Hz;
* frequency study: fe varies, gap = 0.7 mm, F0 = 15 N; swept ``up``, ``down`` or ``both``
  (up, then back down), carrying the state from point to point so that jumps and hysteresis
  between coexisting responses show.

Every point is run to a detected steady state (:func:`rigtools.sim.vibro_impact.run_harmonic`). By default
each point starts from the previous point's final state (``carry_state``), which is what a slow
sweep on the rig does and settles faster; ``carry_state=False`` starts every point from rest.
Progress is reported through an optional callback ``progress(done, total, text)``.

:func:`iter_study` yields each point as it settles and keeps nothing but the carried state, so a
caller can write every point as soon as it exists (``rig study`` does, through
``rigtools.simulation.write_study``); :func:`run_study` keeps every run in memory on top of it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from rigtools.sim.reduction import ReducedSystem
from rigtools.sim.vibro_impact import RunState, SimulationInputError, VibroImpactRun, run_harmonic

StudyKind = Literal["gap", "force", "frequency"]
Direction = Literal["up", "down", "both"]
Progress = Callable[[int, int, str], None]

DEFAULTS = {  # the paper's fixed parameters of each study
    "gap": {"fe": 60.0, "force": 15.0},
    "force": {"fe": 60.0, "gap": 0.7e-3},
    "frequency": {"force": 15.0, "gap": 0.7e-3},
}
UNITS = {"gap": "m", "force": "N", "frequency": "Hz"}


@dataclass
class StudyPoint:
    """One point of a study: the swept value, the sweep direction and the settled run."""

    value: float
    direction: str
    run: VibroImpactRun

    @property
    def fe(self) -> float:
        return self.run.fe

    @property
    def force_amplitude(self) -> float:
        return self.run.force_amplitude

    @property
    def gap(self) -> float:
        return self.run.gap


@dataclass
class Study:
    """A finished study."""

    kind: str
    fixed: dict
    points: list[StudyPoint] = field(default_factory=list)

    def values(self, direction: str | None = None) -> np.ndarray:
        return np.array([p.value for p in self.points if direction in (None, p.direction)])

    def peak_contact_force(self, direction: str | None = None) -> np.ndarray:
        return np.array([p.run.peak_contact_force for p in self.points if direction in (None, p.direction)])


SWEPT = {"gap": "gap", "force": "force", "frequency": "fe"}  # study kind -> swept parameter


@dataclass(frozen=True)
class PlannedPoint:
    """One point of a study plan: its place in run order and every parameter it runs at (SI)."""

    index: int  # run order, from 0
    value: float  # the swept value
    direction: str  # "up" or "down"
    fe: float  # Hz
    force: float  # force amplitude F0, N
    gap: float  # m


@dataclass(frozen=True)
class StudyPlan:
    """What a study runs, in which order, and whether state carries from point to point.

    Shared by model studies (:func:`iter_study`) and rig studies (``rigtools.procedures``), so both
    sweep the same values in the same order.

    Parameters
    ----------
    kind
        ``"gap"`` (values in m), ``"force"`` (N) or ``"frequency"`` (Hz).
    values
        The swept values (any order; run order comes from ``direction``).
    direction
        ``"up"``, ``"down"`` or ``"both"`` (up, then back down without repeating the top value).
    fe, force, gap
        The fixed parameters; ``None`` takes the paper's (:data:`DEFAULTS`). The swept one is ignored.
    carry_state
        Each point starts from the previous point's final state (a slow sweep, as on the rig);
        ``False``: every point starts from rest.
    """

    kind: str
    values: tuple[float, ...]
    direction: str = "up"
    fe: float | None = None
    force: float | None = None
    gap: float | None = None
    carry_state: bool = True

    def __post_init__(self) -> None:
        if self.kind not in DEFAULTS:
            raise SimulationInputError(f"study kind must be gap, force or frequency, got {self.kind!r}")
        object.__setattr__(self, "values", tuple(float(v) for v in self.values))
        defaults = DEFAULTS[self.kind]
        for key in ("fe", "force", "gap"):
            if getattr(self, key) is None and key in defaults:
                object.__setattr__(self, key, float(defaults[key]))
        what = {"gap": "gap", "force": "force amplitude", "frequency": "frequency"}[self.kind]
        for v in self.values:
            if not np.isfinite(v) or v < 0 or (self.kind == "frequency" and v <= 0):
                raise SimulationInputError(
                    f"{what} values must be {'> 0' if self.kind == 'frequency' else '>= 0'}, got {v:g}"
                )
        sweep_order(self.values, self.direction)  # checks direction and emptiness

    @property
    def fixed(self) -> dict[str, float]:
        """The fixed parameters (``fe``, ``force``, ``gap`` without the swept one), SI."""
        return {k: getattr(self, k) for k in ("fe", "force", "gap") if k != SWEPT[self.kind]}

    def points(self) -> list[PlannedPoint]:
        """Every point in run order."""
        out = []
        for i, (v, d) in enumerate(sweep_order(self.values, self.direction)):
            p = {**self.fixed, SWEPT[self.kind]: v}
            out.append(
                PlannedPoint(index=i, value=v, direction=d, fe=p["fe"], force=p["force"], gap=p["gap"])
            )
        return out

    def chains(self) -> list[list[PlannedPoint]]:
        """Independent chains of points: the whole sweep when state carries, else one per point."""
        pts = self.points()
        return [pts] if self.carry_state else [[p] for p in pts]

    def to_dict(self) -> dict:
        """JSON-able description (for a recording's experiment attribute)."""
        return {
            "kind": self.kind,
            "values": list(self.values),
            "direction": self.direction,
            "fixed": self.fixed,
            "carry_state": self.carry_state,
        }


def sweep_order(values: Iterable[float], direction: str) -> list[tuple[float, str]]:
    """The values in run order with their direction: ``up`` ascending, ``down`` descending,
    ``both`` ascending then descending (the turning value is not repeated); any other
    ``direction`` (a :data:`Direction` is expected) is refused."""
    vals = sorted(float(v) for v in values)
    if not vals:
        raise SimulationInputError("a study needs at least one value")
    if direction == "up":
        return [(v, "up") for v in vals]
    if direction == "down":
        return [(v, "down") for v in vals[::-1]]
    if direction == "both":
        return [(v, "up") for v in vals] + [(v, "down") for v in vals[::-1][1:]]
    raise SimulationInputError(f"direction must be up, down or both, got {direction!r}")


@dataclass(frozen=True)
class MapPlan:
    """A gap x F0 x fe map: one frequency sweep per (gap, F0) pair.

    Points are numbered row-major (gap, then F0, then fe in sweep order); each (gap, F0) pair is
    one chain whose points carry state (``carry_state``) or, from rest, a chain per point. Shared
    by model and rig maps like :class:`StudyPlan`.
    """

    gaps: tuple[float, ...]
    forces: tuple[float, ...]
    fes: tuple[float, ...]
    direction: str = "up"
    carry_state: bool = True
    kind: str = "map"

    def __post_init__(self) -> None:
        for name in ("gaps", "forces", "fes"):
            object.__setattr__(self, name, tuple(float(v) for v in getattr(self, name)))
            if not getattr(self, name):
                raise SimulationInputError(f"a map needs at least one value in {name}")
        for gap in self.gaps:
            for force in self.forces:  # validates every value and the direction
                StudyPlan("frequency", self.fes, self.direction, force=force, gap=gap)

    @property
    def fixed(self) -> dict[str, float]:
        return {}

    def chains(self) -> list[list[PlannedPoint]]:
        """The chains in point order (see the class docstring)."""
        out, index = [], 0
        for gap in self.gaps:
            for force in self.forces:
                plan = StudyPlan(
                    "frequency", self.fes, self.direction, force=force, gap=gap, carry_state=self.carry_state
                )
                for chain in plan.chains():
                    renumbered = []
                    for p in chain:
                        renumbered.append(
                            PlannedPoint(
                                index=index,
                                value=p.value,
                                direction=p.direction,
                                fe=p.fe,
                                force=p.force,
                                gap=p.gap,
                            )
                        )
                        index += 1
                    out.append(renumbered)
        return out

    def points(self) -> list[PlannedPoint]:
        """Every point in run order."""
        return [p for chain in self.chains() for p in chain]

    def to_dict(self) -> dict:
        return {
            "kind": "map",
            "gaps": list(self.gaps),
            "forces": list(self.forces),
            "fes": list(self.fes),
            "direction": self.direction,
            "carry_state": self.carry_state,
        }


def iter_study(
    system: ReducedSystem,
    plan: StudyPlan,
    *,
    start: int = 0,
    initial: RunState | None = None,
    record_duration: float | None = None,
    **run_options,
) -> Iterator[tuple[PlannedPoint, VibroImpactRun]]:
    """Run a study plan point by point, yielding ``(planned point, settled run)`` as each finishes.

    Nothing is kept between points but the carried state, so memory does not grow with the
    number of points; the caller writes each point as it comes.

    Parameters
    ----------
    system
        Reduced rig (its contact stiffness/law are used; the gap is set per point).
    plan
        The study.
    start
        Index of the first point to run (resuming: earlier points are skipped).
    initial
        State to start from (resuming a carried-state sweep); ``None`` from rest.
    record_duration
        Recorded time per point, s (whole periods, at least one); overrides ``record_periods``.
    **run_options
        Passed to :func:`rigtools.sim.vibro_impact.run_harmonic` (``record_periods``, ``tol``, ...).
    """
    state = initial
    for point in plan.points()[start:]:
        sysp = system.with_contact(gap=point.gap)
        opts = dict(run_options)
        if record_duration is not None:
            opts["record_periods"] = max(1, round(record_duration * point.fe))
        run = run_harmonic(sysp, point.fe, point.force, initial=state if plan.carry_state else None, **opts)
        state = run.final_state
        yield point, run


def run_study(
    system: ReducedSystem,
    kind: StudyKind,
    values: Iterable[float],
    *,
    fe: float | None = None,
    force: float | None = None,
    gap: float | None = None,
    direction: Direction = "up",
    carry_state: bool = True,
    progress: Progress | None = None,
    record_duration: float | None = None,
    **run_options,
) -> Study:
    """Run a gap, force or frequency study and keep every point in memory (see :func:`iter_study`
    to stream points instead).

    Parameters
    ----------
    system
        Reduced rig (its contact stiffness/law are used; the gap is set per point).
    kind
        ``"gap"`` (values in m), ``"force"`` (N) or ``"frequency"`` (Hz).
    values
        The swept values.
    fe, force, gap
        The fixed parameters (defaults: the paper's, see :data:`DEFAULTS`).
    direction
        ``"up"``, ``"down"`` or ``"both"`` (any kind; most useful for frequency sweeps).
    carry_state
        Start each point from the previous one's final state (default) or from rest.
    progress
        ``progress(done, total, text)`` after each point.
    record_duration
        Recorded time per point, s (whole periods, at least one); overrides ``record_periods``.
    **run_options
        Passed to :func:`rigtools.sim.vibro_impact.run_harmonic` (``record_periods``, ``tol``, ...).

    Returns
    -------
    Study

    Examples
    --------
    Two gaps at 60 Hz and 15 N, each run to steady state; the peak contact force of each, N:

    >>> import numpy as np
    >>> import rigtools
    >>> from rigtools.sim.reduction import reduced_system
    >>> from rigtools.sim.studies import run_study
    >>> system = reduced_system(rigtools.load_rig().to_params(), "fem")
    >>> study = run_study(system, "gap", [0.4e-3, 0.6e-3], fe=60.0, force=15.0, record_periods=4)
    >>> np.round(study.peak_contact_force(), 1)
    array([46.8, 55. ])
    """
    plan = StudyPlan(kind, tuple(values), direction, fe=fe, force=force, gap=gap, carry_state=carry_state)
    study = Study(kind=kind, fixed=plan.fixed)
    total = len(plan.points())
    for point, run in iter_study(system, plan, record_duration=record_duration, **run_options):
        study.points.append(StudyPoint(value=point.value, direction=point.direction, run=run))
        if progress is not None:
            progress(point.index + 1, total, f"{kind} {point.value:g} {UNITS[kind]} ({point.direction})")
    return study
