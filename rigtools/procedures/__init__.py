"""Lab procedures on :class:`rigtools.acquisition.BlockStream`, shared by lab scripts and the CLI.

>>> from rigtools.procedures import SineDwell, SteppedSine, RigStudy, FrfTest, TapTest  # doctest: +SKIP
>>> result = SineDwell(cfg, {"fe": 60.0, "force": 15.0, "gap": 5e-4}, "d.h5", backend="sim").run()

Every procedure validates its parameters (pydantic, SI units), runs start-up -> execute ->
shut-down (in ``finally``) and records its end status (``finished`` / ``aborted`` / ``failed``)
with the reason; see :mod:`rigtools.procedures.base`.
"""

from rigtools.procedures.base import (
    Procedure,
    ProcedureFailed,
    ProcedureResult,
    ProgressEvent,
    Status,
    StopRequested,
)
from rigtools.procedures.dwell import ControlParameters, DwellParameters, SineDwell
from rigtools.procedures.sweep import (
    RigStudy,
    SteppedSine,
    StudyParameters,
    SweepParameters,
    detect_jumps,
)
from rigtools.procedures.tap import TapParameters, TapTest

__all__ = [
    "ControlParameters",
    "DwellParameters",
    "Procedure",
    "ProcedureFailed",
    "ProcedureResult",
    "ProgressEvent",
    "RigStudy",
    "SineDwell",
    "Status",
    "SteppedSine",
    "StopRequested",
    "StudyParameters",
    "SweepParameters",
    "TapParameters",
    "TapTest",
    "detect_jumps",
]
