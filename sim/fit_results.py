"""The outcome of a model update (:class:`UpdateResult`, one :class:`ModeComparison` per mode
target): fitted values, residuals before and after, identifiability, a report and JSON; what it
shares with the contact fit's outcome (:class:`FitResult`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigtools.sim.fit_identifiability import CORRELATION_LIMIT, Identifiability
from rigtools.sim.fit_parameters import rig_file_values
from rigtools.sim.fit_targets import ModeTarget
from rigtools.sim.params import RigParams


@dataclass
class ModeComparison:
    """One mode target before and after the fit."""

    target: ModeTarget
    before_hz: float
    after_hz: float
    damping_before: float
    damping_after: float

    @property
    def error_before(self) -> float:
        """Relative frequency error before the fit."""
        return self.before_hz / self.target.frequency_hz - 1.0

    @property
    def error_after(self) -> float:
        """Relative frequency error after the fit."""
        return self.after_hz / self.target.frequency_hz - 1.0


@dataclass
class FitResult:
    """What every fit of the model to measurements returns (:class:`UpdateResult`,
    :class:`rigtools.sim.contact_fit.ContactFitResult`): the fields they share (described under
    :class:`UpdateResult`), the cost before and after, and the parameters' JSON entries."""

    names: list[str]
    units: list[str]
    initial: dict[str, float]
    fitted: dict[str, float]
    bounds: dict[str, tuple[float, float]]
    params: RigParams
    residual_labels: list[str]
    residuals_before: np.ndarray
    residuals_after: np.ndarray
    n_evaluations: int
    wall_time: float
    success: bool
    message: str
    identifiability: Identifiability

    @property
    def cost_before(self) -> float:
        return 0.5 * float(self.residuals_before @ self.residuals_before)

    @property
    def cost_after(self) -> float:
        return 0.5 * float(self.residuals_after @ self.residuals_after)

    def parameter_entries(self) -> dict[str, dict]:
        """name -> its unit, start and fitted values, bounds and 95 % interval (JSON-ready)."""
        return {
            n: {
                "unit": u,
                "start": self.initial[n],
                "fitted": self.fitted[n],
                "bounds": list(self.bounds[n]),
                "confidence_95": list(self.identifiability.confidence[n]),
            }
            for n, u in zip(self.names, self.units, strict=True)
        }


@dataclass
class UpdateResult(FitResult):
    """The outcome of :func:`rigtools.sim.parameter_fit.update_model`.

    Attributes
    ----------
    names, units
        Fitted parameters (registry names) and their units.
    initial, fitted
        name -> start value (within the bounds; a clamped root starts as stiff springs) and
        fitted value (SI).
    bounds
        name -> (low, high) used.
    params
        The updated :class:`RigParams`.
    residual_labels
        What each residual is.
    residuals_before, residuals_after
        Weighted residuals (in units of their stated 1-sigma) of the rig as given (e.g. clamped)
        and at the optimum.
    modes
        Per mode target: frequency and damping before and after.
    n_evaluations
        Model evaluations (the Jacobian's included).
    wall_time
        Seconds spent in :func:`rigtools.sim.parameter_fit.update_model`.
    success, message
        From the optimiser.
    identifiability
        :class:`Identifiability` at the optimum.
    """

    modes: list[ModeComparison]
    covariance: str = "stated"

    @property
    def max_frequency_error_before(self) -> float:
        """Largest ``|relative frequency error|`` over the mode targets before the fit."""
        return max((abs(m.error_before) for m in self.modes), default=float("nan"))

    @property
    def max_frequency_error_after(self) -> float:
        """Largest ``|relative frequency error|`` over the mode targets after the fit."""
        return max((abs(m.error_after) for m in self.modes), default=float("nan"))

    def rig_file_values(self) -> dict[str, float | str]:
        """Rig-file keys (``"section.key"``) and SI values to write: see :func:`rig_file_values`."""
        return rig_file_values(self.params, self.names)

    def as_dict(self) -> dict:
        """JSON-ready summary (plain floats, lists and strings)."""
        ident = self.identifiability
        return {
            "parameters": {
                n: {**entry, "std_relative": float(ident.std_scaled[i])}
                for i, (n, entry) in enumerate(self.parameter_entries().items())
            },
            "rig_file": self.rig_file_values(),
            "modes": [
                {
                    "blade": m.target.blade,
                    "order": m.target.order,
                    "target_hz": m.target.frequency_hz,
                    "before_hz": m.before_hz,
                    "after_hz": m.after_hz,
                    "error_before": m.error_before,
                    "error_after": m.error_after,
                    "damping_target": m.target.damping_ratio,
                    "damping_before": m.damping_before,
                    "damping_after": m.damping_after,
                }
                for m in self.modes
            ],
            "cost_before": self.cost_before,
            "cost_after": self.cost_after,
            "max_frequency_error_before": self.max_frequency_error_before,
            "max_frequency_error_after": self.max_frequency_error_after,
            "model_evaluations": self.n_evaluations,
            "wall_time_s": self.wall_time,
            "success": self.success,
            "message": self.message,
            "covariance": self.covariance,
            "identifiability": {
                "rank": ident.rank,
                "condition": ident.condition,
                "singular_values": ident.singular_values.tolist(),
                "correlation": [
                    [None if not np.isfinite(c) else float(c) for c in row] for row in ident.correlation
                ],
                "unresolved": list(ident.unresolved),
            },
        }

    def report(self) -> str:
        """A plain-text report: fitted values with 95 % intervals, modes before/after, and the
        parameters the data cannot separate."""
        ident = self.identifiability
        lines = [
            f"model update: {len(self.names)} parameters, {len(self.residual_labels)} residuals, "
            f"{self.n_evaluations} model evaluations, {self.wall_time:.1f} s"
            + ("" if self.success else f" (optimiser: {self.message})")
        ]
        lines.append(f"{'parameter':<30} {'start':>12} {'fitted':>12} {'95 % interval':>27}  unit")
        for n, u in zip(self.names, self.units, strict=True):
            lo, hi = ident.confidence[n]
            lines.append(
                f"{n:<30} {self.initial[n]:>12.5g} {self.fitted[n]:>12.5g} {f'[{lo:.4g}, {hi:.4g}]':>27}  {u}"
            )
        if self.modes:
            lines.append(
                f"{'mode':<12} {'target Hz':>10} {'before Hz':>10} {'err %':>7} {'after Hz':>10} "
                f"{'err %':>7} {'zeta target':>11} {'zeta after':>10}"
            )
            for m in self.modes:
                zt = "-" if m.target.damping_ratio is None else f"{m.target.damping_ratio:.4g}"
                lines.append(
                    f"{m.target.label:<12} {m.target.frequency_hz:>10.2f} {m.before_hz:>10.2f} "
                    f"{100 * m.error_before:>+7.3f} {m.after_hz:>10.2f} {100 * m.error_after:>+7.3f} "
                    f"{zt:>11} {m.damping_after:>10.4g}"
                )
        lines.append(
            f"Jacobian rank {ident.rank} of {len(self.names)}, condition {ident.condition:.3g} "
            f"(covariance from {self.covariance} uncertainties)"
        )
        if ident.unresolved:
            lines.append("the data cannot separate or determine:")
            lines += [f"  {line}" for line in ident.unresolved]
        else:
            lines.append(
                "every parameter is determined by the data (no |correlation| > "
                f"{CORRELATION_LIMIT}, no near-null direction)"
            )
        return "\n".join(lines)
