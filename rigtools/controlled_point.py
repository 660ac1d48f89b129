"""One measured point of a controlled nonlinear test (phase-locked loop or control-based continuation).

The same record for both procedures, so ``rig acquire pll`` and ``rig acquire cbc`` print, store and
report their points alike (``--json`` lists :meth:`ControlledPoint.to_dict` per point).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any


@dataclass(frozen=True)
class ControlledPoint:
    """A converged (or given-up) point of a controlled test.

    Attributes
    ----------
    fe_hz : float
        Excitation frequency, Hz.
    amplitude_m : float
        Displacement amplitude of the active shroud's fundamental, m.
    force_fundamental_n : float
        Amplitude of the force's fundamental, N.
    phase_deg : float
        Phase of the response's fundamental relative to the force's, degrees.
    converged : bool
        Whether the point met its procedure's convergence criteria.
    iterations : int
        Iterations (PLL: control periods to lock; CBC: outer iterations) the point took.
    drive_harmonics_ratio : float
        RMS of harmonics 2-10 of the drive voltage over its fundamental (0 for a pure sine).
    """

    fe_hz: float
    amplitude_m: float
    force_fundamental_n: float
    phase_deg: float
    converged: bool
    iterations: int
    drive_harmonics_ratio: float

    def to_dict(self) -> dict[str, Any]:
        """The point as plain JSON values, keys as in ``--json``."""
        return asdict(self)
