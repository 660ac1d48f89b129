"""The simulated measurement chain against closed forms: quantisation bound, noise level, the
first-order IEPE high-pass (gain, phase, step response) and overload flags."""

import numpy as np
import pytest

from rigtools.drivers.sensor_chain import SensorChain, SensorModel

FS = 2000.0
FORCE = SensorModel(volts_per_unit=11.24e-3, full_scale_volts=2.248, highpass_hz=0.0)  # 200 N range


def test_round_trip_within_half_lsb_without_noise_or_coupling():
    """No noise, DC coupled: reading - physical is the quantisation error, |e| <= LSB/2 (exactly)."""
    x = np.random.default_rng(0).uniform(-199.0, 199.0, (1, 10_000))
    chain = SensorChain([FORCE], FS)
    y = chain.measure(x)
    assert FORCE.lsb_units == pytest.approx(400.0 / 2**24, rel=1e-12)
    assert np.max(np.abs(y - x)) <= 0.5 * FORCE.lsb_units * (1 + 1e-9)
    assert not chain.overloaded.any()


def test_noise_levels_add_in_quadrature():
    """Sensor noise 0.01 N rms and ADC noise 50 uV rms (= 4.45 mN): the reading error is white with
    rms sqrt(0.01^2 + 0.00445^2) = 10.9 mN; 100 000 samples put its estimate within 1 %."""
    model = SensorModel(11.24e-3, 2.248, noise_rms=0.01, adc_noise_rms=50e-6, highpass_hz=0.0)
    x = 50.0 * np.sin(2 * np.pi * 13.0 * np.arange(100_000) / FS)[None, :]
    err = SensorChain([model], FS, seed=1).measure(x) - x
    assert np.std(err) == pytest.approx(np.hypot(0.01, 50e-6 / 11.24e-3), rel=0.01)
    assert abs(np.mean(err)) < 1e-3


@pytest.mark.parametrize("f", [0.25, 0.5, 1.0, 5.0])
def test_iepe_highpass_matches_first_order_response(f):
    """Steady sine through the 0.5 Hz coupling: gain f / sqrt(f^2 + fc^2), phase lead atan(fc/f).
    Fed block by block (state carried). Tolerance 2e-3 (bilinear warping ~(fc/fs)^2 plus the
    least-squares fit after 12 time constants of settling)."""
    fc = 0.5
    model = SensorModel(1.0, 10.0, highpass_hz=fc)
    chain = SensorChain([model], FS)
    t = np.arange(int(40 * FS)) / FS
    x = np.sin(2 * np.pi * f * t)[None, :]
    y = np.concatenate([chain.measure(b) for b in np.array_split(x, 37, axis=1)], axis=1)[0]
    keep = t > 4.0
    basis = np.column_stack([np.sin(2 * np.pi * f * t[keep]), np.cos(2 * np.pi * f * t[keep])])
    (a, b), *_ = np.linalg.lstsq(basis, y[keep], rcond=None)
    assert np.hypot(a, b) == pytest.approx(f / np.hypot(f, fc), abs=2e-3)
    assert np.arctan2(b, a) == pytest.approx(np.arctan2(fc, f), abs=2e-3)


def test_iepe_step_response_decays_with_the_corner_time_constant():
    """A 1 V step through s/(s + wc): exp(-wc t). Within 1e-3 (bilinear, fc/fs = 2.5e-4)."""
    model = SensorModel(1.0, 10.0, highpass_hz=0.5)
    t = np.arange(int(3 * FS)) / FS
    y = SensorChain([model], FS).measure(np.ones((1, t.size)))[0]
    np.testing.assert_allclose(y, np.exp(-2 * np.pi * 0.5 * t), atol=1e-3)


def test_overload_clips_and_flags_the_channel():
    chain = SensorChain([FORCE, SensorModel(1e-3, 5.0, highpass_hz=0.0)], FS)
    x = np.vstack([np.linspace(0.0, 300.0, 100), np.zeros(100)])
    y = chain.measure(x)
    assert chain.overloaded.tolist() == [True, False]
    assert y[0].max() == pytest.approx(200.0, rel=1e-6)
