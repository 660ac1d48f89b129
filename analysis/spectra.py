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

from dataclasses import dataclass

import numpy as np

from rigtools.analysis.harmonics import harmonic_amplitudes

WINDOWS = ("flattop", "hann", "boxcar")


AMPLITUDES = ("peak", "rms")
PSD_PEAK_DB = 3.0  # a peak of the averaged PSD has both half-power points


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

    Examples
    --------
    >>> import numpy as np
    >>> from rigtools.analysis.spectra import amplitude_spectrum
    >>> fs = 1000.0
    >>> t = np.arange(2000) / fs
    >>> f, a = amplitude_spectrum(2.0 * np.sin(2 * np.pi * 50.0 * t), fs)  # 2 units peak at 50 Hz
    >>> float(f[np.argmax(a)]), round(float(a.max()), 4)
    (50.0, 2.0)
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


@dataclass(frozen=True)
class ResponseSpectra:
    """Spectra of one response-only (operational) channel, see :func:`response_spectra`.

    Attributes
    ----------
    frequency_hz, psd
        Welch power spectral density (Hann, 50 % overlap, ``scipy.signal.welch``
        ``scaling="density"``, one-sided): units² / Hz; its integral over frequency is the
        variance of the signal.
    amplitude_hz, amplitude
        Peak-amplitude spectrum of the whole record (:func:`amplitude_spectrum`, flattop): a
        sine of peak amplitude A reads A.
    peaks
        The strongest peaks of the averaged PSD (at least 3 dB prominent: one per resonance,
        where an unaveraged spectrum shows several noise spikes): ``{"frequency_hz", "psd",
        "amplitude"}`` (PSD in units²/Hz; ``amplitude`` the flattop spectrum's highest value
        within one PSD line, the peak amplitude of a tone), descending in PSD.
    harmonics
        With ``fe``: ``{"k", "frequency_hz", "amplitude", "phase"}`` of k·fe by exact least
        squares (:func:`rigtools.analysis.harmonics.harmonic_amplitudes`); else empty.
    """

    frequency_hz: np.ndarray
    psd: np.ndarray
    amplitude_hz: np.ndarray
    amplitude: np.ndarray
    peaks: list[dict]
    harmonics: list[dict]
    rms: float

    def to_dict(self) -> dict:
        """Plain-Python summary (peaks, harmonics, RMS; the arrays are for figures)."""
        return {
            "rms": self.rms,
            "psd_scaling": "units^2/Hz (Welch, Hann, 50 % overlap, one-sided)",
            "amplitude_scaling": "peak (flattop)",
            "resolution_hz": float(self.frequency_hz[1] - self.frequency_hz[0]),
            "peaks": self.peaks,
            "harmonics": self.harmonics,
        }


def response_spectra(
    x: np.ndarray,
    sample_rate: float,
    *,
    fe: float | None = None,
    n_peaks: int = 5,
    k_max: int = 10,
    nperseg: int | None = None,
) -> ResponseSpectra:
    """What a lab reads from a response without a force: PSD, amplitude spectrum, its peaks and
    (with the excitation frequency ``fe``) the harmonics k·fe.

    Parameters
    ----------
    x
        (n,) samples, SI units.
    sample_rate
        Hz.
    fe
        Excitation (e.g. shaft or mains) frequency, Hz, or None.
    n_peaks
        Number of peaks reported (at least 3 dB prominent in the averaged PSD).
    k_max
        Highest harmonic of ``fe`` (lowered below the Nyquist frequency).
    nperseg
        Welch segment length (default: a power of two giving about 16 averages).
    """
    from scipy.signal import find_peaks, welch

    x = np.asarray(x, dtype=float)
    if nperseg is None:
        nperseg = int(min(2 ** np.floor(np.log2(max(x.size / 8.5, 16))), 1 << 16, x.size))
    f, psd = welch(x, fs=sample_rate, window="hann", nperseg=nperseg, noverlap=nperseg // 2)
    fa, amp = amplitude_spectrum(x, sample_rate)
    db = 10 * np.log10(np.maximum(psd, np.finfo(float).tiny))
    idx, _ = find_peaks(db, prominence=PSD_PEAK_DB)
    idx = idx[f[idx] > 0]
    idx = idx[np.argsort(psd[idx])[::-1][:n_peaks]]
    df = float(f[1])
    peaks = []
    for i in idx:
        near = np.abs(fa - f[i]) <= df
        peaks.append(
            {
                "frequency_hz": float(f[i]),
                "psd": float(psd[i]),
                "amplitude": float(np.max(amp[near])) if np.any(near) else float("nan"),
            }
        )
    harmonics: list[dict] = []
    if fe:
        k = max(1, min(int(k_max), int(np.floor(sample_rate / 2 / fe - 1e-9))))
        fit = harmonic_amplitudes(x, sample_rate, float(fe), k)
        harmonics = [
            {"k": j + 1, "frequency_hz": (j + 1) * float(fe), "amplitude": float(a), "phase": float(p)}
            for j, (a, p) in enumerate(zip(fit.amplitude, fit.phase, strict=True))
        ]
    return ResponseSpectra(f, psd, fa, amp, peaks, harmonics, float(np.sqrt(np.mean((x - x.mean()) ** 2))))
