"""Amplitudes and phases of the harmonics k*fe of a periodic response.

A least-squares fit of cos/sin at the exact frequencies k*fe is exact for a signal that holds
only those frequencies, whatever the record length (no leakage, unlike picking FFT bins).

Convention: ``x(t) = offset + sum_k amplitude_k * cos(2*pi*k*fe*(t - t0) + phase_k)``, where
``t0`` is the time of the first sample; amplitudes are peak values in the units of ``x``; phases
are in radians in (-pi, pi].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class HarmonicFit:
    """Result of :func:`harmonic_amplitudes`.

    Attributes
    ----------
    k : (K,) int array
        Harmonic orders 1..k_max.
    frequency_hz : (K,) array
        ``k * fe``.
    amplitude : (K,) array
        Peak amplitude of each harmonic (units of the signal).
    phase : (K,) array
        Phase in radians of ``cos(2 pi k fe t + phase)``, t from the first sample.
    offset : float
        Mean (k = 0) term.
    residual_rms : float
        RMS of what the fit does not explain (noise, non-harmonic content).
    """

    k: np.ndarray
    frequency_hz: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray
    offset: float
    residual_rms: float

    def at(self, k: int) -> float:
        """Amplitude of harmonic ``k``."""
        return float(self.amplitude[int(k) - 1])

    def to_records(self) -> list[dict]:
        """``[{"k", "frequency_hz", "amplitude", "phase"}, ...]`` with plain Python numbers."""
        return [
            {"k": int(k), "frequency_hz": float(f), "amplitude": float(a), "phase": float(p)}
            for k, f, a, p in zip(self.k, self.frequency_hz, self.amplitude, self.phase)
        ]


def harmonic_amplitudes(
    x: np.ndarray, sample_rate: float, fe: float, k_max: int = 30
) -> HarmonicFit:
    """Least-squares fit of ``offset + sum_k (a_k cos + b_k sin)(2 pi k fe t)`` to ``x``.

    Parameters
    ----------
    x
        Uniformly sampled signal, shape (n,).
    sample_rate
        Samples per second, Hz.
    fe
        Fundamental (excitation) frequency, Hz.
    k_max
        Highest harmonic order fitted; ``k_max * fe`` must lie below the Nyquist frequency.

    Returns
    -------
    HarmonicFit
        Peak amplitudes and phases of ``k * fe`` for k = 1..k_max.

    Notes
    -----
    When the record holds a whole number of periods of ``fe`` sampled an integer number of
    times per period, the cos/sin columns are orthogonal and the fit equals the DFT at the
    harmonic bins (used then, it is faster); otherwise a QR least-squares solve is used. Both are
    exact for a signal made of these harmonics only.
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise ValueError(f"x must be one-dimensional, got shape {x.shape}")
    if not (sample_rate > 0 and fe > 0):
        raise ValueError("sample_rate and fe must be positive")
    k_max = int(k_max)
    if k_max < 1:
        raise ValueError("k_max must be >= 1")
    if k_max * fe >= sample_rate / 2:
        raise ValueError(
            f"harmonic {k_max}*fe = {k_max * fe:g} Hz is not below the Nyquist frequency "
            f"{sample_rate / 2:g} Hz")
    n = x.size
    if n < 2 * k_max + 1:
        raise ValueError(f"need at least {2 * k_max + 1} samples to fit {k_max} harmonics, got {n}")
    k = np.arange(1, k_max + 1)

    samples_per_period = sample_rate / fe
    periods = n / samples_per_period
    whole = (abs(samples_per_period - round(samples_per_period)) < 1e-9 * samples_per_period
             and abs(periods - round(periods)) < 1e-9 * max(periods, 1.0) and round(periods) >= 1)
    if whole:
        spectrum = np.fft.rfft(x)
        bins = k * int(round(periods))
        coef = spectrum[bins] * (2.0 / n)   # a - i b for a cos + b sin
        a, b = coef.real, -coef.imag
        offset = spectrum[0].real / n
        # Parseval: the columns are orthogonal, so the residual energy is what the fit leaves
        resid_ms = np.mean(x**2) - offset**2 - 0.5 * np.sum(a**2 + b**2)
        residual_rms = float(np.sqrt(max(resid_ms, 0.0)))
    else:
        t = np.arange(n) / sample_rate
        arg = 2.0 * np.pi * fe * np.outer(t, k)
        design = np.hstack([np.ones((n, 1)), np.cos(arg), np.sin(arg)])
        sol, *_ = np.linalg.lstsq(design, x, rcond=None)
        offset, a, b = sol[0], sol[1:k_max + 1], sol[k_max + 1:]
        residual_rms = float(np.sqrt(np.mean((x - design @ sol) ** 2)))
    amplitude = np.hypot(a, b)
    phase = np.arctan2(-b, a)   # a cos + b sin = A cos(wt + phase)
    return HarmonicFit(k=k, frequency_hz=k * float(fe), amplitude=amplitude, phase=phase,
                       offset=float(offset), residual_rms=residual_rms)


def relative_phases(fit: HarmonicFit, reference: HarmonicFit | float) -> np.ndarray:
    """Phases of ``fit`` relative to a reference fundamental, radians in (-pi, pi].

    ``phase_k - k * phase_ref`` where ``phase_ref`` is the reference's k = 1 phase (e.g. of the
    force): the phase each harmonic would have if the time origin were moved to where the
    reference fundamental is ``cos(2 pi fe t)``. Both fits must share ``fe`` and their first
    sample. This makes phases comparable between records that start at different instants
    (EM versus FEM).
    """
    ref = float(reference.phase[0]) if isinstance(reference, HarmonicFit) else float(reference)
    return np.angle(np.exp(1j * (fit.phase - fit.k * ref)))


def derivative_harmonics(fit: HarmonicFit, order: int = 1) -> HarmonicFit:
    """Harmonics of the ``order``-th time derivative of the fitted signal.

    For a periodic signal the k-th Fourier coefficient of the derivative is exactly
    ``(i k w)`` times the signal's: amplitudes scale by ``(2 pi k fe)**order`` and phases advance
    by ``order * pi/2``. Useful to get acceleration harmonics from a sampled velocity (or
    displacement): when the acceleration jumps (impacts with damping) its point samples converge
    only to first order in the sampling step, while the continuous velocity's converge to second.
    The residual is not transformed (set to NaN).
    """
    order = int(order)
    w = 2.0 * np.pi * fit.frequency_hz
    phase = np.angle(np.exp(1j * (fit.phase + order * np.pi / 2)))
    return HarmonicFit(k=fit.k, frequency_hz=fit.frequency_hz, amplitude=fit.amplitude * w**order,
                       phase=phase, offset=0.0, residual_rms=float("nan"))
