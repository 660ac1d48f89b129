"""Answers that must not change when something that should not matter changes (issue 29, item 7):
the sample rate a known signal is recorded at, and the half of a steady record it is read from.

Property-based (hypothesis): each test draws the signal (amplitudes, phases, fe, rate, noise
seed) and compares the answer with the signal's known value, or with the other half's answer;
each tolerance is stated with its reason. Small ``max_examples``: the whole file runs in seconds.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from rigtools.analysis.harmonics import harmonic_amplitudes
from rigtools.analysis.point import analyze_dwell
from rigtools.analysis.spectra import amplitude_spectrum

FAST = settings(max_examples=25, deadline=None)

rates = st.floats(min_value=2000.0, max_value=60000.0, allow_nan=False)
fundamentals = st.floats(min_value=20.0, max_value=120.0, allow_nan=False)
amplitudes = st.floats(min_value=0.01, max_value=100.0, allow_nan=False)
phases = st.floats(min_value=-np.pi, max_value=np.pi, allow_nan=False)
seeds = st.integers(min_value=0, max_value=2**32 - 1)


def _periodic(t: np.ndarray, fe: float, amps, phis, offset: float = 0.0) -> np.ndarray:
    x = np.full_like(t, offset)
    for k, (a, p) in enumerate(zip(amps, phis, strict=True), start=1):
        x += a * np.cos(2 * np.pi * k * fe * t + p)
    return x


@FAST
@given(
    rate=rates,
    fe=fundamentals,
    periods=st.floats(min_value=5.0, max_value=40.0),
    amps=st.lists(amplitudes, min_size=5, max_size=5),
    phis=st.lists(phases, min_size=5, max_size=5),
)
def test_harmonic_amplitudes_do_not_depend_on_the_sample_rate(rate, fe, periods, amps, phis):
    """Five harmonics of fe, sampled at any rate from 2 to 60 kS/s (not a multiple of fe, the
    record ending mid-period): the fitted amplitudes are the known ones to 1e-7 relative of the
    largest (the fit is exact for this signal; 1e-7 allows the least-squares round-off over up to
    10^6 samples with a 10^4 spread of amplitudes)."""
    n = int(periods * rate / fe)
    t = np.arange(n) / rate
    fit = harmonic_amplitudes(_periodic(t, fe, amps, phis, offset=0.3), rate, fe, 5)
    np.testing.assert_allclose(fit.amplitude, amps, rtol=0, atol=1e-7 * max(amps))
    assert abs(fit.offset - 0.3) <= 1e-7 * max(amps)


@FAST
@given(rate=rates, fe=fundamentals, a=amplitudes, phi=phases)
def test_a_sines_spectrum_peak_does_not_depend_on_the_sample_rate(rate, fe, a, phi):
    """One second of a sine of amplitude ``a`` at fe, at any rate: the flattop amplitude spectrum
    peaks at the bin nearest fe (1 Hz bins) and reads ``a`` within 0.1 % (scipy's flattop window:
    its scalloping loss between bins is below 0.01 dB, 0.1 %), whatever the rate."""
    n = int(rate)
    t = np.arange(n) / rate
    f, amp = amplitude_spectrum(a * np.cos(2 * np.pi * fe * t + phi), rate)
    j = int(np.argmax(amp))
    assert abs(f[j] - fe) <= (f[1] - f[0]) * 1.0 + 1e-9
    assert abs(amp[j] / a - 1.0) < 1e-3


@FAST
@given(
    rate=st.sampled_from([5120.0, 10240.0, 25600.0, 51200.0]),
    fe=fundamentals,
    amps=st.lists(amplitudes, min_size=3, max_size=3),
    phis=st.lists(phases, min_size=3, max_size=3),
)
def test_dwell_analysis_at_a_second_sample_rate_gives_the_same_point(rate, fe, amps, phis):
    """The same force and response (three harmonics each), recorded at ``rate`` and at a quarter
    of it: ``analyze_dwell``'s F1 and the response's harmonics and phases relative to the force
    agree between the two rates (1e-7 of the largest; both are exact fits of the same signal) and
    equal the known values."""
    out = []
    for r in (rate, rate / 4):
        t = np.arange(int(20 * r / fe)) / r
        force = 5.0 * np.cos(2 * np.pi * fe * t + 0.4)
        resp = _periodic(t, fe, amps, phis)
        out.append(analyze_dwell({"force": force, "resp": resp}, r, fe, k_max=3, active="none"))
    full, quarter = out
    assert abs(full.force_amplitude - 5.0) < 1e-9 * 5 and abs(quarter.force_amplitude - 5.0) < 1e-9 * 5
    for d in (full, quarter):
        np.testing.assert_allclose(d.harmonics["resp"].amplitude, amps, rtol=0, atol=1e-7 * max(amps))
    dphi = np.angle(np.exp(1j * (full.phases_to_force["resp"] - quarter.phases_to_force["resp"])))
    big = np.asarray(amps) > 1e-3 * max(amps)  # the phase of a vanishing harmonic means nothing
    assert np.all(np.abs(dphi[big]) < 1e-5)


@FAST
@given(
    fe=fundamentals,
    amps=st.lists(st.floats(min_value=0.5, max_value=10.0), min_size=3, max_size=3),
    phis=st.lists(phases, min_size=3, max_size=3),
    noise=st.floats(min_value=0.0, max_value=0.2),
    seed=seeds,
)
def test_the_two_halves_of_a_steady_record_give_the_same_harmonics(fe, amps, phis, noise, seed):
    """A steady record (three harmonics of fe, white noise of standard deviation ``noise``, 200
    periods at 5120 S/s): the amplitudes of its first and second half agree within six standard
    deviations of their difference, ``6 sqrt(2) noise sqrt(2 / n_half)`` (each half's coefficient
    has standard deviation ``noise sqrt(2 / n_half)``; the two halves are independent), plus 1e-9
    of the amplitude for round-off; and each equals the known amplitude within the same bound."""
    rate = 5120.0
    n = int(200 * rate / fe)
    t = np.arange(n) / rate
    x = _periodic(t, fe, amps, phis) + noise * np.random.default_rng(seed).standard_normal(n)
    h = n // 2
    first = harmonic_amplitudes(x[:h], rate, fe, 3).amplitude
    second = harmonic_amplitudes(x[h : 2 * h], rate, fe, 3).amplitude
    sigma = noise * np.sqrt(2.0 / h)
    bound = 6 * np.sqrt(2) * sigma + 1e-9 * np.asarray(amps)
    assert np.all(np.abs(first - second) <= bound), (first, second, bound)
    assert np.all(np.abs(first - amps) <= bound) and np.all(np.abs(second - amps) <= bound)
