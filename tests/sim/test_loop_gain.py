"""The delayed PD loop's gain on a sinusoid (rigtools.sim.delayed_feedback.loop_gain), held against
the loop itself: DelayedFeedback run per sample on a prescribed sinusoidal displacement (a stand-in
for the integration that writes x = X sin(w t), v = X w cos(w t) at each step end), its output's
phasor at w fitted over whole periods. The closed form is what the real-time CBC's gains are chosen
by (the damping the loop adds at fe: rigtools/procedures/cbc_realtime.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rigtools.sim.delayed_feedback import DelayedFeedback, HarmonicTarget, loop_gain
from rigtools.sim.vibro_impact import OUT_COLUMNS

FS = 51_200.0  # the integration's rate (the simulated rig's step)


class _Sinusoid:
    """What DelayedFeedback needs of the physics: ``advance`` writes the prescribed motion."""

    def __init__(self, amplitude: float, frequency: float) -> None:
        self.x, self.w, self.k = amplitude, 2 * math.pi * frequency, 0

    def advance(self, e: np.ndarray, data: np.ndarray, impulses=None) -> None:
        t = (self.k + 1 + np.arange(e.size)) / FS
        data[:] = 0.0
        data[:, OUT_COLUMNS.index("active_tip_displacement")] = self.x * np.sin(self.w * t)
        data[:, OUT_COLUMNS.index("active_tip_velocity")] = self.x * self.w * np.cos(self.w * t)
        self.k += e.size

    def sampled(self, e: np.ndarray, data: np.ndarray, impulses=None) -> np.ndarray:
        return np.zeros((8, e.size))


def _measured_gain(
    kp: float, kd: float, rate: float, delay: float, frequency: float, lowpass: float | None = None
) -> complex:
    """``U / E`` of the loop's output with a zero target (``E = -x``), after the first 0.1 s."""
    loop = DelayedFeedback(rate, delay, kp, kd, 1.0, 1 / FS, lowpass)
    loop.set_target(HarmonicTarget(frequency), 0.0)  # x* = 0: the error is -x
    motion = _Sinusoid(1e-4, frequency)
    periods = 40
    n = round(periods * FS / frequency)
    _, u, _ = loop.step(motion, np.zeros(n + round(0.1 * FS)))  # type: ignore[arg-type]  # a stand-in
    u = u[-n:]
    t = (np.arange(n) + 1 + round(0.1 * FS)) / FS  # each step's end
    phasor = 2 * np.mean(u * np.exp(-1j * 2 * math.pi * frequency * t))
    error = (
        -1e-4 * 2 * np.mean(np.sin(2 * math.pi * frequency * t) * np.exp(-1j * 2 * math.pi * frequency * t))
    )
    return complex(phasor / error)


def test_the_defaults_gain_at_64_hz_matches_the_loop():
    """Kp 2000 V/m, Kd 4 V s/m, 10 kHz, 1.04 ms at 64 Hz: within w / 51.2 kS/s of |U/E| (0.79 %:
    the integration steps at 51.2 kS/s and a tick's output starts at the step end after it, up
    to one step late, a phase error of at most 0.45 deg at 64 Hz)."""
    g = loop_gain(2000.0, 4.0, 1.04e-3, 10_000.0, 64.0)
    m = _measured_gain(2000.0, 4.0, 10_000.0, 1.04e-3, 64.0)
    assert abs(m - g) <= 2 * math.pi * 64.0 / FS * abs(g)
    assert g.imag > 0  # the loop damps at fe


@settings(max_examples=8, deadline=None)
@given(
    kp=st.floats(0.0, 5000.0),
    kd=st.floats(0.0, 10.0),
    frequency=st.sampled_from([32.0, 64.0, 128.0, 200.0]),
)
def test_the_gain_matches_the_loop_over_gains_and_frequencies(kp, kd, frequency):
    """Any gains and frequencies up to 200 Hz: within w / 51.2 kS/s of |U/E| plus 1e-6 V/m (a
    tick's output starts up to one integration step late: at most 1.4 deg at 200 Hz)."""
    if kp == 0.0 and kd == 0.0:
        return
    g = loop_gain(kp, kd, 1.04e-3, 10_000.0, frequency)
    m = _measured_gain(kp, kd, 10_000.0, 1.04e-3, frequency)
    assert abs(m - g) <= 2 * math.pi * frequency / FS * abs(g) + 1e-6


def test_the_delay_turns_proportional_gain_into_negative_damping():
    """Kp alone: the imaginary part is -Kp sin(w (D + half a tick)) times the hold's sinc,
    negative below w (D + 1/(2 rate)) = pi (closed form)."""
    w = 2 * math.pi * 64.0
    lag = w * (1.04e-3 + 0.5e-4)
    sinc = math.sin(w * 0.5e-4) / (w * 0.5e-4)
    assert loop_gain(1000.0, 0.0, 1.04e-3, 10_000.0, 64.0) == pytest.approx(
        1000.0 * sinc * complex(math.cos(lag), -math.sin(lag)), rel=1e-12
    )


@pytest.mark.parametrize("frequency", [56.0, 64.0, 72.0, 200.0])
def test_the_gain_with_the_output_lowpass_matches_the_loop(frequency):
    """The real-time CBC's law high on the sheet (Kp 2000 V/m, Kd 4 V s/m, the 350 Hz output
    low-pass) at fe, its sidebands (56, 72 Hz) and 200 Hz: the loop run tick by tick through its
    biquad within w / 51.2 kS/s of |U/E| (the one-step lateness, as above) of loop_gain's closed
    form. (At 64 Hz the low-pass costs 15 deg of phase: the damping part -55 V/m against +608
    without it; what the low-pass buys is less gain far above fe, where the impacts put their
    content: |U/E| 5540 V/m at 500 Hz and 2840 at 1 kHz, against 12700 and 24800.)"""
    g = loop_gain(2000.0, 4.0, 1.04e-3, 10_000.0, frequency, 350.0)
    m = _measured_gain(2000.0, 4.0, 10_000.0, 1.04e-3, frequency, 350.0)
    assert abs(m - g) <= 2 * math.pi * frequency / FS * abs(g)
