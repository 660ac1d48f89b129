"""Harmonic fit against exactly known synthetic signals (tolerances: round-off, 1e-9 relative)."""

import numpy as np
import pytest

from rigtools.analysis.harmonics import harmonic_amplitudes


def _signal(t, fe, amps, phases, offset=0.0):
    x = np.full_like(t, offset)
    for k, (a, p) in enumerate(zip(amps, phases, strict=True), start=1):
        x += a * np.cos(2 * np.pi * k * fe * t + p)
    return x


@pytest.mark.parametrize("n, whole", [(5000, True), (4321, False)])
def test_exact_amplitudes_and_phases(n, whole):
    """Whole periods (DFT path) and a record ending mid-period (least squares): both exact."""
    rng = np.random.default_rng(1)
    fs, fe, kmax = 10000.0, 50.0, 30
    amps = rng.uniform(0.1, 2.0, kmax)
    phases = rng.uniform(-np.pi, np.pi, kmax)
    t = np.arange(n) / fs
    fit = harmonic_amplitudes(_signal(t, fe, amps, phases, offset=0.7), fs, fe, kmax)
    np.testing.assert_allclose(fit.amplitude, amps, rtol=1e-9)
    np.testing.assert_allclose(np.angle(np.exp(1j * (fit.phase - phases))), 0, atol=1e-9)
    np.testing.assert_array_equal(fit.k, np.arange(1, kmax + 1))
    np.testing.assert_allclose(fit.frequency_hz, fe * fit.k)
    assert fit.offset == pytest.approx(0.7, rel=1e-9)
    assert fit.residual_rms < 1e-8


def test_sine_convention_and_residual():
    """sin(wt) = cos(wt - pi/2); an off-harmonic tone shows up in the residual, not the fit."""
    fs, fe = 2000.0, 20.0
    t = np.arange(2000) / fs
    fit = harmonic_amplitudes(3 * np.sin(2 * np.pi * fe * t), fs, fe, 5)
    assert fit.at(1) == pytest.approx(3.0, rel=1e-12)
    assert fit.phase[0] == pytest.approx(-np.pi / 2, abs=1e-12)
    tone = 0.5 * np.sin(2 * np.pi * 30.0 * t)  # 1.5 fe, orthogonal over whole periods
    fit2 = harmonic_amplitudes(3 * np.sin(2 * np.pi * fe * t) + tone, fs, fe, 5)
    assert fit2.at(1) == pytest.approx(3.0, rel=1e-12)
    assert fit2.residual_rms == pytest.approx(0.5 / np.sqrt(2), rel=1e-9)


def test_records_are_plain_numbers():
    fs, fe = 1000.0, 10.0
    t = np.arange(1000) / fs
    rec = harmonic_amplitudes(np.cos(2 * np.pi * fe * t), fs, fe, 3).to_records()
    assert rec[0] == {
        "k": 1,
        "frequency_hz": 10.0,
        "amplitude": pytest.approx(1.0),
        "phase": pytest.approx(0.0, abs=1e-12),
    }
    assert all(type(r["k"]) is int and type(r["amplitude"]) is float for r in rec)


def test_refuses_harmonics_above_nyquist():
    with pytest.raises(ValueError, match="Nyquist"):
        harmonic_amplitudes(np.zeros(1000), 1000.0, 20.0, 30)


def test_derivative_harmonics_match_the_differentiated_signal():
    """Harmonics of d/dt and d2/dt2 of a known multi-harmonic signal (exact, 1e-9)."""
    rng = np.random.default_rng(5)
    fs, fe, kmax = 8000.0, 40.0, 10
    amps, phases = rng.uniform(0.1, 1, kmax), rng.uniform(-np.pi, np.pi, kmax)
    t = np.arange(8000) / fs
    x = _signal(t, fe, amps, phases)
    k = np.arange(1, kmax + 1)
    w = 2 * np.pi * fe * k
    acc = np.zeros_like(t)
    for kk, a, p in zip(k, amps, phases, strict=True):
        acc -= a * (2 * np.pi * fe * kk) ** 2 * np.cos(2 * np.pi * kk * fe * t + p)
    from rigtools.analysis.harmonics import derivative_harmonics

    d2 = derivative_harmonics(harmonic_amplitudes(x, fs, fe, kmax), order=2)
    ref = harmonic_amplitudes(acc, fs, fe, kmax)
    np.testing.assert_allclose(d2.amplitude, ref.amplitude, rtol=1e-9)
    np.testing.assert_allclose(np.angle(np.exp(1j * (d2.phase - ref.phase))), 0, atol=1e-9)
    np.testing.assert_allclose(
        derivative_harmonics(harmonic_amplitudes(x, fs, fe, kmax)).amplitude, amps * w, rtol=1e-9
    )


def test_multitone_with_noise_non_integer_records_within_0p1_percent():
    """Harmonics k = 1..30 of 47.3 Hz (amplitudes 0.5..2, random phases) with white noise of
    0.5 % of the signal RMS (sigma ~ 0.0202), over records of 600.37 and 1001.7 periods at a rate
    (5120 S/s) that is not a multiple of fe: every amplitude within 0.1 %, phases within 2e-3 rad.
    Noise on each fitted coefficient is sigma sqrt(2 / n) = 1.1e-4 at n = 65 000, i.e. 0.022 % of
    the smallest amplitude, so 0.1 % is 4.5 standard deviations."""
    rng = np.random.default_rng(8)
    fs, fe, kmax = 5120.0, 47.3, 30
    amps = rng.uniform(0.5, 2.0, kmax)
    phases = rng.uniform(-np.pi, np.pi, kmax)
    for periods in (600.37, 1001.7):
        n = int(periods * fs / fe)
        t = np.arange(n) / fs
        clean = _signal(t, fe, amps, phases)
        x = clean + 0.005 * np.std(clean) * rng.standard_normal(n)
        fit = harmonic_amplitudes(x, fs, fe, kmax)
        np.testing.assert_allclose(fit.amplitude, amps, rtol=1e-3)
        np.testing.assert_allclose(np.angle(np.exp(1j * (fit.phase - phases))), 0, atol=2e-3)
        assert fit.residual_rms == pytest.approx(0.005 * np.std(clean), rel=0.02)


def test_phases_relative_to_the_force_fundamental_do_not_depend_on_the_start():
    """The same periodic response and force sampled from two different start times: absolute
    phases differ, phases relative to the force fundamental agree (1e-9)."""
    from rigtools.analysis.harmonics import relative_phases

    fs, fe = 4000.0, 50.0
    amps, phases = [1.0, 0.3, 0.1], [0.2, -1.0, 2.5]
    fits = []
    for t0 in (0.0, 0.0123):
        t = t0 + np.arange(1000) / fs
        resp = harmonic_amplitudes(_signal(t, fe, amps, phases), fs, fe, 3)
        force = harmonic_amplitudes(_signal(t, fe, [5.0], [0.7]), fs, fe, 3)
        fits.append(relative_phases(resp, force))
    np.testing.assert_allclose(np.angle(np.exp(1j * (fits[0] - fits[1]))), 0, atol=1e-9)
    np.testing.assert_allclose(
        fits[0], np.angle(np.exp(1j * (np.array(phases) - np.arange(1, 4) * 0.7))), atol=1e-9
    )


def test_blocks_give_the_whole_record_fit():
    """Two channels of a 30-harmonic signal with noise, 7.3 s at 5120 S/s of a 47.3 Hz
    fundamental (not whole periods), fed in blocks of 9999: amplitudes, phases, offsets and
    residuals equal the one-shot least squares (1e-9 relative / 1e-9 rad)."""
    from rigtools.analysis.harmonics import harmonics_from_blocks

    rng = np.random.default_rng(12)
    fs, fe, kmax = 5120.0, 47.3, 30
    t = np.arange(int(7.3 * fs)) / fs
    x = np.vstack(
        [
            _signal(t, fe, rng.uniform(0.5, 2, kmax), rng.uniform(-3, 3, kmax), 0.3),
            _signal(t, fe, rng.uniform(0.5, 2, kmax), rng.uniform(-3, 3, kmax), -1.0),
        ]
    )
    x += 0.01 * rng.standard_normal(x.shape)
    fits = harmonics_from_blocks((x[:, i : i + 9999] for i in range(0, x.shape[1], 9999)), fs, fe, kmax)
    for c in range(2):
        ref = harmonic_amplitudes(x[c], fs, fe, kmax)
        np.testing.assert_allclose(fits[c].amplitude, ref.amplitude, rtol=1e-9)
        np.testing.assert_allclose(np.angle(np.exp(1j * (fits[c].phase - ref.phase))), 0, atol=1e-9)
        assert fits[c].offset == pytest.approx(ref.offset, rel=1e-9)
        assert fits[c].residual_rms == pytest.approx(ref.residual_rms, rel=1e-6)
