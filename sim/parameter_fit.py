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
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.stats

from rigtools.sim.blade import BladeModel, build_blade
from rigtools.sim.modal import check_dense, lowest_modes
from rigtools.sim.params import DampingParams, RigParams, RootParams
from rigtools.sim.reduction import damping_ratios
from rigtools.sim.rig_model import blade_masses

Blade = Literal["active", "passive"]
FRFKind = Literal["receptance", "mobility", "accelerance"]
FRF_LOCATIONS = ("active_shroud", "active_force_point")
_FRF_ORDER = {"receptance": 0, "mobility": 1, "accelerance": 2}
_UY, _RZ = 1, 5

# start values of a fitted spring when the nominal rig has a clamped root: stiff, but soft enough
# that the frequencies feel them (1e5 N*m/rad lowers f1 by ~0.3 % on the default rig, 1e10 N/m by
# ~0.003 %)
CLAMPED_START_ROTATIONAL = 1e5  # N*m/rad
CLAMPED_START_TRANSLATIONAL = 1e10  # N/m
# a clamp written as springs, for the spring that is not fitted (frequencies change < 1e-6)
RIGID_ROTATIONAL = 1e9  # N*m/rad
RIGID_TRANSLATIONAL = 1e12  # N/m

CORRELATION_LIMIT = 0.95
NULL_RATIO = 1e-8  # singular value / largest below which a direction carries no information
FD_STEP = 1e-3  # finite-difference step in scaled x (~0.1 %): above the eigenvalue round-off
MAX_STD = 0.25  # 1-sigma extent (in scaled x, ~relative) above which a direction is undetermined


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


# ------------------------------------------------------------------------------- targets


@dataclass(frozen=True)
class ModeTarget:
    """An identified mode: the ``order``-th flexural mode of ``blade``.

    Attributes
    ----------
    blade
        ``"active"`` or ``"passive"``.
    order
        1 for the first flexural mode of that blade, 2 for the second, ...
    frequency_hz
        Identified (undamped) natural frequency, Hz.
    damping_ratio
        Identified damping ratio, or ``None`` to fit the frequency only.
    frequency_sigma
        Relative 1-sigma uncertainty of the frequency (default 0.1 %).
    damping_sigma
        Relative 1-sigma uncertainty of the damping ratio (default 10 %).
    """

    blade: Blade
    order: int
    frequency_hz: float
    damping_ratio: float | None = None
    frequency_sigma: float = 1e-3
    damping_sigma: float = 0.1

    def __post_init__(self) -> None:
        if self.blade not in ("active", "passive"):
            raise ValueError(f"blade must be 'active' or 'passive', got {self.blade!r}")
        if int(self.order) < 1:
            raise ValueError(f"mode order must be >= 1, got {self.order}")
        if not self.frequency_hz > 0:
            raise ValueError(f"frequency must be > 0 Hz, got {self.frequency_hz}")
        if self.damping_ratio is not None and not 0 < self.damping_ratio < 1:
            raise ValueError(f"damping ratio must be in (0, 1), got {self.damping_ratio}")
        if not (self.frequency_sigma > 0 and self.damping_sigma > 0):
            raise ValueError("uncertainties must be > 0")

    @property
    def label(self) -> str:
        return f"{self.blade} f{self.order}"


@dataclass(frozen=True)
class FrfTarget:
    """Measured FRF values of the active blade, driven at the force sensor, at given frequencies.

    Attributes
    ----------
    frequencies_hz
        (n,) frequencies, Hz (pick them where coherence is high).
    values
        (n,) complex FRF, response over force into the blade, convention ``exp(+i w t)``.
    location
        Response point: ``"active_shroud"`` (tip) or ``"active_force_point"`` (drive point).
    kind
        ``"receptance"`` (m/N), ``"mobility"`` (m/s/N) or ``"accelerance"`` (m/s^2/N).
    sigma
        1-sigma uncertainty of ``ln H`` (relative magnitude, and phase in rad); default 5 %.
    """

    frequencies_hz: np.ndarray
    values: np.ndarray
    location: str = "active_shroud"
    kind: FRFKind = "accelerance"
    sigma: float = 0.05

    def __post_init__(self) -> None:
        f = np.atleast_1d(np.asarray(self.frequencies_hz, dtype=float))
        h = np.atleast_1d(np.asarray(self.values, dtype=complex))
        if f.shape != h.shape or f.ndim != 1 or f.size == 0:
            raise ValueError("FRF target: frequencies and values must be 1-D arrays of the same length")
        if not (np.all(f > 0) and np.all(np.isfinite(h)) and np.all(h != 0)):
            raise ValueError("FRF target: frequencies must be > 0 and values finite and non-zero")
        if self.location not in FRF_LOCATIONS:
            raise ValueError(f"FRF target: location must be one of {FRF_LOCATIONS}, got {self.location!r}")
        if self.kind not in _FRF_ORDER:
            raise ValueError(f"FRF target: kind must be one of {tuple(_FRF_ORDER)}, got {self.kind!r}")
        if not self.sigma > 0:
            raise ValueError("FRF target: sigma must be > 0")
        object.__setattr__(self, "frequencies_hz", f)
        object.__setattr__(self, "values", h)


Target = ModeTarget | FrfTarget


# --------------------------------------------------------------------------- the model


def _flexural_group(blade: BladeModel):
    """Sparse K, M of the blade's flexural DOFs (uy, rz) and their free-DOF indices.

    Raises if the group is coupled to other DOFs (a non-symmetric section would couple them).
    """
    comp = blade.components
    idx = np.flatnonzero((comp == _UY) | (comp == _RZ))
    other = np.flatnonzero((comp != _UY) & (comp != _RZ))
    k, m = blade.stiffness, blade.mass
    if k[idx][:, other].count_nonzero() or m[idx][:, other].count_nonzero():
        raise ValueError("the flexural DOFs are coupled to others: not a uniform symmetric blade")
    return k[idx][:, idx].tocsc(), m[idx][:, idx].tocsc(), idx


def flexural_modes(blade: BladeModel, n: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lowest ``n`` flexural modes of a blade (all if ``None``) from its uy/rz DOF group.

    The pencil is badly conditioned (element stiffness ~1e11 against w1^2 ~ 1e5): solved directly,
    the lowest eigenvalues carry relative errors ~1e-7, too coarse for the fit's Jacobian.

    * ``n`` modes: :func:`rigtools.sim.modal.lowest_modes` on the flexural group (polished through
      the element deformations: round-off ~1e-15 at any mesh);
    * all modes: the largest eigenvalues of ``mu = 1/w^2`` of ``L^-1 M L^-T`` (``K = L L^T``, after
      scaling to a unit stiffness diagonal), dense (~1e-9; at most
      :data:`rigtools.sim.modal.DENSE_MAX_ELEMENTS` elements).

    Returns
    -------
    omegas, shapes, dofs
        Circular frequencies (rad/s, ascending), mass-normalised shapes over the group's DOFs
        (one column per mode), and the free-DOF index of each row of ``shapes``.
    """
    k, m, idx = _flexural_group(blade)
    size = len(idx)
    if n is not None and int(n) < size - 1:
        modes = lowest_modes(blade, max(1, int(n)), dofs=idx[:1])
        return modes.omegas, modes.shapes[idx], idx
    check_dense(blade, "an FRF target (the fit sums every flexural mode)")
    kd, md = k.toarray(), m.toarray()
    d = 1.0 / np.sqrt(np.diag(kd))
    ks, ms = kd * d[:, None] * d[None, :], md * d[:, None] * d[None, :]
    low = scipy.linalg.cholesky(ks, lower=True)
    a = scipy.linalg.solve_triangular(low, scipy.linalg.solve_triangular(low, ms, lower=True).T, lower=True)
    mu, z = scipy.linalg.eigh(0.5 * (a + a.T))
    mu, z = mu[::-1], z[:, ::-1]
    ok = mu > 0
    mu, z = mu[ok], z[:, ok]
    phi = d[:, None] * scipy.linalg.solve_triangular(low, z, lower=True, trans="T") / np.sqrt(mu)
    return 1.0 / np.sqrt(mu), phi, idx


@dataclass
class Prediction:
    """What the model predicts for a set of targets."""

    frequencies_hz: dict[str, np.ndarray]  # blade -> lowest flexural frequencies
    damping_ratios: dict[str, np.ndarray]  # blade -> their damping ratios
    frf: list[np.ndarray]  # one array per FRF target


def predict(params: RigParams, targets: Sequence[Target]) -> Prediction:
    """Frequencies and damping ratios of the flexural modes the targets name, and the FRFs.

    Parameters
    ----------
    params
        The rig.
    targets
        :class:`ModeTarget` and :class:`FrfTarget` items.
    """
    modes = [t for t in targets if isinstance(t, ModeTarget)]
    frfs = [t for t in targets if isinstance(t, FrfTarget)]
    need = {b: max([t.order for t in modes if t.blade == b], default=0) for b in ("active", "passive")}
    freqs: dict[str, np.ndarray] = {}
    zetas: dict[str, np.ndarray] = {}
    out_frf: list[np.ndarray] = []
    for b in ("active", "passive"):
        if need[b] == 0 and not (b == "active" and frfs):
            continue
        root = params.root_of(b)
        blade = build_blade(
            b,
            params.active if b == "active" else params.passive,
            blade_masses(params, b),
            root,
            params.force_sensor if b == "active" else None,
        )
        all_modes = b == "active" and bool(frfs)
        om, phi, idx = flexural_modes(blade, None if all_modes else need[b])
        if om.size < need[b]:
            raise ValueError(f"the {b} blade has only {om.size} flexural modes")
        freqs[b] = om[: need[b]] / (2 * np.pi)
        zeta_all = damping_ratios(om, params.damping)
        zetas[b] = zeta_all[: need[b]]
        if all_modes:
            row = {int(d): i for i, d in enumerate(idx)}
            drive = phi[row[blade.sensor_dof(_UY)]]
            for t in frfs:
                at = (
                    blade.dof(blade.tip_node, _UY) if t.location == "active_shroud" else blade.sensor_dof(_UY)
                )
                out = phi[row[at]]
                w = 2 * np.pi * t.frequencies_hz[:, None]
                x = (drive * out)[None, :] / (om**2 - w**2 + 2j * zeta_all * om * w)
                out_frf.append(x.sum(axis=1) * (1j * w[:, 0]) ** _FRF_ORDER[t.kind])
    return Prediction(freqs, zetas, out_frf)


def _residuals(pred: Prediction, targets: Sequence[Target]) -> np.ndarray:
    r = []
    for t in targets:
        if isinstance(t, ModeTarget):
            f = pred.frequencies_hz[t.blade][t.order - 1]
            r.append((f - t.frequency_hz) / t.frequency_hz / t.frequency_sigma)
            if t.damping_ratio is not None:
                z = pred.damping_ratios[t.blade][t.order - 1]
                r.append((z - t.damping_ratio) / t.damping_ratio / t.damping_sigma)
    frf_iter = iter(pred.frf)
    for t in targets:
        if isinstance(t, FrfTarget):
            lr = np.log(next(frf_iter) / t.values) / t.sigma
            r.extend(lr.real)
            r.extend(lr.imag)
    return np.asarray(r, dtype=float)


def _residual_labels(targets: Sequence[Target]) -> list[str]:
    labels = []
    for t in targets:
        if isinstance(t, ModeTarget):
            labels.append(t.label)
            if t.damping_ratio is not None:
                labels.append(f"{t.blade} zeta{t.order}")
    for j, t in enumerate(targets):
        if isinstance(t, FrfTarget):
            labels += [f"frf{j} {t.location} |H| @ {f:.6g} Hz" for f in t.frequencies_hz]
            labels += [f"frf{j} {t.location} phase @ {f:.6g} Hz" for f in t.frequencies_hz]
    return labels


# ------------------------------------------------------------------------------ results


@dataclass
class Identifiability:
    """What the data determine about the fitted parameters, at the optimum (linearised).

    Attributes
    ----------
    names
        Fitted parameter names.
    singular_values
        Singular values of the weighted Jacobian in scaled variables, descending.
    singular_vectors
        Right singular vectors (rows, same order), components per parameter.
    rank
        Numerical rank of the Jacobian (singular values above ``1e-8`` of the largest).
    condition
        Largest over smallest singular value (``inf`` if the smallest is 0).
    correlation
        (n, n) parameter correlation matrix (NaN where a parameter is undetermined).
    std_scaled
        1-sigma of each scaled variable (about the relative 1-sigma of the parameter).
    confidence
        name -> 95 % interval ``(low, high)`` in the parameter's unit.
    unresolved
        One line per parameter pair (or parameter) the data cannot separate (or determine).
    """

    names: list[str]
    singular_values: np.ndarray
    singular_vectors: np.ndarray
    rank: int
    condition: float
    correlation: np.ndarray
    std_scaled: np.ndarray
    confidence: dict[str, tuple[float, float]]
    unresolved: list[str]

    @property
    def identifiable(self) -> bool:
        """Whether every parameter and every pair is determined by the data."""
        return not self.unresolved


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
class UpdateResult:
    """The outcome of :func:`update_model`.

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
        Seconds spent in :func:`update_model`.
    success, message
        From the optimiser.
    identifiability
        :class:`Identifiability` at the optimum.
    """

    names: list[str]
    units: list[str]
    initial: dict[str, float]
    fitted: dict[str, float]
    bounds: dict[str, tuple[float, float]]
    params: RigParams
    residual_labels: list[str]
    residuals_before: np.ndarray
    residuals_after: np.ndarray
    modes: list[ModeComparison]
    n_evaluations: int
    wall_time: float
    success: bool
    message: str
    identifiability: Identifiability
    covariance: str = "stated"

    @property
    def cost_before(self) -> float:
        return 0.5 * float(self.residuals_before @ self.residuals_before)

    @property
    def cost_after(self) -> float:
        return 0.5 * float(self.residuals_after @ self.residuals_after)

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
                n: {
                    "unit": u,
                    "start": self.initial[n],
                    "fitted": self.fitted[n],
                    "bounds": list(self.bounds[n]),
                    "confidence_95": list(ident.confidence[n]),
                    "std_relative": float(ident.std_scaled[i]),
                }
                for i, (n, u) in enumerate(zip(self.names, self.units, strict=True))
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


# ---------------------------------------------------------------------------- the fit


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
            self._cache[key] = _residuals(self.prediction(x), self.targets)
        return self._cache[key]


def _forward_jacobian(fun, x: np.ndarray, hi: np.ndarray, step: float = FD_STEP) -> np.ndarray:
    """Forward differences of ``fun`` at ``x`` with the absolute step ``step`` (backward at
    the upper bound). scipy's own steps are relative to ``|x|``, which is 0 at the start."""
    f0 = fun(x)
    cols = []
    for i in range(x.size):
        h = step if x[i] + step <= hi[i] else -step
        xh = x.copy()
        xh[i] += h
        cols.append((fun(xh) - f0) / h)
    return np.column_stack(cols)


def _central_jacobian(
    fun, x: np.ndarray, lo: np.ndarray, hi: np.ndarray, step: float = FD_STEP
) -> np.ndarray:
    """Central differences (one-sided at a bound) of ``fun`` at ``x``, absolute step ``step``."""
    cols = []
    for i in range(x.size):
        h = step
        xp, xm = x.copy(), x.copy()
        xp[i], xm[i] = min(x[i] + h, hi[i]), max(x[i] - h, lo[i])
        cols.append((fun(xp) - fun(xm)) / (xp[i] - xm[i]))
    return np.column_stack(cols)


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


def _identifiability(
    jac: np.ndarray, names: list[str], specs, x: np.ndarray, v0: np.ndarray, scale2: float, dof: int
) -> Identifiability:
    n = len(names)
    if jac.shape[0] < n:  # fewer residuals than parameters: the missing rows carry nothing
        jac = np.vstack([jac, np.zeros((n - jac.shape[0], n))])
    _, s_full, vt = np.linalg.svd(jac, full_matrices=False)
    smax = s_full[0] if s_full[0] > 0 else 1.0
    keep = s_full > NULL_RATIO * smax
    rank = int(keep.sum())
    condition = float(s_full[0] / s_full[-1]) if s_full[-1] > 0 else float("inf")
    inv = np.where(keep, 1.0 / np.where(keep, s_full, 1.0) ** 2, 0.0)
    cov = scale2 * (vt.T * inv) @ vt
    # a parameter with a component on a direction the data do not see has no finite variance
    blind = np.any(np.abs(vt[~keep]) > 1e-6, axis=0) if (~keep).any() else np.zeros(n, bool)
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    std[blind] = np.inf
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(std, std)
    corr[blind, :] = np.nan
    corr[:, blind] = np.nan
    np.fill_diagonal(corr, 1.0)
    z = 1.959963984540054 if dof <= 0 else float(scipy.stats.t.ppf(0.975, dof))
    confidence = {}
    for i, (name, spec) in enumerate(zip(names, specs, strict=True)):
        half = z * std[i]
        if spec.log:
            confidence[name] = (
                (v0[i] * math.exp(x[i] - half), v0[i] * math.exp(x[i] + half))
                if half < 50
                else (0.0, math.inf)
            )
        else:
            confidence[name] = (
                (v0[i] * (1 + x[i] - half), v0[i] * (1 + x[i] + half))
                if np.isfinite(half)
                else (-math.inf, math.inf)
            )

    unresolved: list[str] = []
    named: set[frozenset] = set()
    for i in range(n):
        for j in range(i + 1, n):
            c = corr[i, j]
            if np.isfinite(c) and abs(c) > CORRELATION_LIMIT:
                unresolved.append(f"{names[i]} <-> {names[j]}: correlation {c:+.3f}")
                named.add(frozenset((i, j)))
    extent = np.sqrt(scale2) / np.where(s_full > 0, s_full, 1e-300)
    for k in range(n):
        if keep[k] and extent[k] <= MAX_STD:
            continue
        # the parameters that move along this direction by a sizeable share (x is ~relative): a
        # direction of mostly one parameter means that parameter is not determined, however its
        # small effect is traded against the others
        v = vt[k]
        big = [int(i) for i in np.argsort(-np.abs(v)) if abs(v[i]) >= 0.3]
        how = "no information" if not keep[k] else f"1-sigma extent {100 * extent[k]:.0f} %"
        direction = " ".join(f"{v[i]:+.2f} {names[i]}" for i in big)
        if len(big) == 1:
            # the others that move along with it, however little (in x, ~relative): what it trades against
            with_ = [names[i] for i in np.argsort(-np.abs(v)) if i != big[0] and abs(v[i]) >= 1e-3]
            trade = f"; trades against {', '.join(with_)}" if with_ else ""
            unresolved.append(f"{names[big[0]]}: not determined by the data ({how}{trade})")
            continue
        for a in range(len(big)):
            for b in range(a + 1, len(big)):
                pair = frozenset((big[a], big[b]))
                if pair in named:
                    continue
                named.add(pair)
                unresolved.append(
                    f"{names[big[a]]} <-> {names[big[b]]}: near-null direction [{direction}] ({how})"
                )
    return Identifiability(names, s_full, vt, rank, condition, corr, std, confidence, unresolved)


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
    """
    t0 = time.perf_counter()
    names = _check_names(names)
    targets = list(targets)
    if not targets:
        raise ValueError("give at least one target (a mode or an FRF)")
    if covariance not in ("stated", "residual"):
        raise ValueError(f"covariance must be 'stated' or 'residual', got {covariance!r}")
    start = dict(start or {})
    v_start = {n: float(start.get(n, PARAMETERS[n].get(params))) for n in names}
    b_all: dict[str, tuple[float, float]] = {}
    for n in names:
        b_lo, b_hi = (bounds or {}).get(n, PARAMETERS[n].default_bounds(v_start[n]))
        if not b_lo < b_hi:
            raise ValueError(f"{n}: bounds ({b_lo}, {b_hi}) are empty")
        if PARAMETERS[n].log and b_lo <= 0:
            raise ValueError(f"{n}: the lower bound must be > 0 (fitted in log scale)")
        v_start[n] = min(max(v_start[n], b_lo), b_hi)
        b_all[n] = (float(b_lo), float(b_hi))
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
    r0 = _residuals(pred0, targets)
    sol = scipy.optimize.least_squares(
        prob.residuals,
        x0,
        jac=lambda x: _forward_jacobian(prob.residuals, x, hi),
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
    ident = _identifiability(
        _central_jacobian(prob.residuals, x, lo, hi),
        names,
        prob.specs,
        x,
        prob.v0,
        scale2,
        dof if covariance == "residual" else 0,
    )
    v = prob.to_v(x)
    modes = [
        ModeComparison(
            t,
            float(pred0.frequencies_hz[t.blade][t.order - 1]),
            float(pred1.frequencies_hz[t.blade][t.order - 1]),
            float(pred0.damping_ratios[t.blade][t.order - 1]),
            float(pred1.damping_ratios[t.blade][t.order - 1]),
        )
        for t in targets
        if isinstance(t, ModeTarget)
    ]
    return UpdateResult(
        names=names,
        units=[PARAMETERS[n].unit for n in names],
        initial={n: float(v) for n, v in zip(names, prob.v0, strict=True)},
        fitted={n: float(vi) for n, vi in zip(names, v, strict=True)},
        bounds=b_all,
        params=prob.params_at(x),
        residual_labels=_residual_labels(targets),
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


def mode_targets(
    params: RigParams,
    n_modes: int = 3,
    *,
    damping: bool = False,
    frequency_sigma: float = 1e-3,
    damping_sigma: float = 0.1,
) -> list[ModeTarget]:
    """Exact targets from a model: the first ``n_modes`` flexural modes of both blades of
    ``params`` (e.g. a test article whose parameters are known), with their damping ratios if
    ``damping``."""
    probe = [ModeTarget(b, n_modes, 1.0) for b in ("active", "passive")]
    pred = predict(params, probe)
    return [
        ModeTarget(
            b,
            k + 1,
            float(pred.frequencies_hz[b][k]),
            float(pred.damping_ratios[b][k]) if damping else None,
            frequency_sigma,
            damping_sigma,
        )
        for b in ("active", "passive")
        for k in range(n_modes)
    ]


@dataclass
class Pairing:
    """Identified modes of one blade paired with the model's flexural modes.

    Attributes
    ----------
    targets
        One :class:`ModeTarget` per paired mode (its ``order`` is the model mode's).
    model_hz
        The model frequency each target was paired with.
    unpaired
        Identified frequencies (Hz) left out: no model mode within ``max_offset``.
    """

    targets: list[ModeTarget]
    model_hz: list[float]
    unpaired: list[float]


def pair_modes(
    params: RigParams,
    blade: Blade,
    frequencies_hz: Sequence[float],
    damping_ratios: Sequence[float | None] | None = None,
    *,
    max_offset: float = 0.15,
    n_model: int = 8,
    frequency_sigma: float = 1e-3,
    damping_sigma: float = 0.1,
) -> Pairing:
    """Pair identified natural frequencies of one blade with the model's flexural modes.

    Each identified mode goes to one model mode (one-to-one, least total ``|ln(f_id / f_model)|``,
    :func:`scipy.optimize.linear_sum_assignment`) and is kept if it is within ``max_offset``
    (relative) of it, so a missed or a spurious peak does not shift the orders of the others.

    Parameters
    ----------
    params
        The model the pairing is made against (e.g. the nominal rig).
    blade
        ``"active"`` or ``"passive"``.
    frequencies_hz, damping_ratios
        The identified modes (damping ratios optional, ``None`` entries allowed).
    max_offset
        Largest relative distance to the paired model mode.
    n_model
        Model flexural modes considered.
    """
    import scipy.optimize as _opt

    f_id = np.asarray(frequencies_hz, dtype=float)
    zetas = list(damping_ratios) if damping_ratios is not None else [None] * f_id.size
    if len(zetas) != f_id.size:
        raise ValueError("give one damping ratio (or None) per identified frequency")
    if f_id.size == 0:
        return Pairing([], [], [])
    if not np.all(f_id > 0):
        raise ValueError("identified frequencies must be > 0 Hz")
    f_model = predict(params, [ModeTarget(blade, n_model, 1.0)]).frequencies_hz[blade]
    cost = np.abs(np.log(f_id[:, None] / f_model[None, :]))
    # pairs beyond the offset are never worth taking: a fixed price of their own
    rows, cols = _opt.linear_sum_assignment(np.where(cost <= math.log1p(max_offset), cost, 1e3))
    targets, model_hz, unpaired = [], [], []
    paired = {}
    for r, c in zip(rows, cols, strict=True):
        if cost[r, c] <= math.log1p(max_offset):
            paired[int(r)] = int(c)
    for i, f in enumerate(f_id):
        if i not in paired:
            unpaired.append(float(f))
            continue
        c = paired[i]
        targets.append(ModeTarget(blade, c + 1, float(f), zetas[i], frequency_sigma, damping_sigma))
        model_hz.append(float(f_model[c]))
    order = np.argsort([t.order for t in targets])
    return Pairing([targets[i] for i in order], [model_hz[i] for i in order], unpaired)
