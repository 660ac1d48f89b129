"""The delay-aware law of the buffered CBC loop: a block-rate model of the fundamental identified
from the response, and the gains chosen for the output queue's known, fixed delay.

The buffered loop (:mod:`rigtools.procedures.cbc_loop`) reads a block (20 ms on NI and on the
simulated rig: a 0.1 s block read in five pieces, two of them queued), estimates the active
shroud's displacement fundamental ``X1`` over the latest whole period, and sets the drive's
fundamental for the block it writes next, which plays after the one still queued, cross-fading
from the previous setting. With ``c_k`` the setting after block ``k`` and ``u_k`` the fundamental
played over block ``k``: ``u_{k+1} = (c_{k-1} + c_{k-2}) / 2`` -- two blocks of delay and a half.

The rig near an orbit, seen at that rate (``x``, ``u`` real 2-vectors Re, Im of the deviations of
``X1`` and ``U1``), is an ARX model (:class:`BlockModel`)::

    x_{k+1} = sum_i A_i x_{k-i} + sum_j B_j u_{k-j}

fitted by least squares to a logged response (:func:`fit_block_model`): a stable orbit with the
feedforward stepped at random, or an unstable one held by the loop (the direct method: the
played drive is what the model sees). Its slow real eigenvalue is the orbit's own growth per
block, ``exp(sigma T)`` with ``sigma = fe ln|mu|``; :meth:`BlockModel.with_growth` moves it, so the
models of orbits further up the unstable part are stand-ins for the ones not yet held.

The law (:class:`~rigtools.procedures.cbc_iteration.EnvelopeGains`) is
``c_k = Uff - K e_k - D (x_k - x_{k-1})``: ``K`` and ``D`` real 2x2 matrices, chosen by
:func:`design_envelope_gains` to minimise the largest spectral radius of the closed loops
(:func:`closed_loop`, with the queue's delay in it) over a set of models: a min-max design for
a known delay and an orbit growth that changes along the branch.
:data:`~rigtools.procedures.cbc_iteration.DELAY_GAINS` are the
simulated rig's, made by ``benchmarks/cbc_delay_design.py`` (identification at A 0.315, 0.340 and
0.350 mm held by the PD law, the last moved to 10 and 13 1/s; each with its drive gain scaled and
turned for the models' own error). They hold the S-curve at 64 Hz up to A 0.360 mm (abs(mu) 1.17,
growth 10 1/s: growth x delay about 0.5) where the PD law lost A 0.355 mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from rigtools.procedures.cbc_iteration import EnvelopeGains


def _real(z: np.ndarray) -> np.ndarray:
    z = np.asarray(z, complex)
    return np.column_stack([z.real, z.imag])


@dataclass(frozen=True)
class BlockModel:
    """``x_{k+1} = sum_i a[i] x_{k-i} + sum_j b[j] u_{k-j}`` (real 2x2 matrices; ``x`` m, ``u`` V).

    Attributes
    ----------
    a, b
        ``(na, 2, 2)`` and ``(nb, 2, 2)``.
    block_seconds
        The sampling time, s (one block).
    residual
        The fit's residual RMS over the RMS of the response's variation (0 for an exact model).
    """

    a: np.ndarray
    b: np.ndarray
    block_seconds: float
    residual: float = 0.0

    def companion(self) -> np.ndarray:
        """The ``(2 na, 2 na)`` matrix of the free response."""
        na = self.a.shape[0]
        c = np.zeros((2 * na, 2 * na))
        c[:2, :] = np.hstack(list(self.a))
        c[2:, :-2] = np.eye(2 * na - 2)
        return c

    def eigenvalues(self) -> np.ndarray:
        """Eigenvalues of the free response per block, largest real part first."""
        ev = np.linalg.eigvals(self.companion())
        return ev[np.argsort(-ev.real)]

    def growth_rate(self) -> float:
        """``ln(max |eigenvalue|) / T``, 1/s: the orbit's own growth (``fe ln|mu|``) seen per block."""
        return float(np.log(np.max(np.abs(self.eigenvalues()))) / self.block_seconds)

    def with_growth(self, sigma: float) -> BlockModel:
        """The model with its largest real eigenvalue moved to ``exp(sigma T)`` (eigenvectors kept).

        Raises
        ------
        ValueError
            If the model has no real eigenvalue.
        """
        c = self.companion()
        ev, v = np.linalg.eig(c)
        real = np.flatnonzero(np.abs(ev.imag) <= 1e-9 * np.maximum(1.0, np.abs(ev)))
        if real.size == 0:
            raise ValueError("the model has no real eigenvalue to move")
        i = int(real[np.argmax(ev[real].real)])
        ev = ev.copy()
        ev[i] = math.exp(sigma * self.block_seconds)
        moved = np.real(v @ np.diag(ev) @ np.linalg.inv(v))
        na = self.a.shape[0]
        a = np.stack([moved[:2, 2 * j : 2 * j + 2] for j in range(na)])
        return BlockModel(a, self.b.copy(), self.block_seconds, self.residual)


def fit_block_model(
    x: np.ndarray, u: np.ndarray, block_seconds: float, na: int = 2, nb: int = 3
) -> BlockModel:
    """Least-squares ARX fit of the response's fundamental ``x`` (m, complex, one per block) to the
    played drive's ``u`` (V, complex, same blocks), with a constant (the orbit's offset).

    Raises
    ------
    ValueError
        With fewer blocks than four times the parameters.
    """
    xr, ur = _real(x), _real(u)
    s = max(na, nb)
    n = xr.shape[0] - 1 - s
    n_par = 2 * (na + nb) + 1
    if n < 4 * n_par:
        raise ValueError(f"{xr.shape[0]} blocks: at least {4 * n_par + s + 1} are needed for the fit")
    k = np.arange(s, s + n)
    cols = [xr[k - i] for i in range(na)] + [ur[k - j] for j in range(nb)] + [np.ones((n, 1))]
    regressors = np.hstack(cols)
    y = xr[k + 1]
    theta = np.linalg.lstsq(regressors, y, rcond=None)[0].T  # (2, n_par)
    residual = float(np.linalg.norm(y - regressors @ theta.T) / np.linalg.norm(y - y.mean(axis=0)))
    a = np.stack([theta[:, 2 * i : 2 * i + 2] for i in range(na)])
    b = np.stack([theta[:, 2 * (na + j) : 2 * (na + j) + 2] for j in range(nb)])
    return BlockModel(a, b, block_seconds, residual)


def closed_loop(model: BlockModel, gains: EnvelopeGains) -> np.ndarray:
    """The closed loop's matrix per block: the model, the law ``c_k = -K x_k - D (x_k - x_{k-1})``
    (deviations) and the queue ``u_{k+1} = (c_{k-1} + c_{k-2}) / 2``. State: ``x_k .. x_{k-na+1}``
    (at least two), ``u_k .. u_{k-nb+1}``, ``c_{k-1}``, ``c_{k-2}``."""
    na, nb = max(2, model.a.shape[0]), model.b.shape[0]
    k, d = np.reshape(gains.k, (2, 2)), np.reshape(gains.d, (2, 2))
    n = 2 * (na + nb + 2)
    m = np.zeros((n, n))
    ix, iu, ic = 0, 2 * na, 2 * (na + nb)
    for i in range(model.a.shape[0]):
        m[0:2, ix + 2 * i : ix + 2 * i + 2] = model.a[i]
    for j in range(nb):
        m[0:2, iu + 2 * j : iu + 2 * j + 2] = model.b[j]
    m[2 : 2 * na, 0 : 2 * na - 2] = np.eye(2 * na - 2)  # x shifts
    m[iu : iu + 2, ic : ic + 4] = 0.5 * np.hstack([np.eye(2), np.eye(2)])  # u_{k+1}
    m[iu + 2 : iu + 2 * nb, iu : iu + 2 * nb - 2] = np.eye(2 * nb - 2)  # u shifts
    m[ic : ic + 2, 0:2] = -k - d  # c_k
    m[ic : ic + 2, 2:4] = d
    m[ic + 2 : ic + 4, ic : ic + 2] = np.eye(2)  # c_{k-1}
    return m


def spectral_radius(model: BlockModel, gains: EnvelopeGains) -> float:
    """Largest eigenvalue modulus of :func:`closed_loop` (below 1: the loop holds the orbit)."""
    return float(np.max(np.abs(np.linalg.eigvals(closed_loop(model, gains)))))


def design_envelope_gains(
    models: list[BlockModel], start: EnvelopeGains | None = None, trials: int = 20, seed: int = 0
) -> tuple[EnvelopeGains, float]:
    """``K``, ``D`` minimising the largest spectral radius of the closed loops over ``models``
    (Nelder-Mead from ``start`` and random starts); ``(gains, that radius)``."""
    scale = 1000.0  # V/m: the gains' order, so that the search works on numbers near 1

    def gains_of(p: np.ndarray) -> EnvelopeGains:
        q = p * scale
        return EnvelopeGains(tuple(q[:4].tolist()), tuple(q[4:].tolist()))

    def cost(p: np.ndarray) -> float:
        return max(spectral_radius(m, gains_of(p)) for m in models)

    rng = np.random.default_rng(seed)
    p0 = np.concatenate([start.k, start.d]) / scale if start is not None else np.zeros(8)
    best: tuple[float, np.ndarray] | None = None
    for trial in range(trials):
        guess = p0 + rng.normal(0, 0.3 if trial % 2 or start is None else 0.0, 8)
        res = minimize(
            cost, guess, method="Nelder-Mead", options={"maxiter": 4000, "xatol": 1e-5, "fatol": 1e-7}
        )
        if best is None or res.fun < best[0]:
            best = (float(res.fun), res.x)
    assert best is not None
    return gains_of(best[1]), best[0]


__all__ = [
    "BlockModel",
    "closed_loop",
    "design_envelope_gains",
    "fit_block_model",
    "spectral_radius",
]
