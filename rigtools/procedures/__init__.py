"""Lab procedures on :class:`rigtools.acquisition.BlockStream`, shared by lab scripts and the CLI.

A force-controlled dwell (15 N at 60 Hz, gap 0.5 mm, 10 periods recorded) on the simulated rig:

>>> from rigtools.config import load_rig
>>> from rigtools.procedures import SineDwell
>>> params = {"fe": 60.0, "force": 15.0, "gap": 5e-4, "record_periods": 10}
>>> result = SineDwell(load_rig(), params, "dwell.h5", backend="sim").run()
>>> point = result.points[0]
>>> result.status, point.settled, f"F1 = {point.force_amplitude_measured:.0f} N"
('finished', True, 'F1 = 15 N')

The other procedures (:class:`SteppedSine`, :class:`RigStudy`, :class:`FrfTest`,
:class:`TapTest`) are used the same way. Every one returns a :class:`RunResult`, the type the
front door's functions (:func:`rigtools.dwell`, ...) return too.

Every procedure validates its parameters (pydantic, SI units), runs start-up -> execute ->
shut-down (in ``finally``) and records its end status (``finished`` / ``aborted`` / ``failed``)
with the reason; see :mod:`rigtools.procedures.base`.
"""

from typing import Any

from rigtools.procedures.base import (
    Procedure,
    ProcedureFailed,
    ProgressEvent,
    StopRequested,
)
from rigtools.procedures.dwell import DwellParameters, SineDwell
from rigtools.procedures.frf import FrfParameters, FrfTest
from rigtools.procedures.reference import reference_table
from rigtools.procedures.result import PointResult, RunResult, Status
from rigtools.procedures.rig_study import RigStudy, StudyParameters
from rigtools.procedures.sine import ControlParameters, SineProcedure
from rigtools.procedures.sweep import SteppedSine, SweepParameters, detect_jumps
from rigtools.procedures.tap import TapParameters, TapTest

__all__ = [
    "ControlParameters",
    "DwellParameters",
    "FrfParameters",
    "FrfTest",
    "PointResult",
    "Procedure",
    "ProcedureFailed",
    "ProgressEvent",
    "RigStudy",
    "RunResult",
    "SineDwell",
    "SineProcedure",
    "Status",
    "SteppedSine",
    "StopRequested",
    "StudyParameters",
    "SweepParameters",
    "TapParameters",
    "TapTest",
    "detect_jumps",
    "reference_table",
]


def __getattr__(name: str) -> Any:
    if name == "ProcedureResult":
        import warnings

        warnings.warn(
            "rigtools.procedures.ProcedureResult is deprecated: every procedure's run() returns a "
            "RunResult (rigtools.procedures.RunResult, the type rigtools.dwell and the others return)",
            DeprecationWarning,
            stacklevel=2,
        )
        return RunResult
    raise AttributeError(f"module 'rigtools.procedures' has no attribute {name!r}")
