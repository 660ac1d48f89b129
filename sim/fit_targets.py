"""What a model update fits to (:class:`ModeTarget`, :class:`FrfTarget`), what the model predicts
for them (:func:`predict`, from the blades' flexural modes, :func:`flexural_modes`), the weighted
residuals, and targets from identified or model modes (:func:`pair_modes`, :func:`mode_targets`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.stats
from scipy.optimize import linear_sum_assignment

from rigtools.sim.blade import BladeModel, build_blade
from rigtools.sim.modal import check_dense, lowest_modes
from rigtools.sim.params import RigParams
from rigtools.sim.reduction import damping_ratios
from rigtools.sim.rig_model import blade_masses

Blade = Literal["active", "passive"]
FRFKind = Literal["receptance", "mobility", "accelerance"]
FRF_LOCATIONS = ("active_shroud", "active_force_point")
_FRF_ORDER = {"receptance": 0, "mobility": 1, "accelerance": 2}
_UY, _RZ = 1, 5


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


def weighted_residuals(pred: Prediction, targets: Sequence[Target]) -> np.ndarray:
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


def residual_labels(targets: Sequence[Target]) -> list[str]:
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
    rows, cols = linear_sum_assignment(np.where(cost <= math.log1p(max_offset), cost, 1e3))
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
