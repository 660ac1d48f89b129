"""The arithmetic of control-based continuation (rigtools.procedures.cbc_iteration) and its drive,
held against time-domain signals built independently (closed forms, a sampled waveform, the
toolkit's least-squares harmonic fit)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from rigtools.analysis.harmonics import harmonic_amplitudes
from rigtools.procedures.cbc_iteration import (
    FeedforwardSecant,
    Gains,
    control_drive,
    displacement_from_acceleration,
    drive_harmonics_ratio,
    growth_rate,
    half_peak_to_peak,
    picard_update,
    secant_predict,
)
from rigtools.procedures.cbc_loop import HarmonicDrive

RATE, FE = 51200.0, 64.0  # 800 samples per period: whole periods fit exactly


def signal(z: np.ndarray, t: np.ndarray) -> np.ndarray:
    k = np.arange(1, z.size + 1)
    return np.real(np.exp(1j * 2 * math.pi * FE * np.outer(t, k)) @ z)


def fitted(x: np.ndarray, k_max: int) -> np.ndarray:
    fit = harmonic_amplitudes(x, RATE, FE, k_max)
    return fit.amplitude * np.exp(1j * fit.phase)


def test_control_drive_is_the_time_domain_pd_law():
    """U_k = Uff_k + (Kp + i k w Kd)(X*_k - X_k) is the PD law u = u_ff + Kp e + Kd e' on the
    waveforms: the law evaluated sample by sample (e' in closed form) and fitted gives the same
    harmonics to 1e-9 (the fit is exact for a sum of these harmonics)."""
    rng = np.random.default_rng(3)
    h = 5
    ff, tgt, x = (rng.normal(size=h) + 1j * rng.normal(size=h) for _ in range(3))
    gains = Gains(kp=-600.0, kd=2.5, harmonics=h)
    t = np.arange(800 * 4) / RATE
    k = np.arange(1, h + 1)
    e = signal(tgt - x, t)
    de = signal(1j * k * 2 * math.pi * FE * (tgt - x), t)  # d/dt of Re(E e^{ikwt})
    u = signal(ff, t) + gains.kp * e + gains.kd * de
    np.testing.assert_allclose(control_drive(ff, tgt, x, gains, FE), fitted(u, h), rtol=1e-9, atol=1e-9)


def test_feedback_leaves_out_the_harmonics_above_its_own():
    gains = Gains(kp=100.0, kd=0.0, harmonics=1)
    u = control_drive(np.zeros(3), np.ones(3), np.zeros(3), gains, FE)
    assert u.tolist() == [100.0, 0.0, 0.0]


def test_drive_harmonics_ratio_is_the_rms_ratio_of_the_waveform():
    """The ratio of the RMS of the waveform without its fundamental to that of the fundamental,
    computed on samples of one period (exact for whole periods)."""
    z = np.zeros(10, complex)
    z[0], z[1], z[4], z[9] = 0.4, 0.004j, -0.002, 0.001 + 0.001j
    t = np.arange(800) / RATE
    rest = signal(np.concatenate([[0], z[1:]]), t)
    fundamental = signal(np.concatenate([z[:1], np.zeros(9)]), t)
    expected = math.sqrt(np.mean(rest**2)) / math.sqrt(np.mean(fundamental**2))
    assert math.isclose(drive_harmonics_ratio(z), expected, rel_tol=1e-9)
    assert drive_harmonics_ratio(np.array([0.3, 0, 0])) == 0.0
    assert drive_harmonics_ratio(np.array([0.0, 0.1])) == math.inf


def test_displacement_from_acceleration_closed_form():
    """x = X cos(k w t + phi) has acceleration -(k w)^2 x."""
    x = np.array([1e-4 * np.exp(0.3j), 2e-6 * np.exp(-1j)])
    k = np.arange(1, 3)
    accel = -((k * 2 * math.pi * FE) ** 2) * x
    np.testing.assert_allclose(displacement_from_acceleration(accel, FE), x, rtol=1e-12)


@settings(max_examples=30, deadline=None)
@given(
    st.lists(
        st.complex_numbers(max_magnitude=1.0, allow_nan=False, allow_infinity=False), min_size=1, max_size=6
    )
)
def test_half_peak_to_peak_matches_a_dense_waveform(values):
    """Half the peak-to-peak of the harmonics' waveform, against 40 000 samples of one period
    (the 2048-sample grid of the function misses a peak by at most (pi k / 2048)^2 / 2 of the
    k-th harmonic's amplitude: tolerance 2e-4 of the sum of amplitudes)."""
    z = np.array(values, complex)
    t = np.arange(40000) / 40000 / FE
    x = signal(z, t)
    bound = 2e-4 * float(np.sum(np.abs(z))) + 1e-12
    assert abs(half_peak_to_peak(z) - (x.max() - x.min()) / 2) <= bound


def test_picard_update_keeps_the_parameter_and_a_fixed_point():
    tgt = np.array([3e-4 + 0j, 1e-6, 2e-6j])
    response = np.array([2.9e-4 + 1e-6j, 5e-6, 1e-6])
    drive = np.array([0.4 + 0.1j, 0.01, 0.0])
    new_t, new_ff = picard_update(tgt, np.zeros(3), response, drive)
    assert new_t[0] == tgt[0] and np.array_equal(new_t[1:], response[1:])
    assert new_ff.tolist() == [0.4 + 0.1j, 0, 0]
    # at a fixed point the control term is zero in every harmonic: the drive is the feedforward
    again_t, again_ff = picard_update(new_t, new_ff, new_t, new_ff)
    np.testing.assert_array_equal(again_t, new_t)
    np.testing.assert_array_equal(again_ff, new_ff)


def test_secant_predictor_is_exact_on_a_line():
    states = [np.array([1.0 + 1j, 2.0]), np.array([1.5 + 0.5j, 3.0])]
    np.testing.assert_allclose(secant_predict([0.30, 0.31], states, 0.33), [2.5 - 0.5j, 5.0])
    np.testing.assert_allclose(secant_predict([0.30], states[:1], 0.33), states[0])


def test_feedforward_secant_solves_a_real_linear_map_that_is_not_complex_linear():
    """X1 = M u + c with M a general 2x2 real matrix (amplitude and phase respond differently, as
    on a nonlinear orbit): from finite-difference probes the first step is exact; from a wrong
    start (the Picard guess 1/K) Broyden still meets the target to 1e-6 within 8 steps."""
    m = np.array([[2e-4, -5e-4], [3e-4, 1e-4]])
    c = np.array([1e-5, -2e-5])

    def response(u: complex) -> complex:
        x = m @ np.array([u.real, u.imag]) + c
        return complex(x[0], x[1])

    target = 3e-4 * np.exp(0.7j)
    u0, delta = 0.4 + 0.0j, 0.004
    probes = FeedforwardSecant.from_probes(
        response(u0), response(u0 + delta), response(u0 + 1j * delta), delta
    )
    probes.max_step = 10.0
    assert abs(response(probes.step(u0, response(u0), target)) - target) < 1e-12
    picard = FeedforwardSecant.from_gain(-600.0)
    picard.max_step = 10.0
    u = u0
    for _ in range(8):
        u = picard.step(u, response(u), target)
    assert abs(response(u) - target) < 1e-6 * abs(target)


def test_feedforward_secant_limits_its_step():
    s = FeedforwardSecant(np.eye(2) * 1e-6, max_step=0.02)
    u = s.step(0.5 + 0j, 0j, 1e-3 + 0j)
    assert math.isclose(abs(u - 0.5), 0.01, rel_tol=1e-12)


def test_growth_rate_of_an_exponential_departure():
    """The slope of log(deviation) between the noise and the nonlinear range: an exponential at
    8 1/s with 1e-4 noise is recovered within 2 % (the noise floor biases the lowest samples)."""
    t = np.arange(0, 0.6, 1 / FE)
    rng = np.random.default_rng(0)
    deviation = 1e-3 * np.exp(8.0 * t) + 1e-4 * np.abs(rng.normal(size=t.size))
    rate, used = growth_rate(t, deviation, 0.005, 0.1)
    assert used >= 10
    assert abs(rate / 8.0 - 1) < 0.02


def test_harmonic_drive_plays_its_harmonics_and_ends_at_zero():
    """After the cross-fade block the drive is exactly Re(sum U_k e^{ik theta}); a sweep ends
    phase-continuous (no step larger than the sine's own slope allows); the stop ramp ends at 0."""
    drive = HarmonicDrive(RATE, FE, 3, max_drive=5.0, ramp_time=0.05)
    u = np.array([0.4 + 0.1j, 0.01j, 0.0])
    drive.set_harmonics(u)
    drive.next_block(1024)  # the fade
    start = drive.samples_written
    block = drive.next_block(1024)
    k = np.arange(1, 4)
    theta = drive.phase_at(start + np.arange(1024))
    np.testing.assert_allclose(block, np.real(np.exp(1j * np.outer(theta, k)) @ u), atol=1e-12)
    drive.sweep_from(56.0, 0.1)
    played = np.concatenate([drive.next_block(1024) for _ in range(8)])
    slope = 2 * math.pi * FE * float(np.sum(np.abs(u) * k)) / RATE
    assert np.max(np.abs(np.diff(played))) <= 1.01 * slope
    tail = drive.stop_block()
    assert tail[-1] == 0.0 and drive.next_block(16).tolist() == [0.0] * 16


def test_harmonic_drive_refuses_more_than_max_drive():
    from rigtools.drivers.contracts import LimitExceeded

    drive = HarmonicDrive(RATE, FE, 2, max_drive=1.0, ramp_time=0.05)
    try:
        drive.set_harmonics(np.array([0.8, 0.3]))
    except LimitExceeded as exc:
        assert "above max_drive" in str(exc)
    else:
        raise AssertionError("a drive above max_drive was accepted")
