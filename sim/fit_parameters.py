"""The registry of rig parameters a model update can adjust (:data:`PARAMETERS`, named by the
rig file's ``"section.key"``), their start values and bounds, and the rig-file values of a fit
(:func:`rig_file_values`). Used by :mod:`rigtools.sim.parameter_fit` and :mod:`rigtools.sim.contact_fit`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from rigtools.sim.params import DampingParams, RigParams, RootParams

# start values of a fitted spring when the nominal rig has a clamped root: stiff, but soft enough
# that the frequencies feel them (1e5 N*m/rad lowers f1 by ~0.3 % on the default rig, 1e10 N/m by
# ~0.003 %)
CLAMPED_START_ROTATIONAL = 1e5  # N*m/rad
CLAMPED_START_TRANSLATIONAL = 1e10  # N/m
# a clamp written as springs, for the spring that is not fitted (frequencies change < 1e-6)
RIGID_ROTATIONAL = 1e9  # N*m/rad
RIGID_TRANSLATIONAL = 1e12  # N/m


# ------------------------------------------------------------------------------ the registry


@dataclass(frozen=True)
class UpdateParameter:
    """A rig parameter the fit can adjust.

    Attributes
    ----------
    name
        Its rig-file key, ``"section.key"`` (e.g. ``"root.rotational_stiffness"``).
    unit
        Unit of the value (SI), as the rig file writes it.
    description
        One line for reports.
    log
        Fitted in ``ln(v)`` (stiffnesses, damping) rather than linearly.
    bounds
        Default bounds ``(low, high)``; numbers are absolute, unless ``relative`` (then factors
        of the start value).
    relative
        Whether ``bounds`` are factors of the start value.
    get
        ``params -> value`` (the start value: for a clamped root, a stiff spring; the spring
        that is not fitted then stays rigid, :data:`RIGID_ROTATIONAL`, :data:`RIGID_TRANSLATIONAL`).
    set
        ``(params, value) -> params`` with this parameter set.
    """

    name: str
    unit: str
    description: str
    log: bool
    bounds: tuple[float, float]
    relative: bool
    get: Callable[[RigParams], float]
    set: Callable[[RigParams, float], RigParams]

    def default_bounds(self, start: float) -> tuple[float, float]:
        """Bounds for a fit starting at ``start``."""
        lo, hi = self.bounds
        return (lo * start, hi * start) if self.relative else (lo, hi)


def _springs(params: RigParams) -> RootParams:
    root = params.root
    if root.kind == "springs":
        return root
    return RootParams("springs", RIGID_ROTATIONAL, RIGID_TRANSLATIONAL)


def _set_root(
    params: RigParams,
    *,
    rotational_stiffness: float | None = None,
    translational_stiffness: float | None = None,
) -> RigParams:
    """Both roots on springs; the stiffnesses given replace the current ones."""
    root = _springs(params)
    root = replace(
        root,
        rotational_stiffness=root.rotational_stiffness
        if rotational_stiffness is None
        else rotational_stiffness,
        translational_stiffness=(
            root.translational_stiffness if translational_stiffness is None else translational_stiffness
        ),
    )
    return replace(params, root=root, passive_root=None)


def _scale_mass(mass, value: float):
    factor = value / mass.mass
    return replace(mass, mass=value, rotary_inertia=mass.rotary_inertia * factor)


def _set_youngs(params: RigParams, value: float) -> RigParams:
    factor = value / params.active.youngs_modulus
    return replace(
        params,
        active=replace(params.active, youngs_modulus=value),
        passive=replace(params.passive, youngs_modulus=params.passive.youngs_modulus * factor),
    )


def _ratio(params: RigParams) -> float:
    if params.damping.ratio is not None:
        return float(params.damping.ratio)
    return 0.01


def _rayleigh(params: RigParams) -> tuple[float, float]:
    d = params.damping
    if d.ratio is None:
        return d.alpha, d.beta
    # equal ratio at 50 Hz and 1.3 kHz (the rig's first and third flexural modes)
    w1, w2 = 2 * np.pi * 50.0, 2 * np.pi * 1300.0
    return 2 * d.ratio * w1 * w2 / (w1 + w2), 2 * d.ratio / (w1 + w2)


def _set_alpha(params: RigParams, value: float) -> RigParams:
    return replace(params, damping=DampingParams(ratio=None, alpha=value, beta=_rayleigh(params)[1]))


def _set_beta(params: RigParams, value: float) -> RigParams:
    return replace(params, damping=DampingParams(ratio=None, alpha=_rayleigh(params)[0], beta=value))


PARAMETERS: dict[str, UpdateParameter] = {
    p.name: p
    for p in (
        UpdateParameter(
            "root.rotational_stiffness",
            "N*m/rad",
            "root rotational springs (both blades, every axis)",
            True,
            (1e1, 1e9),
            False,
            lambda p: p.root.rotational_stiffness if p.root.kind == "springs" else CLAMPED_START_ROTATIONAL,
            lambda p, v: _set_root(p, rotational_stiffness=v),
        ),
        UpdateParameter(
            "root.translational_stiffness",
            "N/m",
            "root translational springs (both blades, every axis)",
            True,
            (1e4, 1e13),
            False,
            lambda p: (
                p.root.translational_stiffness if p.root.kind == "springs" else CLAMPED_START_TRANSLATIONAL
            ),
            lambda p, v: _set_root(p, translational_stiffness=v),
        ),
        UpdateParameter(
            "damping.ratio",
            "",
            "modal damping ratio (every mode)",
            True,
            (1e-5, 0.5),
            False,
            _ratio,
            lambda p, v: replace(p, damping=DampingParams(ratio=v)),
        ),
        UpdateParameter(
            "damping.alpha",
            "1/s",
            "Rayleigh mass-proportional damping (C = alpha M + beta K)",
            True,
            (1e-6, 1e4),
            False,
            lambda p: _rayleigh(p)[0],
            _set_alpha,
        ),
        UpdateParameter(
            "damping.beta",
            "s",
            "Rayleigh stiffness-proportional damping (C = alpha M + beta K)",
            True,
            (1e-12, 1e-2),
            False,
            lambda p: _rayleigh(p)[1],
            _set_beta,
        ),
        UpdateParameter(
            "shroud.mass",
            "kg",
            "shroud mass (both tips; rotary inertia scaled with it)",
            False,
            (0.5, 1.5),
            True,
            lambda p: p.shroud.mass,
            lambda p, v: replace(p, shroud=_scale_mass(p.shroud, v)),
        ),
        UpdateParameter(
            "force_sensor.mass",
            "kg",
            "force-sensor mass (rotary inertia scaled with it)",
            False,
            (0.5, 1.5),
            True,
            lambda p: p.force_sensor.mass,
            lambda p, v: replace(p, force_sensor=_scale_mass(p.force_sensor, v)),
        ),
        UpdateParameter(
            "blade.youngs_modulus",
            "Pa",
            "Young's modulus of the blades (the passive one scaled alike)",
            False,
            (0.5, 1.5),
            True,
            lambda p: p.active.youngs_modulus,
            _set_youngs,
        ),
    )
}


def rig_file_values(params: RigParams, names: Sequence[str]) -> dict[str, float | str]:
    """The rig-file keys (``"section.key"`` -> SI value or text) that describe ``params`` for the
    parameters ``names``: what an updated rig file must hold.

    Root springs bring ``root.kind = "springs"`` and both spring stiffnesses; masses bring their
    rotary inertia (scaled with them); Rayleigh damping brings ``alpha`` and ``beta`` (and the
    ``ratio`` key must then be removed); Young's modulus of a passive blade that has its own
    brings ``passive_blade.youngs_modulus``.
    """
    out: dict[str, float | str] = {}
    for name in names:
        if name not in PARAMETERS:
            raise KeyError(name)
        section = name.split(".")[0]
        if section == "root":
            out["root.kind"] = params.root.kind
            out["root.rotational_stiffness"] = params.root.rotational_stiffness
            out["root.translational_stiffness"] = params.root.translational_stiffness
        elif section == "damping":
            if params.damping.ratio is not None:
                out["damping.ratio"] = params.damping.ratio
            else:
                out["damping.alpha"] = params.damping.alpha
                out["damping.beta"] = params.damping.beta
        elif name == "shroud.mass":
            out["shroud.mass"] = params.shroud.mass
            out["shroud.rotary_inertia"] = params.shroud.rotary_inertia
        elif name == "force_sensor.mass":
            out["force_sensor.mass"] = params.force_sensor.mass
            out["force_sensor.rotary_inertia"] = params.force_sensor.rotary_inertia
        elif name == "blade.youngs_modulus":
            out["blade.youngs_modulus"] = params.active.youngs_modulus
            if not math.isclose(params.passive.youngs_modulus, params.active.youngs_modulus, rel_tol=1e-12):
                out["passive_blade.youngs_modulus"] = params.passive.youngs_modulus
    return out
