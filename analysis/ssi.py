"""Covariance-driven stochastic subspace identification (SSI-cov) of response-only records.

The output covariances ``R_k = E[y(t + k) y(t)^T]`` of a linear system driven by white noise are
``R_k = C A^(k-1) G``: the block Hankel matrix of ``R_1 .. R_(2p-1)`` (``p`` block rows) factors
into the observability matrix ``O = [C; CA; ...; CA^(p-1)]`` times a controllability matrix, so
its singular value decomposition gives ``O`` up to a similarity transform at any model order
``n`` (the ``n`` largest singular values), ``A`` from the shift structure of ``O`` (least
squares) and ``C`` from its first block row. The eigenvalues of ``A`` are the discrete poles
``exp(mu dt)``; ``mu = -zeta w + i w sqrt(1 - zeta^2)`` gives the natural frequency and damping
ratio, ``C psi`` the mode shape at the sensors (Peeters and De Roeck 1999; Brincker and Ventura,
*Introduction to Operational Modal Analysis*, 2015, ch. 9).

:func:`ssi_cov_poles` runs the model orders 2, 4, ..., and classifies each pole as
*stable* when the previous order has a pole within ``freq_tol`` in frequency, ``damping_tol``
in damping and (several sensors) a MAC of at least ``min_mac``: the stabilisation chart
(:class:`rigtools.analysis.stabilisation.StabilisationChart`, the same type the LSCF chart of
the FRF path uses).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_triangular


def output_covariances(y: np.ndarray, max_lag: int) -> np.ndarray:
    """Unbiased output covariances ``R_k[i, j] = sum_t y_i(t + k) y_j(t) / (N - k)``.

    Parameters
    ----------
    y
        (channels, N) zero-mean samples.
    max_lag
        Highest lag ``k`` (samples), below ``N``.

    Returns
    -------
    (max_lag + 1, channels, channels) array
        ``R_0 .. R_max_lag`` (by FFT: exact, the zero padding removes the circular wrap).
    """
    n = y.shape[1]
    if not 0 < max_lag < n:
        raise ValueError(f"max_lag {max_lag} must be in 1..{n - 1}")
    nfft = 1 << int(np.ceil(np.log2(n + max_lag + 1)))
    spec = np.fft.rfft(y, nfft, axis=1)
    cross = np.fft.irfft(spec[:, None, :] * np.conj(spec[None, :, :]), nfft, axis=2)[:, :, : max_lag + 1]
    return np.moveaxis(cross, 2, 0) / (n - np.arange(max_lag + 1))[:, None, None]


def block_hankel(cov: np.ndarray, block_rows: int) -> np.ndarray:
    """``H[a, b] = R_(a + b + 1)`` for block indices ``a, b = 0 .. block_rows - 1``: a
    ``(block_rows * l, block_rows * l)`` matrix from ``cov`` (at least ``2 block_rows`` lags)."""
    lag = cov.shape[0]
    if lag < 2 * block_rows:
        raise ValueError(f"{lag} covariance lags are fewer than 2 x {block_rows} block rows")
    l = cov.shape[1]
    h = np.empty((block_rows * l, block_rows * l))
    for a in range(block_rows):
        for b in range(block_rows):
            h[a * l : (a + 1) * l, b * l : (b + 1) * l] = cov[a + b + 1]
    return h


@dataclass(frozen=True)
class SSIPoles:
    """Poles of every model order of one SSI-cov run (one entry per pole, ``Im(lambda) > 0``).

    Attributes
    ----------
    orders, frequency_hz, damping_ratio
        (n_poles,) model order, natural frequency (Hz) and damping ratio of each pole.
    shapes
        (n_poles, channels) complex mode shapes at the sensors (``C psi``), each scaled to unit
        norm with its largest component real and positive.
    stable
        (n_poles,) stable with the previous order (frequency, damping, MAC).
    mac
        (n_poles,) MAC with the matched pole of the previous order (NaN for the first order).
    mpc
        (n_poles,) modal phase collinearity of the shape (1: a real, classically damped shape).
    singular_values
        The block Hankel matrix's singular values (their drop shows the system order).
    block_rows, sample_rate
        The run's settings.
    """

    orders: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    stable: np.ndarray
    mac: np.ndarray
    mpc: np.ndarray
    singular_values: np.ndarray
    block_rows: int
    sample_rate: float


def mac_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MAC of every row of ``a`` with every row of ``b`` (complex shapes as rows)."""
    num = np.abs(np.conj(a) @ b.T) ** 2
    den = np.real(np.sum(np.conj(a) * a, axis=1))[:, None] * np.real(np.sum(np.conj(b) * b, axis=1))[None, :]
    return np.divide(num, den, out=np.zeros_like(num), where=den > 0)


def modal_phase_collinearity(shapes: np.ndarray) -> np.ndarray:
    """MPC of each row (Pappa et al. 1993): 1 for a shape whose components share one phase
    (up to sign), lower for a complex, spread shape."""
    re, im = shapes.real, shapes.imag
    sxx = np.sum(re * re, axis=1)
    syy = np.sum(im * im, axis=1)
    sxy = np.sum(re * im, axis=1)
    tot = sxx + syy
    return np.divide((sxx - syy) ** 2 + 4 * sxy**2, tot**2, out=np.ones_like(tot), where=tot > 0)


def _normalised(shapes: np.ndarray) -> np.ndarray:
    """Unit norm, the largest component real and positive."""
    big = shapes[np.arange(shapes.shape[0]), np.argmax(np.abs(shapes), axis=1)]
    phase = np.where(np.abs(big) > 0, big / np.where(np.abs(big) > 0, np.abs(big), 1.0), 1.0)
    out = shapes / phase[:, None]
    norm = np.linalg.norm(out, axis=1)
    return out / np.where(norm > 0, norm, 1.0)[:, None]


def ssi_cov_poles(
    y: np.ndarray,
    sample_rate: float,
    *,
    block_rows: int,
    max_order: int,
    freq_tol: float = 0.01,
    damping_tol: float = 0.25,
    min_mac: float = 0.95,
) -> SSIPoles:
    """SSI-cov poles at model orders 2, 4, ..., ``max_order`` with their stability.

    Parameters
    ----------
    y
        (channels, N) zero-mean samples (scale channels of different units to comparable
        levels first: the identification weights channels by their covariances).
    sample_rate
        Hz.
    block_rows
        Block rows ``p`` of the Hankel matrix (lags 1 .. 2p - 1 used); ``p * channels`` must be
        at least ``max_order``.
    max_order
        Highest model order (state dimension), even.
    freq_tol, damping_tol, min_mac
        Stability with the previous order: relative frequency difference, damping difference
        relative to the pole's damping (at least 0.001 absolute, so near-zero damping of a
        harmonic compares), lowest MAC (several channels).

    Returns
    -------
    SSIPoles
    """
    y = np.asarray(y, dtype=float)
    l = y.shape[0]
    if block_rows * l < max_order:
        raise ValueError(f"{block_rows} block rows x {l} channels < model order {max_order}")
    cov = output_covariances(y, 2 * block_rows)
    u, s, _ = np.linalg.svd(block_hankel(cov, block_rows), full_matrices=False)
    obs = u[:, :max_order] * np.sqrt(s[:max_order])
    # A_n = pinv(O_up[:, :n]) O_down[:, :n] for every n from one QR of O_up: the QR of the
    # first n columns is the first n columns of Q and the leading n x n block of R
    q, r = np.linalg.qr(obs[:-l])
    qtd = q.T @ obs[l:]
    dt = 1.0 / sample_rate
    rows: list[tuple[int, float, float, np.ndarray]] = []
    for n in range(2, max_order + 1, 2):
        a = solve_triangular(r[:n, :n], qtd[:n, :n])
        lam, psi = np.linalg.eig(a)
        keep = lam.imag > 0
        mu = np.log(lam[keep]) / dt
        wn = np.abs(mu)
        phi = obs[:l, :n] @ psi[:, keep]
        for k in range(mu.size):
            rows.append((n, float(wn[k] / (2 * np.pi)), float(-mu[k].real / wn[k]), phi[:, k]))
    orders = np.array([r[0] for r in rows], dtype=int)
    freq = np.array([r[1] for r in rows])
    zeta = np.array([r[2] for r in rows])
    shapes = _normalised(np.array([r[3] for r in rows]).reshape(len(rows), l))
    stable = np.zeros(len(rows), bool)
    mac = np.full(len(rows), np.nan)
    for n in range(4, max_order + 1, 2):
        cur, prev = np.flatnonzero(orders == n), np.flatnonzero(orders == n - 2)
        if not cur.size or not prev.size:
            continue
        m = mac_matrix(shapes[cur], shapes[prev])
        df = np.abs(freq[cur][:, None] - freq[prev][None, :]) / np.maximum(freq[cur][:, None], 1e-300)
        best = np.argmin(df - m, axis=1)  # nearest in frequency, shape breaking ties
        j = prev[best]
        mac[cur] = m[np.arange(cur.size), best]
        dz = np.abs(zeta[cur] - zeta[j])
        stable[cur] = (
            (df[np.arange(cur.size), best] <= freq_tol)
            & (dz <= np.maximum(damping_tol * np.abs(zeta[cur]), 1e-3))
            & ((mac[cur] >= min_mac) | (l == 1))
        )
    return SSIPoles(
        orders,
        freq,
        zeta,
        shapes,
        stable,
        mac,
        modal_phase_collinearity(shapes),
        s,
        block_rows,
        float(sample_rate),
    )
