"""Single-sided amplitude spectra with documented scaling.

Scaling: a sine ``A*sin(2*pi*f*t)`` reads ``A`` (peak) at its bin when ``f`` falls on a bin, for
every window (the window is normalised by its coherent gain ``sum(w)/n``). Between bins the
reading drops by the window's scalloping loss: up to about 36 % (boxcar), 15 % (Hann) and under
0.12 % (flattop). Use the flattop window to read amplitudes of tones, Hann to separate close
tones, boxcar when the record holds whole periods of every tone. The DC bin reads the mean.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import get_window

WINDOWS = ("flattop", "hann", "boxcar")


def amplitude_spectrum(
    x: np.ndarray, sample_rate: float, window: str = "flattop"
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

    Returns
    -------
    freqs : (n//2 + 1,) array
        Bin frequencies, Hz (``scipy.fft.rfftfreq``).
    amplitude : array, shape (..., n//2 + 1)
        Peak amplitude per bin, in the units of ``x`` (see module docstring for the scaling).
    """
    if window not in WINDOWS:
        raise ValueError(f"window must be one of {', '.join(WINDOWS)}, got {window!r}")
    if not sample_rate > 0:
        raise ValueError("sample_rate must be positive")
    x = np.asarray(x, dtype=float)
    n = x.shape[-1]
    if n < 2:
        raise ValueError("need at least 2 samples")
    w = get_window(window, n, fftbins=True)
    spectrum = np.fft.rfft(x * w, axis=-1)
    amplitude = np.abs(spectrum) * (2.0 / w.sum())
    amplitude[..., 0] *= 0.5
    if n % 2 == 0:
        amplitude[..., -1] *= 0.5   # the Nyquist bin has no mirror image either
    freqs = np.fft.rfftfreq(n, d=1.0 / sample_rate)
    return freqs, amplitude
