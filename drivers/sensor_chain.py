"""The measurement chain of a simulated input channel: sensor, IEPE coupling, noise, ADC.

For each channel, a physical signal ``x`` (N, m/s^2 or V) becomes what a DAQ reads:

1. sensor: ``x + n_s`` (the sensor's own broadband noise ``n_s``, SI rms), times the sensitivity
   ``S`` (V per SI unit);
2. IEPE / AC coupling: first-order high-pass ``H(s) = s / (s + 2 pi fc)`` (``fc`` about 0.5 Hz;
   0 disables it), discretised by the bilinear transform pre-warped at ``fc`` (exact at the
   corner, within ``(fc / fs)**2`` elsewhere); its state is carried from block to block;
3. ADC: input noise ``n_a`` (V rms), then 24-bit quantisation over the channel range
   ``+-full_scale`` V (the channel's SI range times ``S``); values beyond it clip and are flagged
   as an overload;
4. scaling back to SI by ``1 / S``, as DAQmx does for accelerometer and force channels.

So a reading equals the physical value within the noise, the quantisation step
``2 full_scale / 2**24 / S`` and the high-pass (which removes DC and slow drift, as on the rig).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import signal


@dataclass(frozen=True)
class SensorModel:
    """One simulated input channel.

    Parameters
    ----------
    volts_per_unit
        Sensitivity in V per SI unit (V/N, V/(m/s^2), V/V).
    full_scale_volts
        ADC input range ``+-full_scale_volts`` in V.
    noise_rms
        Sensor noise, SI units rms over the full band (white).
    adc_noise_rms
        ADC input noise, V rms (white).
    highpass_hz
        IEPE / AC-coupling corner frequency, Hz; 0 for DC coupling.
    bits
        ADC resolution.
    """

    volts_per_unit: float
    full_scale_volts: float
    noise_rms: float = 0.0
    adc_noise_rms: float = 0.0
    highpass_hz: float = 0.5
    bits: int = 24

    def __post_init__(self) -> None:
        if not (self.volts_per_unit > 0 and self.full_scale_volts > 0):
            raise ValueError("volts_per_unit and full_scale_volts must be > 0")
        if self.noise_rms < 0 or self.adc_noise_rms < 0 or self.highpass_hz < 0:
            raise ValueError("noise levels and the high-pass corner must be >= 0")
        if not 2 <= self.bits <= 32:
            raise ValueError(f"bits = {self.bits} outside 2..32")

    @property
    def lsb_volts(self) -> float:
        """Quantisation step, V."""
        return 2.0 * self.full_scale_volts / 2.0**self.bits

    @property
    def lsb_units(self) -> float:
        """Quantisation step in SI units of the channel."""
        return self.lsb_volts / self.volts_per_unit

    @property
    def full_scale_units(self) -> float:
        """Channel range ``+-`` in SI units."""
        return self.full_scale_volts / self.volts_per_unit


def highpass_coefficients(corner_hz: float, sample_rate: float) -> tuple[np.ndarray, np.ndarray]:
    """First-order high-pass ``s / (s + wc)`` by the bilinear transform pre-warped at ``corner_hz``."""
    return signal.butter(1, corner_hz, btype="highpass", fs=sample_rate)


class SensorChain:
    """The measurement chain of several channels with state carried between blocks.

    Parameters
    ----------
    sensors
        One :class:`SensorModel` per channel, in row order.
    sample_rate
        Samples per second.
    seed
        Seed of the noise generator (reproducible runs).
    """

    def __init__(self, sensors: Sequence[SensorModel], sample_rate: float, seed: int | None = None) -> None:
        self.sensors = tuple(sensors)
        self.sample_rate = float(sample_rate)
        self._rng = np.random.default_rng(seed)
        n = len(self.sensors)
        self._gain = np.array([s.volts_per_unit for s in self.sensors])[:, None]
        self._fs_volts = np.array([s.full_scale_volts for s in self.sensors])[:, None]
        self._lsb = np.array([s.lsb_volts for s in self.sensors])[:, None]
        self._code_max = np.array([2.0 ** (s.bits - 1) - 1 for s in self.sensors])[:, None]
        self._noise = np.array([s.noise_rms * s.volts_per_unit for s in self.sensors])[:, None]
        self._adc_noise = np.array([s.adc_noise_rms for s in self.sensors])[:, None]
        self._any_noise = bool(np.any(self._noise > 0) or np.any(self._adc_noise > 0))
        # channels with the same coupling corner are filtered in one call (one lfilter call per
        # block costs as much as thousands of samples: the simulated rig reads 20 ms pieces)
        groups: dict[float, list[int]] = {}
        for i, s in enumerate(self.sensors):
            if s.highpass_hz > 0:
                groups.setdefault(s.highpass_hz, []).append(i)
        self._groups = [
            (np.array(rows), highpass_coefficients(hz, self.sample_rate), np.zeros((len(rows), 1)))
            for hz, rows in groups.items()
        ]
        self.overloaded = np.zeros(n, dtype=bool)
        self.first_overload = -1  # sample index of the first overload in the last block, or -1

    def reset(self) -> None:
        """Coupling filters back to rest, overload flags cleared."""
        for _, _, z in self._groups:
            z[:] = 0.0
        self.overloaded[:] = False
        self.first_overload = -1

    def to_volts(self, physical: np.ndarray) -> np.ndarray:
        """Quantised ADC voltages ``(n_channels, n)`` of physical values ``(n_channels, n)`` (SI).

        Sets :attr:`overloaded` per channel when the block clipped at full scale, and
        :attr:`first_overload` to the first clipped sample (-1 if none).
        """
        x = np.asarray(physical, dtype=float)
        if x.ndim != 2 or x.shape[0] != len(self.sensors):
            raise ValueError(f"expected ({len(self.sensors)}, n) physical values, got {x.shape}")
        v = x * self._gain
        if self._any_noise:
            v = v + self._noise * self._rng.standard_normal(x.shape)
        for rows, (b, a), zi in self._groups:
            v[rows], zi[:] = signal.lfilter(b, a, v[rows], axis=1, zi=zi)
        if self._any_noise:
            v = v + self._adc_noise * self._rng.standard_normal(x.shape)
        # NaN compares False: it passes through as NaN (the device flags it separately)
        over = np.abs(v) > self._fs_volts
        self.overloaded = over.any(axis=1)
        hit = over.any(axis=0)
        self.first_overload = int(np.argmax(hit)) if hit.any() else -1
        codes = np.clip(np.rint(v / self._lsb), -self._code_max - 1, self._code_max)
        return codes * self._lsb

    def to_units(self, volts: np.ndarray) -> np.ndarray:
        """ADC voltages back to SI units (divide by each channel's sensitivity)."""
        return np.asarray(volts, dtype=float) / self._gain

    def measure(self, physical: np.ndarray) -> np.ndarray:
        """Physical values in, readings out (SI), through the whole chain: ``to_units(to_volts(x))``."""
        return self.to_units(self.to_volts(physical))
