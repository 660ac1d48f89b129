"""Frequency response functions from measured (or simulated) excitation and response records.

Conventions (the same as :func:`scipy.signal.csd`):

- ``csd(x, y)`` is the averaged ``conj(X) * Y`` (one-sided), so with ``x`` the excitation (force)
  and ``y`` the response,

  - ``H1 = Sxy / Sxx``  (least squares for noise on the response; biased LOW by input noise),
  - ``H2 = Syy / Syx``  with ``Syx = conj(Sxy)`` (biased HIGH by output noise),
  - ``coherence = |Sxy|**2 / (Sxx * Syy) = H1 / H2`` (real, between 0 and 1).

- Time convention ``exp(+i w t)``: a response lagging the force has a negative phase.
- FRF kinds: receptance ``X/F`` (m/N), mobility ``V/F = i w X/F`` (m/s/N),
  accelerance ``A/F = -w**2 X/F`` (m/s^2/N).

Random excitation needs a window (Hann by default), overlap and several averages; the coherence of a
single average is identically 1 and meaningless, so :func:`estimate_frf` refuses fewer than two.
Periodic (stepped-sine) excitation is best fitted at its exact frequency, see :func:`sine_frf`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import signal

FRFKind = Literal["receptance", "mobility", "accelerance"]
_KINDS = ("receptance", "mobility", "accelerance")


@dataclass(frozen=True)
class FRFEstimate:
    """An averaged FRF estimate on a one-sided frequency grid.

    Attributes
    ----------
    frequency_hz
        (n_freq,) frequencies, Hz (0 .. sample_rate / 2).
    h1, h2
        (n_freq,) complex FRF estimates, response units per excitation unit.
    coherence
        (n_freq,) ordinary coherence, 0..1.
    n_averages
        Number of (overlapping) segments averaged.
    sxx, syy, sxy
        Auto spectra of excitation and response and the cross spectrum csd(x, y), as
        densities (units**2 / Hz).
    """

    frequency_hz: np.ndarray
    h1: np.ndarray
    h2: np.ndarray
    coherence: np.ndarray
    n_averages: int
    sxx: np.ndarray
    syy: np.ndarray
    sxy: np.ndarray

    @property
    def resolution_hz(self) -> float:
        """Spacing of the frequency grid, Hz."""
        return float(self.frequency_hz[1] - self.frequency_hz[0])


def n_welch_segments(n_samples: int, nperseg: int, noverlap: int) -> int:
    """Number of segments scipy's Welch averaging uses for a record of ``n_samples``."""
    if n_samples < nperseg:
        return 0
    return 1 + (n_samples - nperseg) // (nperseg - noverlap)


def estimate_frf(
    excitation: np.ndarray,
    response: np.ndarray,
    sample_rate: float,
    *,
    nperseg: int,
    noverlap: int | None = None,
    window: str = "hann",
    detrend: str | bool = "constant",
) -> FRFEstimate:
    """H1, H2 and coherence of ``response`` over ``excitation`` by Welch averaging.

    Parameters
    ----------
    excitation, response
        Equal-length 1-D records (e.g. force in N and acceleration in m/s^2).
    sample_rate
        Samples per second, Hz.
    nperseg
        Segment length in samples; the frequency resolution is ``sample_rate / nperseg``.
    noverlap
        Overlap in samples; default half a segment.
    window
        Any :func:`scipy.signal.get_window` name; ``"hann"`` for random excitation,
        ``"boxcar"`` for periodic excitation with whole periods per segment.
    detrend
        Passed to scipy (``"constant"`` removes each segment's mean).

    Returns
    -------
    FRFEstimate

    Raises
    ------
    ValueError
        If the records differ in length or hold fewer than two segments.
    """
    x = np.asarray(excitation, dtype=float)
    y = np.asarray(response, dtype=float)
    if x.ndim != 1 or x.shape != y.shape:
        raise ValueError(f"excitation and response must be equal-length 1-D arrays, got {x.shape} and {y.shape}")
    if noverlap is None:
        noverlap = nperseg // 2
    n_avg = n_welch_segments(x.size, nperseg, noverlap)
    if n_avg < 2:
        raise ValueError(
            f"{x.size} samples give {n_avg} segment(s) of {nperseg}: need at least 2 averages "
            "(a single average has coherence 1 by construction)"
        )
    kw = dict(fs=sample_rate, window=window, nperseg=nperseg, noverlap=noverlap, detrend=detrend)
    f, sxx = signal.welch(x, **kw)
    _, syy = signal.welch(y, **kw)
    _, sxy = signal.csd(x, y, **kw)
    with np.errstate(divide="ignore", invalid="ignore"):
        h1 = sxy / sxx
        h2 = syy / np.conj(sxy)
        coh = np.abs(sxy) ** 2 / (sxx * syy)
    return FRFEstimate(f, h1, h2, np.clip(np.nan_to_num(coh), 0.0, 1.0), n_avg, sxx, syy, sxy)


def sine_frf(excitation: np.ndarray, response: np.ndarray, sample_rate: float, frequency_hz: float) -> complex:
    """Complex ratio response/excitation at one frequency (stepped-sine point).

    Each record is fitted by least squares with ``c + a cos(w t) + b sin(w t)``; the ratio of the
    fitted complex amplitudes ``a - i b`` is exact for any record length (no leakage), provided the
    response has settled.
    """
    x = np.asarray(excitation, dtype=float)
    y = np.asarray(response, dtype=float)
    t = np.arange(x.size) / sample_rate
    w = 2.0 * np.pi * frequency_hz
    basis = np.column_stack([np.ones_like(t), np.cos(w * t), np.sin(w * t)])
    coef, *_ = np.linalg.lstsq(basis, np.column_stack([x, y]), rcond=None)
    amp = coef[1] - 1j * coef[2]
    return complex(amp[1] / amp[0])


def convert_frf(h: np.ndarray, frequency_hz: np.ndarray, source: FRFKind, target: FRFKind) -> np.ndarray:
    """Convert between receptance, mobility and accelerance (``exp(+i w t)`` convention).

    mobility = i w * receptance; accelerance = i w * mobility = -w**2 * receptance. Converting
    towards receptance divides by ``(i w)**k`` and gives ``nan`` at 0 Hz.
    """
    if source not in _KINDS or target not in _KINDS:
        raise ValueError(f"FRF kind must be one of {_KINDS}, got {source!r} -> {target!r}")
    order = _KINDS.index(target) - _KINDS.index(source)
    iw = 2j * np.pi * np.asarray(frequency_hz, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(h) * iw**order


def sdof_frf(
    frequency_hz: np.ndarray,
    natural_hz: float,
    damping_ratio: float,
    modal_mass: float = 1.0,
    kind: FRFKind = "receptance",
) -> np.ndarray:
    """Exact FRF of a viscously damped single-degree-of-freedom oscillator.

    receptance = 1 / (m (wn**2 - w**2 + 2 i zeta wn w)), converted to ``kind``.
    """
    w = 2.0 * np.pi * np.asarray(frequency_hz, dtype=float)
    wn = 2.0 * np.pi * natural_hz
    receptance = 1.0 / (modal_mass * (wn**2 - w**2 + 2j * damping_ratio * wn * w))
    return convert_frf(receptance, frequency_hz, "receptance", kind)
