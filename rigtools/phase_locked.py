"""The front door's phase-locked-loop test: :func:`phase_locked_loop` (``rig acquire pll``)."""

from __future__ import annotations

import numbers
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from rigtools.config import RigConfig, load_rig
from rigtools.errors import UserError, reword
from rigtools.experiments import NO_BACKEND
from rigtools.keywords import unknown_keyword
from rigtools.options import seed as seed_option
from rigtools.procedures.base import ProgressEvent
from rigtools.procedures.pll import PhaseLockedLoop, PllParameters
from rigtools.procedures.pll_options import OPTIONS, pll_parameters
from rigtools.procedures.result import RunResult

# the words the options parser reads from text (units), besides the force and phase lists
_TEXT_WORDS = ("fe_start", "f_min", "f_max", "lock_tolerance", "phase_rate", "max_amplitude")
# the options parser's words in this door's: its keywords
_KEYWORDS = {"--force": "forces", "--phase": "phases", **{option: name for name, option in OPTIONS.items()}}


def _joined(values: Sequence[float | str] | float | str, unit: str) -> str:
    if isinstance(values, (str, float, int, numbers.Real)):  # numbers.Real: numpy scalars (np.int64(5))
        values = [values]
    return ",".join(v if isinstance(v, str) else f"{float(v)!r} {unit}" for v in values)


def phase_locked_loop(
    forces: Sequence[float | str] | float | str,
    out: str | Path,
    *,
    phases: Sequence[float | str] | float | str = "-90 deg",
    gap: float | str | None = None,
    fe_start: float | str | None = None,
    rig: Any = None,
    backend: str | None = None,
    overwrite: bool = False,
    progress: Callable[[ProgressEvent], None] | None = None,
    seed: int | None = None,
    **params: Any,
) -> RunResult:
    """Phase-locked-loop test: hold the response's phase to the force by the drive frequency.

    One phase and several forces trace the backbone (-90 deg); one force and several phases the
    frequency response under phase control, through the fold (:mod:`rigtools.procedures.pll`).

    Parameters
    ----------
    forces
        Force fundamental per point: ``"5 N"``, ``"1 N,2 N"``, ``[1.0, 2.0]`` (N).
    out
        Recording to write (HDF5).
    phases
        Target phase per point, with a unit (``"-90 deg"``, ``"-152 deg,-156 deg"``); plain
        numbers are degrees.
    gap
        Shroud gap, ``"0.5 mm"`` or m; ``None``: as set.
    fe_start
        Where the first point starts, ``"52 Hz"`` or Hz; ``None``: the rig file's nominal model's
        frequency at the first phase, without contact.
    rig, backend, overwrite, progress, seed
        As :func:`rigtools.dwell` (``backend`` has no default: ``"sim"`` or ``"nidaq"``).
    **params
        More :class:`rigtools.procedures.pll.PllParameters` (``kp``, ``ki``, ``lock_periods``,
        ``lock_tolerance``, ``max_periods``, ``record_periods``, ``max_amplitude``,
        ``on_lock_loss``, ...).

    Returns
    -------
    RunResult
        One point per target; ``point.extra`` holds the :class:`~rigtools.controlled_point.ControlledPoint` fields
        (``fe_hz``, ``amplitude_m``, ``phase_deg``, ``converged``, ``iterations``, ...).

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "pll.h5"
    >>> run = rigtools.phase_locked_loop("0.2 N", out, gap="0.5 mm", backend="sim")
    >>> point = run.points[0].extra
    >>> point["converged"], round(point["fe_hz"], 1), round(point["phase_deg"])
    (True, 52.0, -90)
    """
    for name in params:
        if name not in PllParameters.model_fields or name in ("forces", "phases", "gap", "fe_start"):
            raise unknown_keyword("rigtools.phase_locked_loop", name, PllParameters.model_fields)
    if backend is None:
        raise UserError(NO_BACKEND)
    if backend not in ("sim", "nidaq"):
        raise UserError(f'backend = {backend!r}: use "sim" (the simulated rig) or "nidaq" (the NI rig)')
    cfg = rig if isinstance(rig, RigConfig) else load_rig(rig)
    plain = {k: v for k, v in params.items() if k not in _TEXT_WORDS or not isinstance(v, str)}
    text = {k: v for k, v in params.items() if k in _TEXT_WORDS and isinstance(v, str)}
    options = {"force": _joined(forces, "N"), "phase": _joined(phases, "deg"), "gap": gap, **text}
    if fe_start is not None:
        options["fe_start"] = fe_start if isinstance(fe_start, str) else f"{float(fe_start)!r} Hz"
    try:
        values = {**pll_parameters(cfg, options), **plain}
        proc = PhaseLockedLoop(
            cfg,
            values,
            out,
            backend=backend,
            overwrite=overwrite,
            progress=progress,
            seed=seed_option(seed, "seed"),
        )
        return proc.run()
    except Exception as exc:  # re-raised, its advice in a script's words
        reword(exc, _KEYWORDS)
        raise
