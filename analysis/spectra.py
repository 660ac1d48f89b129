"""Single-sided amplitude spectra with documented scaling.

Scaling: a sine ``A*sin(2*pi*f*t)`` reads ``A`` (peak) at its bin when ``f`` falls on a bin, for
every window (the window is normalised by its coherent gain ``sum(w)/n``). Between bins the
reading drops by the window's scalloping loss: up to about 36 % (boxcar), 15 % (Hann) and under
0.12 % (flattop). Use the flattop window to read amplitudes of tones, Hann to separate close
tones, boxcar when the record holds whole periods of every tone. The DC bin reads the mean.

``amplitude="peak"`` (default) reads a tone's peak value ``A``; ``amplitude="rms"`` reads its RMS
value ``A / sqrt(2)`` (the DC bin reads the mean in both). Labels should say which
(:func:`amplitude_label`). For the harmonics of a known ``fe`` use
:func:`rigtools.analysis.harmonics.harmonic_amplitudes` (exact least squares, no window, no scalloping).
For broadband signals use a density (:func:`scipy.signal.welch`), not an amplitude spectrum.
"""

from __future__ import annotations

import numpy as np

WINDOWS = ("flattop", "hann", "boxcar")


AMPLITUDES = ("peak", "rms")


def amplitude_label(quantity: str, unit: str, amplitude: str = "peak") -> str:
    """Axis label such as ``"acceleration, peak amplitude (m/s²)"``."""
    if amplitude not in AMPLITUDES:
        raise ValueError(f"amplitude must be 'peak' or 'rms', got {amplitude!r}")
    unit = unit.replace("^2", "²")
    kind = "peak amplitude" if amplitude == "peak" else "RMS amplitude"
    return f"{quantity}, {kind} ({unit})"


def amplitude_spectrum(
    x: np.ndarray, sample_rate: float, window: str = "flattop", amplitude: str = "peak"
) -> tuple[np.ndarray, np.ndarray]:
    """Peak-amplitude spectrum of a real signal.

    Parameters
    ----------
    x
        Uniformly sampled signal, shape (n,), or (channels, n) for several at once.
    sample_rate
        Samples per second, Hz.
    window
        ``"flattop"`` (default, amplitude-accurate between bins), ``"hann"`` or ``"boxcar"``.
    amplitude
        ``"peak"`` (default) or ``"rms"`` (peak / sqrt(2) for every bin but DC).

    Returns
    -------
    freqs : (n//2 + 1,) array
        Bin frequencies, Hz (``scipy.fft.rfftfreq``).
    amplitude : array, shape (..., n//2 + 1)
        Peak amplitude per bin, in the units of ``x`` (see module docstring for the scaling).
    """
    if window not in WINDOWS:
        raise ValueError(f"window must be one of {', '.join(WINDOWS)}, got {window!r}")
    if amplitude not in AMPLITUDES:
        raise ValueError(f"amplitude must be 'peak' or 'rms', got {amplitude!r}")
    if not sample_rate > 0:
        raise ValueError("sample_rate must be positive")
    x = np.asarray(x, dtype=float)
    n = x.shape[-1]
    if n < 2:
        raise ValueError("need at least 2 samples")
    if window == "boxcar":
        w = np.ones(n)
    else:
        from scipy.signal import get_window  # 0.3 s to import: only when a window is used

        w = get_window(window, n, fftbins=True)
    spectrum = np.fft.rfft(x * w, axis=-1)
    amp = np.abs(spectrum) * (2.0 / w.sum())
    amp[..., 0] *= 0.5
    if n % 2 == 0:
        amp[..., -1] *= 0.5  # the Nyquist bin has no mirror image either
    if amplitude == "rms":
        amp[..., 1:] /= np.sqrt(2.0)
    freqs = np.fft.rfftfreq(n, d=1.0 / sample_rate)
    return freqs, amp
