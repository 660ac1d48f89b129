"""``rig acquire pll`` from option text, and its ``--json`` document.

* :func:`phases_option`: ``"-90 deg"``, ``"-152 deg,-156 deg"`` (or rad) -> degrees;
* :func:`start_frequency`: the default first frequency, from the rig file's nominal model;
* :func:`pll_parameters`: :class:`rigtools.procedures.pll.PllParameters` values of the options;
* :func:`pll_document`: the points of a run as the shared controlled-point record.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from rigtools.errors import UserError
from rigtools.options import comma_items, quantity, value_list
from rigtools.options import gap as gap_option
from rigtools.sim.phase_points import linear_phase_resonance
from rigtools.sim.reduction import reduced_system

#: The command's option of each parameter (its one-line errors name the option; the Python door,
#: :func:`rigtools.phase_locked_loop`, the keyword).
OPTIONS = {
    name: "--" + name.replace("_", "-")
    for name in (
        *("fe_start", "f_min", "f_max", "kp", "ki", "lock_periods", "lock_tolerance", "max_periods"),
        *("record_periods", "phase_rate", "max_amplitude", "on_lock_loss", "inner_loop"),
    )
}
_ANGLE_UNITS = {"deg": 1.0, "degree": 1.0, "degrees": 1.0, "°": 1.0, "rad": 180.0 / math.pi}


def angle_option(text: str, option: str) -> float:
    """One angle with its unit (``"-90 deg"``, ``"-90°"``, ``"-1.571 rad"``) in degrees; a plain
    number is refused (degrees or radians would be a guess)."""
    t = str(text).strip()
    for unit in sorted(_ANGLE_UNITS, key=len, reverse=True):
        if t.endswith(unit):
            try:
                value = float(t[: -len(unit)].strip())
            except ValueError:
                break
            if not math.isfinite(value):
                break
            return value * _ANGLE_UNITS[unit]
    raise UserError(f'{option} = {text!r}: give an angle with its unit, e.g. "-90 deg" or "-1.571 rad"')


def phases_option(text: str, option: str = "--phase") -> list[float]:
    """A comma list of angles (:func:`angle_option`), degrees."""
    if not str(text).replace(",", "").strip():
        raise UserError(f"{option} = {text!r}: give at least one phase")
    return [angle_option(p, option) for p in comma_items(str(text), option)]


def start_frequency(cfg: Any, phase_deg: float) -> float:
    """Where the first point starts: the frequency at ``phase_deg`` of the rig file's nominal model
    without contact (its first mode; the test article differs, the loop finds its own)."""
    system = reduced_system(cfg.to_params(), "fem")
    f1 = float(min(system.omega)) / (2 * math.pi)
    try:
        return linear_phase_resonance(system, phase_deg, band=(0.5 * f1, 1.3 * f1))
    except ValueError:
        return f1


def pll_parameters(cfg: Any, options: Mapping[str, Any]) -> dict:
    """The PLL's parameters (SI, degrees) from ``rig acquire pll`` options (text with units)."""
    o = options
    forces = value_list(str(o["force"]), "force", "--force", positive=True)
    phases = phases_option("-90 deg" if o.get("phase") is None else o["phase"])  # "": an error
    params: dict[str, Any] = {"forces": forces, "phases": phases}
    if o.get("gap") is not None:
        params["gap"] = gap_option(o["gap"])
    start = o.get("fe_start")
    params["fe_start"] = (
        quantity(start, "frequency", "--fe-start") if start is not None else start_frequency(cfg, phases[0])
    )
    for key, flag in (("f_min", "--f-min"), ("f_max", "--f-max")):
        if o.get(key) is not None:
            params[key] = quantity(o[key], "frequency", flag)
    for key in ("kp", "ki", "lock_periods", "max_periods", "record_periods"):
        if o.get(key) is not None:
            params[key] = o[key]
    if o.get("lock_tolerance") is not None:
        params["lock_tolerance"] = angle_option(o["lock_tolerance"], "--lock-tolerance")
    if o.get("phase_rate") is not None:
        text = str(o["phase_rate"]).strip()
        params["phase_rate"] = angle_option(text.removesuffix("/s").strip(), "--phase-rate")
    if o.get("max_amplitude") is not None:
        params["max_amplitude"] = quantity(o["max_amplitude"], "length", "--max-amplitude")
    if o.get("on_lock_loss") is not None:
        params["on_lock_loss"] = o["on_lock_loss"]
    if o.get("inner_loop") is not None:
        params["inner_loop"] = o["inner_loop"]
    return params


def pll_document(proc: Any) -> list[dict]:
    """Each point of a PLL run as the shared controlled-point record (``--json``'s ``points``)."""
    return [c.to_dict() for c in getattr(proc, "points", [])]
