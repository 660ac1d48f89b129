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
            for k, f, a, p in zip(self.k, self.frequency_hz, self.amplitude, self.phase, strict=True)
        ]


def harmonic_amplitudes(x: np.ndarray, sample_rate: float, fe: float, k_max: int = 30) -> HarmonicFit:
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

    Examples
    --------
    A record of 1234 samples is not a whole number of periods of 60 Hz; the fit is exact anyway:

    >>> import numpy as np
    >>> from rigtools.analysis.harmonics import harmonic_amplitudes
    >>> fs, fe = 1000.0, 60.0
    >>> t = np.arange(1234) / fs
    >>> x = 3.0 * np.cos(2 * np.pi * fe * t) + 0.5 * np.sin(2 * np.pi * 3 * fe * t)
    >>> fit = harmonic_amplitudes(x, fs, fe, k_max=3)
    >>> fit.k, np.round(fit.amplitude, 6)
    (array([1, 2, 3]), array([3. , 0. , 0.5]))
    >>> round(float(fit.phase[2]), 4)  # sin = cos(... - pi/2)
    -1.5708
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
            f"{sample_rate / 2:g} Hz"
        )
    n = x.size
    if n < 2 * k_max + 1:
        raise ValueError(f"need at least {2 * k_max + 1} samples to fit {k_max} harmonics, got {n}")
    k = np.arange(1, k_max + 1)

    samples_per_period = sample_rate / fe
    periods = n / samples_per_period
    whole = (
        abs(samples_per_period - round(samples_per_period)) < 1e-9 * samples_per_period
        and abs(periods - round(periods)) < 1e-9 * max(periods, 1.0)
        and round(periods) >= 1
    )
    if whole:
        spectrum = np.fft.rfft(x)
        bins = k * round(periods)
        coef = spectrum[bins] * (2.0 / n)  # a - i b for a cos + b sin
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
        offset, a, b = sol[0], sol[1 : k_max + 1], sol[k_max + 1 :]
        residual_rms = float(np.sqrt(np.mean((x - design @ sol) ** 2)))
    amplitude = np.hypot(a, b)
    phase = np.arctan2(-b, a)  # a cos + b sin = A cos(wt + phase)
    return HarmonicFit(
        k=k,
        frequency_hz=k * float(fe),
        amplitude=amplitude,
        phase=phase,
        offset=float(offset),
        residual_rms=residual_rms,
    )


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
    return HarmonicFit(
        k=fit.k,
        frequency_hz=fit.frequency_hz,
        amplitude=fit.amplitude * w**order,
        phase=phase,
        offset=0.0,
        residual_rms=float("nan"),
    )


class HarmonicAccumulator:
    """Harmonic least squares of long multichannel records fed block by block (bounded memory).

    Accumulates the normal equations of the fit of :func:`harmonic_amplitudes`,
    ``(D^T D) c = D^T x`` with ``D = [1, cos(2 pi k fe t), sin(2 pi k fe t)]``, block by block, with
    ``t`` counted from the first sample of the first block; :meth:`result` solves them. The same
    numbers as :func:`harmonic_amplitudes` on the whole record (to round-off; the columns are
    nearly orthogonal over many periods, so the normal equations are well conditioned). Memory:
    one block times ``2 k_max + 1`` columns.

    Parameters
    ----------
    sample_rate, fe, k_max
        As :func:`harmonic_amplitudes`.
    """

    def __init__(self, sample_rate: float, fe: float, k_max: int = 30) -> None:
        if not (sample_rate > 0 and fe > 0):
            raise ValueError("sample_rate and fe must be positive")
        if k_max * fe >= sample_rate / 2:
            raise ValueError(
                f"harmonic {k_max}*fe = {k_max * fe:g} Hz is not below the Nyquist frequency "
                f"{sample_rate / 2:g} Hz"
            )
        self.sample_rate, self.fe, self.k_max = float(sample_rate), float(fe), int(k_max)
        self.k = np.arange(1, self.k_max + 1)
        m = 2 * self.k_max + 1
        self._dtd = np.zeros((m, m))
        self._dtx: np.ndarray | None = None
        self._xtx: np.ndarray | None = None
        self.n = 0

    def add(self, block: np.ndarray, max_rows: int = 65536) -> None:
        """Add the next ``(n_channels, n)`` (or ``(n,)``) samples."""
        x = np.atleast_2d(np.asarray(block, dtype=float))
        if self._dtx is None:
            self._dtx = np.zeros((2 * self.k_max + 1, x.shape[0]))
            self._xtx = np.zeros(x.shape[0])
        for start in range(0, x.shape[1], max_rows):
            xs = x[:, start : start + max_rows]
            idx = self.n + np.arange(xs.shape[1])
            # phase of the fundamental reduced modulo one period in exact integer arithmetic
            # where possible, so far-off samples keep full precision
            arg = 2.0 * np.pi * np.outer(np.mod(idx * self.fe / self.sample_rate, 1.0), self.k)
            d = np.hstack([np.ones((idx.size, 1)), np.cos(arg), np.sin(arg)])
            self._dtd += d.T @ d
            self._dtx += d.T @ xs.T
            self._xtx += np.einsum("cn,cn->c", xs, xs)
            self.n += idx.size

    def result(self) -> list[HarmonicFit]:
        """One :class:`HarmonicFit` per channel."""
        if self._dtx is None or self._xtx is None or self.n < 2 * self.k_max + 1:
            raise ValueError(
                f"need at least {2 * self.k_max + 1} samples to fit {self.k_max} harmonics, got {self.n}"
            )
        sol = np.linalg.solve(self._dtd, self._dtx)
        fits = []
        for c in range(sol.shape[1]):
            coef = sol[:, c]
            offset, a, b = coef[0], coef[1 : self.k_max + 1], coef[self.k_max + 1 :]
            resid = self._xtx[c] - 2 * coef @ self._dtx[:, c] + coef @ self._dtd @ coef
            fits.append(
                HarmonicFit(
                    k=self.k,
                    frequency_hz=self.k * self.fe,
                    amplitude=np.hypot(a, b),
                    phase=np.arctan2(-b, a),
                    offset=float(offset),
                    residual_rms=float(np.sqrt(max(resid, 0.0) / self.n)),
                )
            )
        return fits


def harmonics_from_blocks(blocks, sample_rate: float, fe: float, k_max: int = 30) -> list[HarmonicFit]:
    """:class:`HarmonicAccumulator` over an iterable of ``(n_channels, n)`` blocks in time order."""
    acc = HarmonicAccumulator(sample_rate, fe, k_max)
    for block in blocks:
        acc.add(block)
    return acc.result()


ROUND_OFF = 1e-9  # a harmonic below this fraction of its channel's largest is zero (round-off)


def without_round_off(amplitudes) -> np.ndarray:
    """Harmonic amplitudes with the round-off of a zero harmonic (below :data:`ROUND_OFF` times
    the channel's largest, e.g. the k >= 2 force harmonics of a model driven by ``F0 sin``) set to
    NaN: not a number to compare nor a bar to draw on a log axis."""
    a = np.array(amplitudes, dtype=float)
    finite = np.abs(a[np.isfinite(a)])
    top = finite.max() if finite.size else 0.0
    a[np.abs(a) <= ROUND_OFF * top] = np.nan
    return a
