"""Model runs at the EM points of a comparison (``rig compare --simulate``): each point driven by
the EM force's harmonics (``excitation="measured"``) or by ``F0 sin`` (``"nominal"``), through
:class:`rigtools.study_runner.StudyRunner`, carrying the state from point to point when the EM
study did."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from rigtools.comparison_points import em_force_harmonics
from rigtools.errors import UserError
from rigtools.sim.studies import PlannedPoint
from rigtools.sim.vibro_impact import SimulationInputError
from rigtools.simulation import check_finite
from rigtools.study_runner import RunOptions, StudyRunner, run_point

MODEL_RECORD_PERIODS = 10
Progress = Callable[[int, int, str], None]


@dataclass(frozen=True)
class DrivenPoint(PlannedPoint):
    """A planned point with the periodic force that drives it (``None``: ``F0 sin``)."""

    force_harmonics: tuple | None = None


def run_driven_point(system, point: DrivenPoint, options, previous=None):
    """:func:`rigtools.study_runner.run_point` with the point's ``force_harmonics``."""
    return run_point(system, point, options, previous, force_harmonics=point.force_harmonics)


def simulate_em_points(
    system,
    em_points: Sequence[tuple[dict, Any]],
    excitation: str,
    *,
    carry_state: bool = True,
    workers: int | None = None,
    max_settle_time: float = 30.0,
    progress: Progress | None = None,
) -> list:
    """Model runs at the EM points: ``em_points`` is ``[(params, DwellAnalysis)]``; returns the runs."""
    planned = []
    for i, (params, ana) in enumerate(em_points):
        f1 = float(ana.force_amplitude)
        harm = tuple(em_force_harmonics(ana)) if excitation == "measured" else None
        gap = params.get("gap")
        if gap is None:
            raise UserError(f"EM point {i} has no gap parameter: cannot simulate it")
        planned.append(
            DrivenPoint(
                index=i,
                value=float(params.get("study_value", i)),
                direction=str(params.get("direction", "up")),
                fe=float(params["fe"]),
                force=f1,
                gap=float(gap),
                force_harmonics=harm,
            )
        )
    chains = [planned] if carry_state else [[p] for p in planned]
    fe_min = min(p.fe for p in planned)
    options = RunOptions(record_duration=MODEL_RECORD_PERIODS / fe_min, max_settle_time=max_settle_time)
    runs = []
    try:
        with StudyRunner(workers=workers) as runner:
            for _, run in runner.run(system, chains, options, progress=progress, point_fn=run_driven_point):
                check_finite(run)
                runs.append(run)
    except SimulationInputError as exc:
        raise UserError(str(exc)) from None
    return runs
