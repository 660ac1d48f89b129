"""Exact references shared by the analysis tests: a viscously damped 2-DOF mass-spring system.

Masses m1, m2 in a chain (ground - k1 - m1 - k2 - m2), dampers c1, c2 parallel to the springs
(non-proportional in general). Force on m1, response at ``out``. The FRF is the exact
``(K - w^2 M + i w C)^-1``; the poles are the eigenvalues of the first-order system, so natural
frequencies ``|s| / 2 pi`` and damping ratios ``-Re s / |s|`` are exact.
"""

from __future__ import annotations

import numpy as np

M = np.diag([1.0, 0.5])
K = np.array([[3.0e5 + 2.0e5, -2.0e5], [-2.0e5, 2.0e5]])
C = 5e-5 * K + 8.0 * M  # Rayleigh damping: zeta 2.6 % and 2.6 % (see modes())


def receptance(f: np.ndarray, out: int = 0, m=M, c=C, k=K) -> np.ndarray:
    """X_out / F_1 (m/N) at frequencies ``f`` (Hz)."""
    w = 2 * np.pi * np.asarray(f, dtype=float)
    z = k[None] - (w**2)[:, None, None] * m[None] + 1j * w[:, None, None] * c[None]  # (n, 2, 2)
    det = z[:, 0, 0] * z[:, 1, 1] - z[:, 0, 1] * z[:, 1, 0]
    # first column of the 2x2 inverse: [z11, -z10] / det
    return (z[:, 1, 1] if out == 0 else -z[:, 1, 0]) / det


def modes(m=M, c=C, k=K) -> tuple[np.ndarray, np.ndarray]:
    """(natural frequencies Hz, damping ratios) from the state-space poles, ascending."""
    n = m.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(m, k), -np.linalg.solve(m, c)]])
    s = np.linalg.eigvals(a)
    s = s[s.imag > 0]
    s = s[np.argsort(np.abs(s))]
    return np.abs(s) / (2 * np.pi), -s.real / np.abs(s)


def periodic_response(x: np.ndarray, fs: float, out: int = 0, kind: str = "receptance") -> np.ndarray:
    """Exact periodic steady-state response of the 2-DOF to the periodic band-limited force ``x``
    (the record repeated), by multiplying its DFT by the FRF at the DFT bins."""
    f = np.fft.rfftfreq(x.size, 1 / fs)
    h = receptance(f, out)
    h *= (2j * np.pi * f) ** {"receptance": 0, "mobility": 1, "accelerance": 2}[kind]
    return np.fft.irfft(np.fft.rfft(x) * h, n=x.size)


def one_frf(x: np.ndarray, y: np.ndarray, fs: float, excitation: str, frame: int):
    """:meth:`rigtools.analysis.frf.FRFMethod.estimate` of one response ``y`` over ``x``, its
    arrays made 1-D (the estimator itself, not a reference)."""
    from dataclasses import replace

    from rigtools.analysis.frf import FRFMethod

    e = FRFMethod(excitation, frame).estimate([np.vstack([x, y])], fs)
    return replace(e, h1=e.h1[0], h2=e.h2[0], coherence=e.coherence[0], syy=e.syy[0], sxy=e.sxy[0])
