"""The phase-locked loop's parts that need no rig: the drive's phase history, the phase detector
and the PI controller on the drive frequency.

Phase detector (:func:`detect`): over the last whole periods, the fundamentals of the force and of
the active shroud's acceleration are fitted by least squares together with harmonics 2..K (so the
impacts' harmonics do not leak into the fundamental) on the drive's own instantaneous phase
(:class:`PhaseLog`): the drive's frequency changes between blocks, and a fit at one frequency over
a window that holds two would bias the phase. The phase each input sample was driven at is the
drive's phase ``delay`` earlier (the device's input-to-output delay: the converter's queue and its
filters), so the fit holds through a frequency change. The displacement fundamental is
``X1 = -A1 / w^2``; the phase is ``angle(X1 / F1)``, -90 deg at phase resonance.

Controller (:class:`PhaseController`): a PI on the drive frequency in velocity form,
``fe += kp (e_k - e_{k-1}) + ki e_k dt`` with ``e = phase - target`` (deg): more lag than the
target lowers the frequency. Each step is limited (``max_step`` Hz), the frequency kept in
``[f_min, f_max]``; the drive's phase stays continuous (:class:`rigtools.drivers.drive_signals.SineDrive`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


class PhaseLog:
    """The drive's phase (rad) as a function of the drive sample index, from its frequency changes.

    Parameters
    ----------
    rate
        Sample rate, S/s.
    fe
        Frequency from sample 0, Hz.
    """

    def __init__(self, rate: float, fe: float) -> None:
        self.rate = float(rate)
        self._starts = [0.0]  # drive sample where each frequency begins
        self._phases = [0.0]  # phase at that sample, rad
        self._freqs = [float(fe)]

    def change(self, sample: float, fe: float) -> None:
        """From drive sample ``sample`` on, the frequency is ``fe`` (phase continuous)."""
        s0, p0, f0 = self._starts[-1], self._phases[-1], self._freqs[-1]
        sample = max(float(sample), s0)
        self._starts.append(sample)
        self._phases.append(p0 + 2 * math.pi * f0 * (sample - s0) / self.rate)
        self._freqs.append(float(fe))
        if len(self._starts) > 4096:  # keep the recent history only
            del self._starts[:2048], self._phases[:2048], self._freqs[:2048]

    def phase(self, samples: np.ndarray) -> np.ndarray:
        """The drive's phase at (fractional) drive sample indices ``samples``."""
        starts = np.asarray(self._starts)
        i = np.clip(np.searchsorted(starts, samples, side="right") - 1, 0, None)
        return (
            np.asarray(self._phases)[i]
            + 2 * math.pi * np.asarray(self._freqs)[i] * (samples - starts[i]) / self.rate
        )

    def mean_frequency(self, first: float, last: float) -> float:
        """The mean frequency over drive samples ``[first, last]``, Hz."""
        if last <= first:
            return self._freqs[-1]
        p = self.phase(np.array([first, last]))
        return float((p[1] - p[0]) * self.rate / (2 * math.pi * (last - first)))


@dataclass(frozen=True)
class Detection:
    """What the phase detector found over one window."""

    fe: float  # mean drive frequency over the window, Hz
    force: complex  # force fundamental, N (phase on the drive's)
    displacement: complex  # active shroud displacement fundamental, m
    drive: complex  # drive fundamental, V
    drive_harmonics_ratio: float  # rms of drive harmonics 2..K over its fundamental
    harmonics: np.ndarray  # (rows, K) complex harmonics of every row

    @property
    def phase_deg(self) -> float:
        """Phase of the displacement fundamental relative to the force's, deg in (-360, 0]."""
        if self.force == 0:
            return math.nan
        p = math.degrees(float(np.angle(self.displacement / self.force)))
        return p - 360.0 if p > 0 else p


def detect(
    rows: np.ndarray,
    first_sample: int,
    log: PhaseLog,
    delay: float,
    *,
    force_row: int,
    accel_row: int,
    drive_row: int,
    k_max: int,
) -> Detection:
    """Fundamentals of ``rows`` (inputs and the drive as written; stream samples ``first_sample``
    on), fitted with harmonics 1..``k_max`` on the drive's phase ``delay`` samples earlier (the
    drive row itself on the phase it was written at).

    Returns
    -------
    Detection
    """
    n = rows.shape[1]
    s = first_sample + np.arange(n, dtype=float)
    fe = log.mean_frequency(s[0] - delay, s[-1] - delay)
    k = np.arange(1, k_max + 1)

    def fit(theta: np.ndarray, data: np.ndarray) -> np.ndarray:
        arg = np.outer(k, theta)
        basis = np.vstack([np.ones(n), np.cos(arg), np.sin(arg)])
        coef = np.linalg.solve(basis @ basis.T, basis @ data.T)
        return (coef[1 : k_max + 1] - 1j * coef[k_max + 1 :]).T  # (rows, K)

    h = fit(log.phase(s - delay), rows)
    h[drive_row] = fit(log.phase(s), rows[drive_row : drive_row + 1])[0]
    w = 2 * math.pi * fe
    d1 = abs(h[drive_row, 0])
    ratio = float(np.sqrt(np.sum(np.abs(h[drive_row, 1:]) ** 2)) / d1) if d1 > 0 else 0.0
    return Detection(
        fe=fe,
        force=complex(h[force_row, 0]),
        displacement=complex(-h[accel_row, 0] / w**2),
        drive=complex(h[drive_row, 0]),
        drive_harmonics_ratio=ratio,
        harmonics=h,
    )


def wrap_deg(x: float) -> float:
    """``x`` wrapped to (-180, 180] deg."""
    return -((-x + 180.0) % 360.0 - 180.0)


@dataclass
class PhaseController:
    """PI on the drive frequency (see the module docstring); gains in Hz/deg and Hz/(deg s)."""

    kp: float
    ki: float
    f_min: float
    f_max: float
    max_step: float
    _last_error: float | None = field(default=None, repr=False)

    def reset(self) -> None:
        """Forget the last error (a new target: no proportional kick)."""
        self._last_error = None

    def update(self, fe: float, error_deg: float, dt: float) -> float:
        """The next frequency from the present one and the phase error (deg) over ``dt`` s."""
        last = error_deg if self._last_error is None else self._last_error
        self._last_error = error_deg
        step = self.kp * (error_deg - last) + self.ki * error_deg * dt
        step = max(-self.max_step, min(self.max_step, step))
        return max(self.f_min, min(self.f_max, fe + step))
