"""The control-based continuation from a script or the command line: the front door
:func:`control_based_continuation`, ``rig acquire cbc``'s :func:`from_options` and its ``--json``
document (:func:`json_document`), the gains' grammar (:func:`parse_gains`); the procedure itself
is :mod:`rigtools.procedures.cbc`."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rigtools.config import load_rig
from rigtools.drivers.realtime import NO_REALTIME_LOOP
from rigtools.errors import UserError
from rigtools.keywords import unknown_keyword
from rigtools.options import gap as gap_text
from rigtools.options import quantity, value_list
from rigtools.procedures.base import ProgressEvent
from rigtools.procedures.cbc import CBCParameters, ControlBasedContinuation

#: The command's option of each parameter its one-line errors may name (``rig acquire cbc``).
OPTIONS = {
    "max_iterations": "--max-iterations",
    "tolerance": "--tolerance",
    "release_seconds": "--release",
    "kp": "--gains",
    "kd": "--gains",
    "amplitudes": "--amplitude",
    "inner_loop": "--inner-loop",
}


def control_based_continuation(
    fe: float | str,
    amplitudes: Any,
    out: str | Path,
    *,
    gap: float | str | None = None,
    gains: Any = None,
    rig: Any = None,
    backend: str | None = None,
    overwrite: bool = False,
    progress: Callable[[ProgressEvent], None] | None = None,
    seed: int | None = None,
    inner_loop: str | None = None,
    **params: Any,
):
    """Control-based continuation of the rig's orbits in the target amplitude at one frequency.

    Parameters
    ----------
    fe
        Excitation frequency, ``"64 Hz"`` or Hz.
    amplitudes
        Target fundamental amplitudes of the active shroud: ``"0.300 mm:0.360 mm:0.005 mm"``,
        ``"0.3 mm,0.32 mm"`` or a sequence of m.
    out
        Recording to write (HDF5; procedure ``cbc``).
    gap
        Shroud gap (``"0.5 mm"`` or m); ``None``: as set.
    gains
        ``(kp V/m, kd V s/m)``, ``"KP,KD"`` or ``None`` (the defaults of :class:`~rigtools.procedures.cbc.CBCParameters`);
        ``0`` for none (open loop).
    rig, backend, overwrite, progress, seed
        As :func:`rigtools.dwell` (``backend`` ``"nidaq"`` or ``"sim"``, no default).
    inner_loop
        ``"realtime"`` (the backend's per-sample loop; gains 2000 V/m, 2-3.5 V s/m unless given;
        each point's multipliers measured), ``"buffered"``, or ``None``: realtime where the
        backend has one, else buffered with the one-line note.
    **params
        More :class:`~rigtools.procedures.cbc.CBCParameters` (``tolerance``, ``max_iterations``, ``release_seconds``, ...).

    Returns
    -------
    RunResult
        Its points carry the :class:`~rigtools.controlled_point.ControlledPoint`
        fields and the control effort (``point.extra``).

    Raises
    ------
    rigtools.errors.TargetNotReached
        No target converged (e.g. every one past grazing): the drive at rest, the recording kept
        with status failed and the reason (``rig acquire cbc``: exit 5).

    Examples
    --------
    One point on the stable side of the F1 minimum at 64 Hz (the model: 4.93 N at A 0.3196 mm):

    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "cbc.h5"
    >>> run = rigtools.control_based_continuation(
    ...     "64 Hz", "0.32 mm", out, gap="0.5 mm", backend="sim", inner_loop="buffered"
    ... )
    >>> p = run.points[0].extra
    >>> p["converged"], round(p["force_fundamental_n"], 1), p["drive_harmonics_ratio"] < 0.01
    (True, 4.9, True)
    """

    for name in params:  # else one line "unknown key", naming neither the door nor the keywords
        if name not in CBCParameters.model_fields or name in ("fe", "amplitudes", "gap"):
            raise unknown_keyword("rigtools.control_based_continuation", name, CBCParameters.model_fields)
    if backend not in ("nidaq", "sim"):
        raise UserError(f"backend = {backend!r}: name backend='nidaq' or backend='sim'")
    cfg = rig if hasattr(rig, "safety") else load_rig(rig)
    values = (
        value_list(amplitudes, "amplitude", "amplitudes") if isinstance(amplitudes, str) else list(amplitudes)
    )
    p: dict[str, Any] = {
        "fe": quantity(fe, "frequency", "fe") if isinstance(fe, str) else fe,
        "amplitudes": values,
    }
    if gap is not None:
        p["gap"] = quantity(gap, "length", "gap") if isinstance(gap, str) else gap
    p.update(parse_gains(gains, "gains"))
    p.update(params)
    proc = ControlBasedContinuation(
        cfg, p, out, backend=backend, overwrite=overwrite, progress=progress, seed=seed, inner_loop=inner_loop
    )
    return proc.run()


def from_options(cfg: Any, out: str | Path, o: Any, **run_options: Any) -> ControlBasedContinuation:
    """``rig acquire cbc``: the procedure from the command's options (quantities as text)."""

    params: dict[str, Any] = {
        "fe": quantity(o["fe"], "frequency", "--fe"),
        "amplitudes": value_list(o["amplitude"], "amplitude", "--amplitude"),
        **parse_gains(o.get("gains")),
    }
    if o.get("gap") is not None:
        params["gap"] = gap_text(o["gap"], "--gap")
    for key in ("max_iterations", "tolerance"):
        if o.get(key) is not None:
            params[key] = o[key]
    if o.get("release") is not None:
        params["release_seconds"] = quantity(o["release"], "time", "--release")
    proc = ControlBasedContinuation(cfg, params, out, inner_loop=o.get("inner_loop"), **run_options)
    proc.note = (
        NO_REALTIME_LOOP if run_options.get("backend") == "nidaq" else ""
    )  # said before the device opens
    return proc


def json_document(proc: ControlBasedContinuation) -> dict[str, Any]:
    """The ``--json`` part of a CBC run: each point as :class:`~rigtools.controlled_point.ControlledPoint` fields plus its
    control effort, the inner loop, and the release's growth rate if one was measured."""
    doc: dict[str, Any] = {
        "inner_loop": getattr(proc.session, "name", ""),
        "points": [
            {
                **pt.point.to_dict(),
                "control_effort": pt.control_effort,
                "tip_amplitude_m": pt.tip_amplitude,
                "drive_amplitude_v": float(abs(pt.measurement.drive[0])),
                "parameterisation": "arclength" if pt.arclength else "amplitude",
                **({"branch": pt.branch} if pt.branch else {}),
                **({"step_cut": pt.step_cut} if pt.step_cut else {}),
                **pt.multiplier_fields(),
            }
            for pt in proc.points
        ],
        "skipped_amplitudes": proc.result.summary.get("skipped_amplitudes", []),
    }
    if proc.lost:
        doc["lost"] = list(proc.lost)
    if proc.release:
        doc["release"] = {k: v for k, v in proc.release.items() if k != "deviation"}
    if getattr(proc, "note", ""):
        doc["note"] = proc.note
    return doc


def parse_gains(gains: Any, name: str = "--gains") -> dict[str, float]:
    """``{"kp": ..., "kd": ...}`` of ``"KP[,KD]"`` (V/m, V s/m), a number or a pair; ``{}`` for ``None``.
    ``name`` is what an error line calls the value (the option, or the front door's parameter)."""

    if gains is None:
        return {}
    parts = (
        gains.split(",")
        if isinstance(gains, str)
        else (list(gains) if isinstance(gains, (list, tuple)) else [gains])
    )
    how = f'{name} = {gains!r}: write KP[,KD] in V/m and V s/m, e.g. "300,0" (0: open loop)'
    try:
        values = [float(v) for v in parts]
    except (TypeError, ValueError):
        raise UserError(how) from None
    if not 1 <= len(values) <= 2 or not all(math.isfinite(v) for v in values):
        raise UserError(how)
    if any(v < 0 for v in values):
        raise UserError(
            f"{name} = {gains!r}: gains are >= 0 (a negative gain feeds the error back with the wrong "
            "sign and drives the orbit away from its target)"
        )
    return {"kp": values[0], "kd": values[1] if len(values) > 1 else 0.0}


__all__ = ["OPTIONS", "control_based_continuation", "from_options", "json_document", "parse_gains"]
