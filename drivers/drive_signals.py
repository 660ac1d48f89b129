"""Every drive signal that goes to the shaker amplifier, and the ramps that shape them.

* :func:`raised_cosine` -- the 0 -> 1 ramp every amplitude change follows;
* :class:`AmplitudeEnvelope` -- the one owner of drive-amplitude ramps (no step ever reaches
  the shaker);
* :class:`SineDrive` -- phase-continuous sine (dwell, stepped sine, force control);
* :class:`RandomDrive` -- band-limited Gaussian random, continuous or burst;
* :class:`PeriodicChirp` -- a linear chirp over a band repeated every period (periodic, so a
  rectangular window over whole periods has no leakage).

Every drive has ``next_block(n)``, ``stop_block()`` (a normal ramp to exactly 0 V) and
``settled``; :class:`rigtools.acquisition.BlockStream` streams them. A raised-cosine ramp from
``a0`` to ``a1`` over ``T`` is ``a0 + (a1 - a0) (1 - cos(pi t / T)) / 2``: continuous in value
and slope at both ends, so the shaker sees no step and no kink.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy import signal

from rigtools.drivers.contracts import ConfigurationError, LimitExceeded


def raised_cosine(n: int) -> np.ndarray:
    """``n`` samples of a 0 -> 1 raised-cosine ramp, excluding 0 and including 1.

    Sample ``k`` (1-based) is ``(1 - cos(pi k / n)) / 2``, so a ramp written after a sample at
    the start value ends exactly at the end value.
    """
    if n <= 0:
        return np.empty(0)
    k = np.arange(1, n + 1, dtype=float)
    return 0.5 * (1.0 - np.cos(np.pi * k / n))


class AmplitudeEnvelope:
    """A drive amplitude that never steps: every change follows a raised-cosine ramp.

    The one owner of drive-amplitude ramps: :class:`SineDrive` and
    :class:`rigtools.acquisition.RandomDrive` multiply their unit signal by :meth:`take`.

    Parameters
    ----------
    sample_rate
        Samples per second of the drive.
    ramp_time
        Duration of every change unless :meth:`set_target` is given another, s (> 0).
    max_value
        Targets above it are refused, V.
    what
        Name of the amplitude in error messages (``"drive amplitude"``, ``"rms"``).

    Raises
    ------
    ConfigurationError
        If ``ramp_time`` or ``max_value`` is not > 0.
    """

    def __init__(
        self, sample_rate: float, ramp_time: float, max_value: float, what: str = "drive amplitude"
    ) -> None:
        if not ramp_time > 0:
            raise ConfigurationError(f"ramp time {ramp_time!r} s must be > 0")
        if not max_value > 0:
            raise ConfigurationError(f"max drive {max_value!r} V must be > 0")
        self.sample_rate = float(sample_rate)
        self.ramp_time = float(ramp_time)
        self.max_value = float(max_value)
        self.what = what
        self._amp = 0.0  # amplitude of the last sample taken
        self._ramp = np.empty(0)  # amplitudes still to come on the current ramp
        self._target = 0.0

    @property
    def amplitude(self) -> float:
        """Amplitude of the last sample taken."""
        return self._amp

    @property
    def target(self) -> float:
        return self._target

    @property
    def settled(self) -> bool:
        """True when the amplitude has reached its target (no ramp in progress)."""
        return self._ramp.size == 0

    def set_target(self, value: float, ramp_time: float | None = None) -> int:
        """Ramp from the present amplitude to ``value`` over ``ramp_time`` (default the envelope's).

        A new target during a ramp starts a new ramp from the present amplitude.

        Returns
        -------
        int
            Samples of the ramp: ``ceil(ramp_time * sample_rate)``, at least 1.

        Raises
        ------
        LimitExceeded
            If ``value`` is negative, not finite or above ``max_value``.
        """
        if not (math.isfinite(value) and 0.0 <= value <= self.max_value):
            raise LimitExceeded(f"{self.what} {value!r} V is outside 0..{self.max_value:g} V (maximum drive)")
        duration = self.ramp_time if ramp_time is None else float(ramp_time)
        n = max(1, math.ceil(duration * self.sample_rate))
        self._target = float(value)
        if value == self._amp:
            self._ramp = np.empty(0)
        else:
            self._ramp = self._amp + (value - self._amp) * raised_cosine(n)
        return n

    def take(self, n: int) -> np.ndarray:
        """The amplitudes of the next ``n`` samples, continuing the ramp in progress."""
        amps = np.full(int(n), self._target)
        m = min(amps.size, self._ramp.size)
        amps[:m] = self._ramp[:m]
        self._ramp = self._ramp[m:]
        if amps.size:
            self._amp = float(amps[-1])
        return amps

    def stop_block(
        self, next_block: Callable[[int], np.ndarray], ramp_time: float | None = None
    ) -> np.ndarray:
        """A normal ramp to zero (``ramp_time``) as one block of ``next_block``; ends at 0 V.

        ``next_block(n)`` is the drive's, taking its amplitudes from this envelope. The ramp's
        last amplitude is exactly 0 (:func:`raised_cosine` ends at exactly 1); the last sample is
        set to +0.0 all the same (sign, clipping).
        """
        block = next_block(self.set_target(0.0, ramp_time))
        block[-1] = 0.0
        return block


class SineDrive:
    """Phase-continuous sine drive ``a(t) sin(2 pi f t + phi)`` with ramped amplitude ``a(t)``.

    Parameters
    ----------
    sample_rate
        Drive sample rate, S/s (use the device's actual rate).
    frequency
        Sine frequency, Hz.
    max_drive
        Peak voltage never exceeded: targets above it are refused.
    ramp_time
        Duration of every amplitude change (raised cosine), s.

    Examples
    --------
    >>> import numpy as np
    >>> drive = SineDrive(51200.0, 60.0, max_drive=5.0, ramp_time=0.5)
    >>> drive.set_target(2.0)                  # ramps up over 0.5 s from the next sample
    >>> block = drive.next_block(51200)        # 1 s: the ramp, then 2 V peak
    >>> round(float(np.abs(block[-854:]).max()), 3)      # the last period
    2.0
    >>> tail = drive.stop_block()              # 0.5 s of samples ending at 0 V
    >>> len(tail), float(tail[-1]), drive.amplitude
    (25600, 0.0, 0.0)
    """

    def __init__(
        self, sample_rate: float, frequency: float, max_drive: float, ramp_time: float, phase: float = 0.0
    ) -> None:
        if not (sample_rate > 0 and math.isfinite(sample_rate)):
            raise ConfigurationError(f"sample rate {sample_rate!r} must be > 0")
        self._envelope = AmplitudeEnvelope(sample_rate, ramp_time, max_drive)
        self.sample_rate = float(sample_rate)
        self.max_drive = float(max_drive)
        self.ramp_time = float(ramp_time)
        self._phase = float(phase)  # phase of the next sample, rad
        self._omega = 0.0
        self.set_frequency(frequency)
        self.samples_written = 0

    @property
    def amplitude(self) -> float:
        """Amplitude (V peak) of the last sample produced."""
        return self._envelope.amplitude

    @property
    def target(self) -> float:
        return self._envelope.target

    @property
    def frequency(self) -> float:
        return self._omega * self.sample_rate / (2 * math.pi)

    @property
    def settled(self) -> bool:
        """True when the amplitude has reached its target (no ramp in progress)."""
        return self._envelope.settled

    def set_frequency(self, frequency: float) -> None:
        """Change the frequency; the phase stays continuous."""
        if not (frequency > 0 and frequency < self.sample_rate / 2):
            raise LimitExceeded(
                f"drive frequency {frequency!r} Hz must be in (0, "
                f"{self.sample_rate / 2:g}) Hz (below Nyquist)"
            )
        self._omega = 2 * math.pi * frequency / self.sample_rate

    def set_target(self, amplitude: float, ramp_time: float | None = None) -> None:
        """Move the amplitude to ``amplitude`` (V peak) along a raised-cosine ramp.

        A new target during a ramp starts a new ramp from the present amplitude.

        Raises
        ------
        LimitExceeded
            If ``amplitude`` is negative, not finite or above ``max_drive``.
        """
        self._envelope.set_target(amplitude, ramp_time)

    def next_block(self, n: int) -> np.ndarray:
        """The next ``n`` drive samples (V), continuing phase and ramp."""
        n = int(n)
        amps = self._envelope.take(n)
        phases = self._phase + self._omega * np.arange(n)
        self._phase = float((self._phase + self._omega * n) % (2 * math.pi))
        self.samples_written += n
        return amps * np.sin(phases)

    def stop_block(self, ramp_time: float | None = None) -> np.ndarray:
        """A ramp to zero (default ``ramp_time``) as one block; the last sample is 0 V."""
        return self._envelope.stop_block(self.next_block, ramp_time)


class RandomDrive:
    """Band-limited Gaussian random drive, continuous or in bursts, with ramped amplitude.

    White Gaussian noise through a Butterworth band-pass (state carried across blocks), scaled
    to ``rms`` volts and clipped at ``max_drive``. Amplitude changes follow a raised-cosine ramp
    of ``ramp_time`` (a :class:`AmplitudeEnvelope`, as for the sine drive). With
    ``burst_period``, the noise is on for ``burst_fraction`` of every period (starting at each
    period), its edges tapered over ``edge_time``, and off for the rest:
    burst random, where each period holds the whole response (no leakage with a rectangular
    window when the response has decayed by the period's end).

    Parameters
    ----------
    sample_rate
        S/s.
    rms
        Target RMS of the continuous noise (within bursts), V.
    band
        ``(f_low, f_high)`` Hz of the band-pass (4th order).
    max_drive
        Peak never exceeded, V (samples beyond are clipped).
    ramp_time
        Amplitude ramp, s (> 0).
    burst_period, burst_fraction, edge_time
        Burst random timing, s / fraction / s; ``burst_period=None`` for continuous random.
    seed
        Noise seed.
    """

    def __init__(
        self,
        sample_rate: float,
        rms: float,
        band: tuple[float, float],
        *,
        max_drive: float,
        ramp_time: float = 0.5,
        burst_period: float | None = None,
        burst_fraction: float = 0.5,
        edge_time: float = 0.005,
        seed: int | None = None,
    ) -> None:
        lo, hi = band
        if not 0 < lo < hi < sample_rate / 2:
            raise ValueError(f"band {band} Hz must satisfy 0 < low < high < {sample_rate / 2:g}")
        if not 0 < rms <= max_drive:
            raise ValueError(f"rms {rms} V must be in (0, max_drive = {max_drive}]")
        if burst_period is not None and not (0 < burst_fraction <= 1 and burst_period > 0):
            raise ValueError("burst_period must be > 0 and burst_fraction in (0, 1]")
        self._envelope = AmplitudeEnvelope(sample_rate, ramp_time, max_drive, what="rms")
        self.sample_rate = float(sample_rate)
        self.max_drive = float(max_drive)
        self.ramp_time = float(ramp_time)
        self._sos = signal.butter(4, [lo, hi], btype="bandpass", fs=sample_rate, output="sos")
        self._zi = np.zeros((self._sos.shape[0], 2))
        impulse = np.zeros(int(20 * sample_rate / lo))
        impulse[0] = 1.0
        self._gain = 1.0 / math.sqrt(float(np.sum(signal.sosfilt(self._sos, impulse) ** 2)))
        self._rng = np.random.default_rng(seed)
        self._k = 0
        if burst_period is None:
            self._gate = None
        else:
            period = round(burst_period * sample_rate)
            on = round(burst_fraction * period)
            edge = min(max(1, round(edge_time * sample_rate)), on // 2)
            rise = raised_cosine(edge)  # ends at exactly 1
            gate = np.zeros(period)
            gate[:on] = 1.0
            gate[:edge] = rise
            if on < period:
                gate[on - edge : on] = 1.0 - rise  # ends at exactly 0
            self._gate = gate
        self.set_target(rms)

    @property
    def settled(self) -> bool:
        return self._envelope.settled

    @property
    def burst_samples(self) -> int | None:
        """Samples per burst period, or ``None`` for continuous random."""
        return None if self._gate is None else self._gate.size

    def set_target(self, rms: float, ramp_time: float | None = None) -> None:
        """Ramp the RMS to ``rms`` V (raised cosine over ``ramp_time``).

        Raises
        ------
        LimitExceeded
            (a ``ValueError``) if ``rms`` is negative, not finite or above ``max_drive``.
        """
        self._envelope.set_target(rms, ramp_time)

    def next_block(self, n: int) -> np.ndarray:
        """The next ``n`` samples, V."""
        amps = self._envelope.take(n)
        noise, self._zi = signal.sosfilt(self._sos, self._rng.standard_normal(n), zi=self._zi)
        out = amps * self._gain * noise
        if self._gate is not None:
            out *= self._gate[(self._k + np.arange(n)) % self._gate.size]
        self._k += n
        return np.clip(out, -self.max_drive, self.max_drive)

    def stop_block(self, ramp_time: float | None = None) -> np.ndarray:
        """A ramp to zero (default ``ramp_time``), ending at exactly 0 V."""
        return self._envelope.stop_block(self.next_block, ramp_time)


class PeriodicChirp:
    """A linear chirp from ``band[0]`` to ``band[1]`` Hz, repeated every ``period`` s.

    Each period is ``sin(2 pi (f0 t + (f1 - f0) t^2 / (2 T)))``, ``0 <= t < T``, with the sweep
    rate rounded so that every period ends at a whole number of cycles: the signal is exactly
    periodic, and an FRF over whole periods needs no window. The amplitude ramps through an
    :class:`AmplitudeEnvelope` like every drive.

    Parameters
    ----------
    sample_rate
        S/s.
    amplitude
        Peak drive, V.
    band
        ``(f_low, f_high)`` Hz, ``0 < f_low < f_high < sample_rate / 2``.
    period
        Chirp period, s (the frequency resolution of an FRF over whole periods is ``1 / period``).
    max_drive, ramp_time
        As for :class:`SineDrive`.
    """

    def __init__(
        self,
        sample_rate: float,
        amplitude: float,
        band: tuple[float, float],
        *,
        period: float,
        max_drive: float,
        ramp_time: float = 0.5,
    ) -> None:
        lo, hi = float(band[0]), float(band[1])
        if not 0 < lo < hi < sample_rate / 2:
            raise ValueError(f"band {band} Hz must satisfy 0 < low < high < {sample_rate / 2:g}")
        n = round(period * sample_rate)
        if n < 4:
            raise ValueError(f"period {period!r} s is shorter than 4 samples")
        t_per = n / sample_rate
        # the phase at the period's end, (f0 + f1) T / 2 cycles, made a whole number
        cycles = max(1, round((lo + hi) * t_per / 2))
        hi_eff = 2 * cycles / t_per - lo
        t = np.arange(n) / sample_rate
        self.period_samples = n
        self.band = (lo, hi_eff)
        self._unit = np.sin(2 * np.pi * (lo * t + (hi_eff - lo) * t * t / (2 * t_per)))
        self._envelope = AmplitudeEnvelope(sample_rate, ramp_time, max_drive)
        self.sample_rate = float(sample_rate)
        self.max_drive = float(max_drive)
        self._k = 0
        self.set_target(amplitude)

    @property
    def settled(self) -> bool:
        return self._envelope.settled

    def set_target(self, amplitude: float, ramp_time: float | None = None) -> None:
        """Ramp the peak amplitude to ``amplitude`` V (raised cosine)."""
        self._envelope.set_target(amplitude, ramp_time)

    def next_block(self, n: int) -> np.ndarray:
        """The next ``n`` samples, V."""
        idx = (self._k + np.arange(int(n))) % self.period_samples
        self._k += int(n)
        return self._envelope.take(n) * self._unit[idx]

    def stop_block(self, ramp_time: float | None = None) -> np.ndarray:
        """A ramp to zero (default ``ramp_time``), ending at exactly 0 V."""
        return self._envelope.stop_block(self.next_block, ramp_time)
