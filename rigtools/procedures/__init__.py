"""Lab procedures on :class:`rigtools.acquisition.BlockStream`, shared by lab scripts and the CLI.

A force-controlled dwell (15 N at 60 Hz, gap 0.5 mm, 10 periods recorded) on the simulated rig:

>>> from rigtools.config import load_rig
>>> from rigtools.procedures import SineDwell
>>> params = {"fe": 60.0, "force": 15.0, "gap": 5e-4, "record_periods": 10}
>>> result = SineDwell(load_rig(), params, "dwell.h5", backend="sim").run()
>>> point = result.points[0]
>>> result.status.value, point["settled"], f"F1 = {point['force_amplitude_measured']:.0f} N"
('finished', True, 'F1 = 15 N')

The other procedures (:class:`SteppedSine`, :class:`RigStudy`, :class:`FrfTest`,
:class:`TapTest`) are used the same way.

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
from rigtools.procedures.dwell import DwellParameters, SineDwell
from rigtools.procedures.frf import FrfParameters, FrfTest
from rigtools.procedures.reference import reference_table
from rigtools.procedures.rig_study import RigStudy, StudyParameters
from rigtools.procedures.sine import ControlParameters, SineProcedure
from rigtools.procedures.sweep import SteppedSine, SweepParameters, detect_jumps
from rigtools.procedures.tap import TapParameters, TapTest

__all__ = [
    "ControlParameters",
    "DwellParameters",
    "FrfParameters",
    "FrfTest",
    "Procedure",
    "ProcedureFailed",
    "ProcedureResult",
    "ProgressEvent",
    "RigStudy",
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
