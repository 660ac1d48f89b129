"""Parameter studies of the vibro-impact response (the paper's Figures 10-16).

* gap study: gap varies, F0 = 15 N, fe = 60 Hz;
* force study: F0 varies, gap = 0.7 mm, fe = 60 Hz;
* frequency study: fe varies, gap = 0.7 mm, F0 = 15 N; swept ``up``, ``down`` or ``both``
  (up, then back down), carrying the state from point to point so that jumps and hysteresis
  between coexisting responses show.

Every point is run to a detected steady state (:func:`sim.vibro_impact.run_harmonic`). By default
each point starts from the previous point's final state (``carry_state``), which is what a slow
sweep on the rig does and settles faster; ``carry_state=False`` starts every point from rest.
Progress is reported through an optional callback ``progress(done, total, text)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterable, Literal

import numpy as np

from sim.reduction import ReducedSystem
from sim.vibro_impact import RunState, SimulationInputError, VibroImpactRun, run_harmonic

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


def sweep_order(values: Iterable[float], direction: Direction) -> list[tuple[float, str]]:
    """The values in run order with their direction: ``up`` ascending, ``down`` descending,
    ``both`` ascending then descending (the turning value is not repeated)."""
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


def run_study(system: ReducedSystem, kind: StudyKind, values: Iterable[float], *,
              fe: float | None = None, force: float | None = None, gap: float | None = None,
              direction: Direction = "up", carry_state: bool = True,
              progress: Progress | None = None, record_duration: float | None = None,
              **run_options) -> Study:
    """Run a gap, force or frequency study.

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
        Passed to :func:`sim.vibro_impact.run_harmonic` (``record_periods``, ``tol``, ...).

    Returns
    -------
    Study
    """
    if kind not in DEFAULTS:
        raise SimulationInputError(f"study kind must be gap, force or frequency, got {kind!r}")
    fixed = {"fe": fe, "force": force, "gap": gap}
    for key, val in DEFAULTS[kind].items():
        if fixed[key] is None:
            fixed[key] = val
    fixed.pop({"gap": "gap", "force": "force", "frequency": "fe"}[kind])
    order = sweep_order(values, direction)
    for v, _ in order:
        if not np.isfinite(v) or v < 0 or (kind == "frequency" and v <= 0):
            what = {"gap": "gap", "force": "force amplitude", "frequency": "frequency"}[kind]
            raise SimulationInputError(f"{what} values must be {'> 0' if kind == 'frequency' else '>= 0'}, got {v:g}")
    study = Study(kind=kind, fixed=dict(fixed))
    state: RunState | None = None
    for i, (v, d) in enumerate(order):
        p = dict(fixed)
        p[{"gap": "gap", "force": "force", "frequency": "fe"}[kind]] = v
        sysp = system.with_contact(gap=p["gap"])
        opts = dict(run_options)
        if record_duration is not None:
            opts["record_periods"] = max(1, int(round(record_duration * p["fe"])))
        run = run_harmonic(sysp, p["fe"], p["force"], initial=state if carry_state else None, **opts)
        state = run.final_state
        study.points.append(StudyPoint(value=v, direction=d, run=run))
        if progress is not None:
            progress(i + 1, len(order), f"{kind} {v:g} {UNITS[kind]} ({d})")
    return study
