"""FRF estimation against exact references: closed-form SDOF conversions, H1/H2 of a known digital
filter driven by white noise (exact FRF from ``scipy.signal.freqz``), the closed-form noise biases,
and an exact stepped-sine point."""

import numpy as np
import pytest
from _reference import one_frf
from scipy import signal

from rigtools.analysis.frf import FRFMethod, convert_frf, sdof_frf, sine_frf

FS = 1000.0


def _resonator(fn: float, zeta: float, fs: float = FS):
    """Digital SDOF (receptance-like) by the bilinear transform of 1 / (s^2 + 2 zeta wn s + wn^2)."""
    wn = 2 * np.pi * fn
    return signal.bilinear([wn**2], [1.0, 2 * zeta * wn, wn**2], fs=fs)


def _exact(b, a, f):
    return signal.freqz(b, a, worN=f, fs=FS)[1]


def test_kind_conversions_match_closed_form():
    f = np.linspace(1.0, 500.0, 200)
    w = 2 * np.pi * f
    rec = sdof_frf(f, 80.0, 0.02, 0.3, "receptance")
    # closed forms, exp(+iwt): mobility = iw X/F, accelerance = -w^2 X/F (rel. 1e-12: arithmetic only)
    np.testing.assert_allclose(sdof_frf(f, 80.0, 0.02, 0.3, "mobility"), 1j * w * rec, rtol=1e-12)
    np.testing.assert_allclose(sdof_frf(f, 80.0, 0.02, 0.3, "accelerance"), -(w**2) * rec, rtol=1e-12)
    back = convert_frf(convert_frf(rec, f, "receptance", "accelerance"), f, "accelerance", "receptance")
    np.testing.assert_allclose(back, rec, rtol=1e-12)
    # static limit of receptance is 1/k = 1/(m wn^2)
    assert sdof_frf(np.array([1e-6]), 80.0, 0.02, 0.3)[0].real == pytest.approx(
        1 / (0.3 * (2 * np.pi * 80) ** 2), rel=1e-6
    )


def test_h1_of_known_filter_with_output_noise():
    """White force through a known resonator, noise on the response only: H1 is unbiased.

    Tolerance: 4096-sample Hann segments give df = 0.24 Hz against a 4 Hz half-power band (leakage
    bias < 0.5 %, allowed 1 %); the random error of |H1| per bin is
    sigma = sqrt(1 - g^2) / (|g| sqrt(2 n_avg)) (Bendat & Piersol), allowed 4.5 sigma over ~700 bins;
    the band median within 1 %.
    """
    rng = np.random.default_rng(1)
    b, a = _resonator(100.0, 0.02)
    x = rng.standard_normal(2**17)
    y_true = signal.lfilter(b, a, x)
    y = y_true + 0.05 * np.std(y_true) * rng.standard_normal(x.size)
    est = one_frf(x, y, FS, "random", 4096)
    assert est.n_averages == 63
    band = (est.frequency_hz > 5) & (est.frequency_hz < 300) & (est.coherence > 0.9)
    assert band.sum() > 600
    exact = _exact(b, a, est.frequency_hz[band])
    ratio = est.h1[band] / exact
    g = np.sqrt(est.coherence[band])
    sigma = np.sqrt(1 - g**2) / (g * np.sqrt(2 * est.n_averages))
    assert np.all(np.abs(np.abs(ratio) - 1) < 0.01 + 4.5 * sigma)
    assert np.all(np.abs(np.angle(ratio)) < 0.01 + 4.5 * sigma)  # phase error (rad) has the same sigma
    assert abs(np.median(np.abs(ratio)) - 1) < 0.01
    # coherence = H1/H2 by definition
    np.testing.assert_allclose(est.coherence[band], (est.h1 / est.h2).real[band], rtol=1e-9)


def test_input_noise_biases_h1_low_by_closed_form_and_leaves_h2():
    """Input noise of variance s_n^2 on a white input of variance s_x^2:
    H1 -> H * s_x^2 / (s_x^2 + s_n^2) (here 0.8), H2 stays H. Tolerance 2 % on the band median."""
    rng = np.random.default_rng(2)
    b, a = _resonator(100.0, 0.02)
    x = rng.standard_normal(2**17)
    y = signal.lfilter(b, a, x)
    x_meas = x + 0.5 * rng.standard_normal(x.size)
    est = one_frf(x_meas, y, FS, "random", 4096)
    band = (est.frequency_hz > 5) & (est.frequency_hz < 300)
    exact = _exact(b, a, est.frequency_hz[band])
    assert np.median(np.abs(est.h1[band] / exact)) == pytest.approx(1 / 1.25, rel=0.02)
    assert np.median(np.abs(est.h2[band] / exact)) == pytest.approx(1.0, rel=0.02)
    assert np.median(est.coherence[band]) == pytest.approx(0.8, abs=0.02)


def test_single_average_is_refused():
    x = np.zeros(1000)
    with pytest.raises(ValueError, match="at least 2 averages"):
        FRFMethod("random", 1000).estimate([np.vstack([x, x])], FS)


def test_sine_frf_is_exact_for_non_integer_periods():
    t = np.arange(777) / FS
    f0, h = 37.3, 2.5 * np.exp(-1j * 1.1)
    x = 3.0 * np.cos(2 * np.pi * f0 * t + 0.4) + 0.2
    y = np.abs(h) * 3.0 * np.cos(2 * np.pi * f0 * t + 0.4 + np.angle(h)) - 1.0
    assert sine_frf(x, y, FS, f0) == pytest.approx(h, rel=1e-9)
