"""Model updating: fit chosen rig parameters to identified natural frequencies, damping ratios
and FRF values, and say which of them the data can actually determine.

The measured rig differs from the nominal FE model (a bolted root instead of the clamp, its own
damping, small mass deviations). :func:`update_model` adjusts the parameters named in
:data:`PARAMETERS` (root springs, modal damping ratio or Rayleigh coefficients, shroud and sensor
masses, Young's modulus) by weighted least squares (:func:`scipy.optimize.least_squares`, trust
region reflective, with bounds):

* a mode residual is the relative frequency error over its stated relative uncertainty,
  ``(f_model - f_target) / f_target / sigma_f``, and, when a damping ratio is given,
  ``(zeta_model - zeta_target) / zeta_target / sigma_zeta``;
* an FRF residual at each frequency is the complex log-ratio ``log(H_model / H_target) / sigma``
  split into its real part (log-magnitude) and imaginary part (phase, rad), so near-zero values
  (anti-resonances) do not dominate.

Modes are paired by blade and order: ``ModeTarget("active", 2, ...)`` is the active blade's 2nd
flexural (thin-direction, impact-direction) mode. The accelerometers and the shaker act along y,
so only flexural modes show in the rig's FRFs; the n-th peak of a blade's FRF is its n-th
flexural mode.

The optimiser works on scaled variables: ``x = ln(v / v0)`` for stiffnesses and damping
(log-scaling: they range over decades) and ``x = v / v0 - 1`` for the others, ``v0`` the start
value, so one unit of ``x`` is about a 100 % change of any parameter.

Identifiability is judged at the optimum from the SVD of the weighted Jacobian ``J = U S V^T``:
the covariance of ``x`` is ``s^2 (J^T J)^+`` with ``s = 1`` (the stated uncertainties are true,
``covariance="stated"``) or ``s^2 = SSR / (m - n)`` (``covariance="residual"``). A parameter pair
is reported as not separable when ``|correlation| > 0.95``, and a near-null direction of ``J``
(a singular value below ``1e-8`` of the largest, or a 1-sigma extent along it above 25 %) is
reported with the parameters that make it up (those with a component >= 0.3 in it). Confidence
intervals are linearised (95 %). The Jacobian is taken by finite differences with an absolute step
of 1e-3 in ``x`` (forward in the optimiser, central at the optimum).

:func:`pair_modes` turns a blade's identified frequencies (a missed or a spurious peak included)
into :class:`ModeTarget` items by pairing them one-to-one with the model's flexural orders.
:func:`rig_file_values` gives the rig-file keys (``"section.key"``) that carry the fitted values.

One model evaluation builds the FE model of both blades (:func:`rigtools.sim.blade.build_blade`) and solves
the flexural DOF group (uy, rz) of each for its lowest modes only; FRFs use all flexural modes of
the active blade (modal superposition: exact for modal and Rayleigh damping).

This module holds :func:`update_model`; every name below is importable from it. The parts:
:mod:`rigtools.sim.fit_parameters` (the registry :data:`PARAMETERS`, :func:`rig_file_values`),
:mod:`rigtools.sim.fit_targets` (targets, predictions, :func:`pair_modes`, :func:`mode_targets`),
:mod:`rigtools.sim.fit_identifiability` (:class:`Identifiability`) and
:mod:`rigtools.sim.fit_results` (:class:`UpdateResult`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Literal

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.stats

from rigtools.sim.fit_identifiability import (
    CORRELATION_LIMIT,
    FD_STEP,
    MAX_STD,
    NULL_RATIO,
    Identifiability,
    central_jacobian,
    forward_jacobian,
    identifiability,
)
from rigtools.sim.fit_parameters import (
    CLAMPED_START_ROTATIONAL,
    CLAMPED_START_TRANSLATIONAL,
    PARAMETERS,
    RIGID_ROTATIONAL,
    RIGID_TRANSLATIONAL,
    UpdateParameter,
    rig_file_values,
)
from rigtools.sim.fit_results import ModeComparison, UpdateResult
from rigtools.sim.fit_targets import (
    FRF_LOCATIONS,
    Blade,
    FRFKind,
    FrfTarget,
    ModeTarget,
    Pairing,
    Prediction,
    Target,
    flexural_modes,
    mode_targets,
    pair_modes,
    predict,
    residual_labels,
    weighted_residuals,
)
from rigtools.sim.params import RigParams

__all__ = [
    "CLAMPED_START_ROTATIONAL",
    "CLAMPED_START_TRANSLATIONAL",
    "CORRELATION_LIMIT",
    "FD_STEP",
    "FRF_LOCATIONS",
    "MAX_STD",
    "NULL_RATIO",
    "PARAMETERS",
    "RIGID_ROTATIONAL",
    "RIGID_TRANSLATIONAL",
    "Blade",
    "FRFKind",
    "FrfTarget",
    "Identifiability",
    "ModeComparison",
    "ModeTarget",
    "Pairing",
    "Prediction",
    "Target",
    "UpdateParameter",
    "UpdateResult",
    "flexural_modes",
    "mode_targets",
    "pair_modes",
    "predict",
    "rig_file_values",
    "update_model",
]


class _Problem:
    """Scaled variables <-> parameter values, and the counted, cached model evaluation."""

    def __init__(
        self,
        params: RigParams,
        targets: Sequence[Target],
        names: list[str],
        start: dict[str, float],
        bounds: dict[str, tuple[float, float]],
    ) -> None:
        self.base, self.targets, self.names = params, targets, names
        self.specs = [PARAMETERS[n] for n in names]
        self.v0 = np.array([start[n] for n in names])
        self.bounds = bounds
        self.n_evaluations = 0
        self._cache: dict[bytes, np.ndarray] = {}

    def to_x(self, v: np.ndarray) -> np.ndarray:
        return np.array(
            [
                math.log(vi / v0) if s.log else vi / v0 - 1.0
                for s, vi, v0 in zip(self.specs, v, self.v0, strict=True)
            ]
        )

    def to_v(self, x: np.ndarray) -> np.ndarray:
        return np.array(
            [
                v0 * math.exp(xi) if s.log else v0 * (1.0 + xi)
                for s, xi, v0 in zip(self.specs, x, self.v0, strict=True)
            ]
        )

    def params_at(self, x: np.ndarray) -> RigParams:
        p = self.base
        for s, v in zip(self.specs, self.to_v(x), strict=True):
            p = s.set(p, float(v))
        return p

    def prediction(self, x: np.ndarray) -> Prediction:
        self.n_evaluations += 1
        return predict(self.params_at(x), self.targets)

    def residuals(self, x: np.ndarray) -> np.ndarray:
        key = np.asarray(x, dtype=float).tobytes()
        if key not in self._cache:
            self._cache[key] = weighted_residuals(self.prediction(x), self.targets)
        return self._cache[key]


def _check_names(names: Sequence[str]) -> list[str]:
    names = list(dict.fromkeys(names))
    if not names:
        raise ValueError("give at least one parameter to fit")
    unknown = [n for n in names if n not in PARAMETERS]
    if unknown:
        raise ValueError(f"unknown parameter {unknown[0]!r} (known: {', '.join(PARAMETERS)})")
    if "damping.ratio" in names and ({"damping.alpha", "damping.beta"} & set(names)):
        raise ValueError("fit either damping.ratio (modal) or damping.alpha/beta (Rayleigh), not both")
    return names


def update_model(
    params: RigParams,
    targets: Sequence[Target],
    names: Sequence[str],
    *,
    start: dict[str, float] | None = None,
    bounds: dict[str, tuple[float, float]] | None = None,
    covariance: Literal["stated", "residual"] = "stated",
    max_evaluations: int = 400,
) -> UpdateResult:
    """Fit the parameters ``names`` of ``params`` to ``targets`` by weighted least squares.

    Parameters
    ----------
    params
        The nominal rig (the parameters not fitted stay as they are).
    targets
        :class:`ModeTarget` (frequency, optional damping ratio) and :class:`FrfTarget` items.
    names
        Registry names (:data:`PARAMETERS`), e.g. ``["root.rotational_stiffness", "damping.ratio"]``.
    start
        Start values by name (default: from ``params``; a clamped root starts at springs of
        :data:`CLAMPED_START_ROTATIONAL` and :data:`CLAMPED_START_TRANSLATIONAL`).
    bounds
        ``(low, high)`` by name (default: the registry's).
    covariance
        ``"stated"``: the targets' uncertainties are taken as true (confidence intervals from
        them); ``"residual"``: scaled by the residual variance ``SSR / (m - n)``.
    max_evaluations
        Limit on the optimiser's function evaluations.

    Returns
    -------
    UpdateResult

    Raises
    ------
    ValueError
        Unknown or conflicting names, no targets, bad bounds, or a mode the model does not have.

    Examples
    --------
    The root's rotational stiffness of the default rig fitted to the first two flexural modes of both
    blades of the simulated rig's test article (its blades sit on a bolted root, not the clamp):

    >>> import rigtools
    >>> from rigtools.sim.parameter_fit import mode_targets, update_model
    >>> cfg = rigtools.load_rig()
    >>> nominal = cfg.to_params()
    >>> measured = cfg.test_article.to_params().apply(nominal)
    >>> fit = update_model(nominal, mode_targets(measured, 2), ["root.rotational_stiffness"])
    >>> fit.success, round(fit.fitted["root.rotational_stiffness"], -2)
    (True, 10800.0)
    >>> round(100 * fit.max_frequency_error_before, 2), round(100 * fit.max_frequency_error_after, 2)
    (2.31, 0.25)
    """
    t0 = time.perf_counter()
    names = _check_names(names)
    targets = list(targets)
    if not targets:
        raise ValueError("give at least one target (a mode or an FRF)")
    if covariance not in ("stated", "residual"):
        raise ValueError(f"covariance must be 'stated' or 'residual', got {covariance!r}")
    v_start, b_all = _start_and_bounds(params, names, start or {}, bounds or {})
    # the base: each fitted parameter set to its start (so a clamped root becomes springs)
    base = params
    for n in names:
        base = PARAMETERS[n].set(base, v_start[n])
    prob = _Problem(base, targets, names, v_start, b_all)
    lo = prob.to_x(np.array([b_all[n][0] for n in names]))
    hi = prob.to_x(np.array([b_all[n][1] for n in names]))
    x0 = np.zeros(len(names))
    lo = np.minimum(lo, -1e-12)
    hi = np.maximum(hi, 1e-12)

    pred0 = predict(params, targets)  # the nominal rig as given (clamped root and all)
    prob.n_evaluations += 1
    r0 = weighted_residuals(pred0, targets)
    sol = scipy.optimize.least_squares(
        prob.residuals,
        x0,
        jac=lambda x: forward_jacobian(prob.residuals, x, hi),
        bounds=(lo, hi),
        method="trf",
        x_scale=1.0,
        max_nfev=max_evaluations,
        xtol=1e-10,
        ftol=1e-10,
        gtol=1e-10,
    )
    x = sol.x
    r1 = prob.residuals(x)
    pred1 = prob.prediction(x)
    m, n_p = r1.size, len(names)
    dof = m - n_p
    scale2 = 1.0 if covariance == "stated" else (float(r1 @ r1) / dof if dof > 0 else 1.0)
    ident = identifiability(
        central_jacobian(prob.residuals, x, lo, hi),
        names,
        prob.specs,
        x,
        prob.v0,
        scale2,
        dof if covariance == "residual" else 0,
    )
    v = prob.to_v(x)
    modes = _mode_comparisons(targets, pred0, pred1)
    return UpdateResult(
        names=names,
        units=[PARAMETERS[n].unit for n in names],
        initial={n: float(v) for n, v in zip(names, prob.v0, strict=True)},
        fitted={n: float(vi) for n, vi in zip(names, v, strict=True)},
        bounds=b_all,
        params=prob.params_at(x),
        residual_labels=residual_labels(targets),
        residuals_before=r0,
        residuals_after=r1,
        modes=modes,
        n_evaluations=prob.n_evaluations,
        wall_time=time.perf_counter() - t0,
        success=bool(sol.success),
        message=str(sol.message),
        identifiability=ident,
        covariance=covariance,
    )


def _start_and_bounds(
    params: RigParams,
    names: list[str],
    start: dict[str, float],
    bounds: dict[str, tuple[float, float]],
) -> tuple[dict[str, float], dict[str, tuple[float, float]]]:
    """Start values by name (given, or from ``params``; clipped into the bounds) and bounds (given,
    or the registry's); a one-line ``ValueError`` for empty bounds or a log-scaled one at zero."""
    v_start = {n: float(start.get(n, PARAMETERS[n].get(params))) for n in names}
    b_all: dict[str, tuple[float, float]] = {}
    for n in names:
        b_lo, b_hi = bounds.get(n, PARAMETERS[n].default_bounds(v_start[n]))
        if not b_lo < b_hi:
            raise ValueError(f"{n}: bounds ({b_lo}, {b_hi}) are empty")
        if PARAMETERS[n].log and b_lo <= 0:
            raise ValueError(f"{n}: the lower bound must be > 0 (fitted in log scale)")
        v_start[n] = min(max(v_start[n], b_lo), b_hi)
        b_all[n] = (float(b_lo), float(b_hi))
    return v_start, b_all


def _mode_comparisons(targets: list[Target], before: Prediction, after: Prediction) -> list[ModeComparison]:
    """One :class:`ModeComparison` per mode target: frequency and damping before and after."""
    return [
        ModeComparison(
            t,
            float(before.frequencies_hz[t.blade][t.order - 1]),
            float(after.frequencies_hz[t.blade][t.order - 1]),
            float(before.damping_ratios[t.blade][t.order - 1]),
            float(after.damping_ratios[t.blade][t.order - 1]),
        )
        for t in targets
        if isinstance(t, ModeTarget)
    ]
