"""What the data determine about fitted parameters (:class:`Identifiability`, from the SVD of the
weighted Jacobian at the optimum, :func:`identifiability`) and the finite-difference Jacobians of a
fit (:func:`forward_jacobian`, :func:`central_jacobian`). Shared by the linear model update
(:mod:`rigtools.sim.parameter_fit`) and the contact fit (:mod:`rigtools.sim.contact_fit`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.stats

CORRELATION_LIMIT = 0.95
NULL_RATIO = 1e-8  # singular value / largest below which a direction carries no information
FD_STEP = 1e-3  # finite-difference step in scaled x (~0.1 %): above the eigenvalue round-off
MAX_STD = 0.25  # 1-sigma extent (in scaled x, ~relative) above which a direction is undetermined


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


def forward_jacobian(fun, x: np.ndarray, hi: np.ndarray, step: float = FD_STEP) -> np.ndarray:
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


def central_jacobian(fun, x: np.ndarray, lo: np.ndarray, hi: np.ndarray, step: float = FD_STEP) -> np.ndarray:
    """Central differences (one-sided at a bound) of ``fun`` at ``x``, absolute step ``step``."""
    cols = []
    for i in range(x.size):
        h = step
        xp, xm = x.copy(), x.copy()
        xp[i], xm[i] = min(x[i] + h, hi[i]), max(x[i] - h, lo[i])
        cols.append((fun(xp) - fun(xm)) / (xp[i] - xm[i]))
    return np.column_stack(cols)


def identifiability(
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
