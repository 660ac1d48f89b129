"""The real-time PLL run per sample inside the simulated rig (sim/realtime_pll.py) and its
contract (drivers/realtime_pll.py), against independent references: the host's least-squares
fit of the recorded channels on the loop's reported phase (a second method of the same phase),
the sine's own closed form, and the model's linear phase resonance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigtools.branches import simulated_rig_model
from rigtools.config import load_rig
from rigtools.drivers.contracts import ConfigurationError
from rigtools.drivers.realtime_pll import NO_REALTIME_PLL, PllCommand, RealTimePll
from rigtools.procedures.rig import configure, open_device
from rigtools.sim.phase_points import linear_phase_resonance

BLOCK = 1024


def _run(pll: RealTimePll, command: PllCommand, blocks: int):
    """The simulated rig (gap 0.5 mm) with ``pll``, zeros written, ``blocks`` blocks read."""
    cfg = load_rig()
    device = open_device(cfg, "sim", seed=1)
    device.set_gap(0.5e-3)
    configure(device, cfg)
    device.set_realtime_loop(pll)
    device.write(np.zeros(BLOCK))
    device.write(np.zeros(BLOCK))
    device.start()
    device.set_pll_command(command)
    data = []
    for _ in range(blocks):
        data.append(device.read(BLOCK))
        device.write(np.zeros(BLOCK))
    return device, np.hstack(data)


@pytest.fixture(scope="module")
def open_loop():
    """The loop at a fixed frequency (gains 0), 0.05 V at 53 Hz, 3 s: its detector alone."""
    pll = RealTimePll(f_start=53.0, f_min=40.0, f_max=80.0, kp=0.0, ki=0.0)
    return _run(pll, PllCommand(-90.0, 0.05, 0.01), 150)


def test_detector_agrees_with_a_least_squares_fit(open_loop):
    """The loop's phase (demodulation, one-period moving mean, measurements 1.04 ms late) against
    the host's least-squares fit of force and acceleration over the last 20 periods on the loop's
    reported oscillator phase (X1 = -A1 / w^2): within 0.05 deg (the fit's window differs from the
    loop's last period by a settled transient only)."""
    device, data = open_loop
    rate = device.sample_rate
    n = round(rate / 53.0 * 20)
    total = data.shape[1]
    theta = device.pll_oscillator(total - n, n)[0] - math.pi * 53.0 / rate  # mid-sample
    basis = np.column_stack([np.ones(n), np.cos(theta), np.sin(theta)])
    coef = np.linalg.lstsq(basis, data[:2, -n:].T, rcond=None)[0]
    force, accel = coef[1] - 1j * coef[2]
    host = math.degrees(float(np.angle(-accel / force)))
    loop = float(device.pll_oscillator(total - 1, 1)[2, 0])
    assert abs(loop - host) <= 0.05, (loop, host)
    assert -160 < host < -130  # above the linear resonance (52.0 Hz): more lag than -90 deg


def test_output_is_the_phase_continuous_sine(open_loop):
    """With the gains at 0 the output is ``a sin(theta)`` at the ticks (10 kHz) held over the
    samples: its fit on the reported phase (at each step's end) is 0.05 V, lagging by the hold's
    half tick on average, 2 pi 53 Hz x 0.5 / 10 kHz."""
    device, data = open_loop
    n = 51200
    u = device.loop_log[0, -n:]
    theta = device.pll_oscillator(data.shape[1] - n, n)[0]
    coef = np.linalg.lstsq(np.column_stack([np.cos(theta), np.sin(theta)]), u, rcond=None)[0]
    lag = 2 * math.pi * 53.0 * 0.5 / 1e4
    assert abs(coef[1] - 0.05 * math.cos(lag)) < 1e-5  # 0.02 %: the amplitude, the hold's sinc
    # the hold's mean delay to 1.5 %: the 51.2 kHz step ends sample the tick's offset unevenly
    assert abs(coef[0] + 0.05 * math.sin(lag)) < 1.2e-5


def test_locks_to_the_linear_phase_resonance():
    """Closed loop at -90 deg, 0.05 V (linear: 0.1 mm, under the 0.5 mm gap), default gains:
    within 0.01 % of the model's linear phase resonance after 3 s (the model's closed form)."""
    _, system, _ = simulated_rig_model(None)
    f_lin = linear_phase_resonance(system)
    device, _ = _run(RealTimePll(f_start=53.0, f_min=40.0, f_max=80.0), PllCommand(-90.0, 0.05, 0.01), 150)
    f = device.pll_oscillator(device.drive_samples - 1, 1)[1, 0]
    assert abs(f / f_lin - 1) < 1e-4, (f, f_lin)


def test_contract_refuses_bad_values_in_one_line():
    with pytest.raises(ConfigurationError, match="f_min"):
        RealTimePll(f_start=30.0, f_min=40.0, f_max=80.0)
    with pytest.raises(ConfigurationError, match="gains"):
        RealTimePll(f_start=50.0, f_min=40.0, f_max=80.0, kp=-1.0)
    assert RealTimePll(50.0, 40.0, 80.0).delay_s == pytest.approx(0.84e-3 + 2e-4)
    assert "real-time" in NO_REALTIME_PLL and "\n" not in NO_REALTIME_PLL


def test_command_without_a_pll_is_refused():
    cfg = load_rig()
    device = open_device(cfg, "sim", seed=1)
    configure(device, cfg)
    with pytest.raises(ConfigurationError, match="no real-time PLL"):
        device.set_pll_command(PllCommand(-90.0, 0.1))
