"""H1, H2, Hv of a 2-DOF mass-spring system with an exact FRF (tests/analysis/_reference.py),
the chunked accumulator against scipy.signal.csd, burst random and periodic chirp."""

import numpy as np
import pytest
from _reference import one_frf, periodic_response, receptance
from scipy import signal

from rigtools.analysis.frf import FRFMethod

FS = 512.0


def _random_test(out_noise=0.0, in_noise=0.0, n=2**18, seed=7):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n)
    y = periodic_response(x, FS, out=1, kind="accelerance")
    xm = x + in_noise * rng.standard_normal(n)
    ym = y + out_noise * np.std(y) * rng.standard_normal(n)
    return x, y, xm, ym


def _exact_accelerance(f):
    return -((2 * np.pi * f) ** 2) * receptance(f, out=1)


def _within_1_percent(est, h):
    f = est.frequency_hz
    sel = (f > 5) & (f < 250) & (est.coherence > 0.99)
    assert sel.sum() > 500
    ratio = h[sel] / _exact_accelerance(f[sel])
    assert np.max(np.abs(np.abs(ratio) - 1)) < 0.01
    assert np.max(np.abs(np.angle(ratio))) < 0.01
    return sel


def test_h1_h2_of_two_dof_within_1_percent_where_coherent():
    """Random force; Hann 2048 (df = 0.25 Hz vs half-power bands of 2.6 and 7.1 Hz: leakage bias
    < 0.3 %), 1023 averages, so the random error of |H| at coherence 0.99,
    sqrt(1 - g^2) / (g sqrt(2 n_avg)) = 0.22 %, stays below 1 % at 4.5 sigma.

    Each estimator is held to 1 % (amplitude) and 0.01 rad where coherence > 0.99 with the noise
    it is built for: H1 with 2 % noise on the response, H2 with 2 % noise on the force (the other
    estimator is then biased by up to 1 / coherence - 1 = 1.01 %, see the bias test). Hv lies
    between them, within 1 % in both cases."""
    _, _, x, y = _random_test(out_noise=0.02, n=2**20)
    est = one_frf(x, y, FS, "random", 2048)
    sel = _within_1_percent(est, est.h1)
    _within_1_percent(est, est.hv)
    # Hv is the geometric mean: between H1 and H2 everywhere
    assert np.all(np.abs(est.h1[sel]) <= np.abs(est.hv[sel]) * (1 + 1e-12))
    assert np.all(np.abs(est.hv[sel]) <= np.abs(est.h2[sel]) * (1 + 1e-12))

    x, y, _, _ = _random_test(n=2**20)
    xm = x + 0.02 * np.random.default_rng(9).standard_normal(x.size)
    est = one_frf(xm, y, FS, "random", 2048)
    _within_1_percent(est, est.h2)
    _within_1_percent(est, est.hv)


def test_noise_bias_directions_follow_theory():
    """Input noise: H1 low by Sff / (Sff + Snn) = 1 / (1 + 0.5**2) = 0.8, H2 unbiased.
    Output noise: H2 high by 1 + Smm / Syy (per bin), H1 unbiased. Band medians within 2 %."""
    x, y, xm, _ = _random_test(in_noise=0.5)
    est = one_frf(xm, y, FS, "random", 2048)
    f = est.frequency_hz
    band = (f > 5) & (f < 250)
    exact = _exact_accelerance(f[band])
    assert np.median(np.abs(est.h1[band] / exact)) == pytest.approx(0.8, rel=0.02)
    assert np.median(np.abs(est.h2[band] / exact)) == pytest.approx(1.0, rel=0.02)

    rng = np.random.default_rng(3)
    noise_std = 0.3 * np.std(y)
    ym = y + noise_std * rng.standard_normal(y.size)
    est = one_frf(x, ym, FS, "random", 2048)
    exact_all = _exact_accelerance(f)
    # theory: H2 / H = 1 + Smm / (|H|^2 Sff), with Sff = 2 / FS and Smm = 2 noise_std^2 / FS
    expected_h2 = 1 + noise_std**2 / np.abs(exact_all[band]) ** 2
    assert np.median(np.abs(est.h1[band] / exact)) == pytest.approx(1.0, rel=0.02)
    assert np.median(np.abs(est.h2[band] / exact) / expected_h2) == pytest.approx(1.0, rel=0.02)
    assert np.all(np.median(np.abs(est.h2[band] / exact)) > 1.05)


@pytest.mark.parametrize("block", [1000, 4096, 77777])
def test_accumulator_equals_scipy_csd_for_any_block_size(block):
    """Three responses against one force: the block-by-block spectra equal scipy.signal.welch/csd
    on the whole record to 1e-10 (relative to the largest value)."""
    rng = np.random.default_rng(11)
    data = rng.standard_normal((4, 100_000)) + 0.3
    kw = dict(fs=FS, nperseg=1024, noverlap=512, window="hann", detrend="constant")
    blocks = (data[:, i : i + block] for i in range(0, data.shape[1], block))
    est = FRFMethod("random", 1024).estimate(blocks, FS)
    f, sxx = signal.welch(data[0], **kw)
    np.testing.assert_allclose(est.frequency_hz, f)
    np.testing.assert_allclose(est.sxx, sxx, rtol=0, atol=1e-10 * sxx.max())
    for i in range(3):
        _, syy = signal.welch(data[i + 1], **kw)
        _, sxy = signal.csd(data[0], data[i + 1], **kw)
        np.testing.assert_allclose(est.syy[i], syy, rtol=0, atol=1e-10 * syy.max())
        np.testing.assert_allclose(est.sxy[i], sxy, rtol=0, atol=1e-10 * np.abs(sxy).max())
    _, syy = signal.welch(data[1], **kw)
    _, sxy = signal.csd(data[0], data[1], **kw)
    assert est.n_averages == 1 + (100_000 - 1024) // 512
    np.testing.assert_allclose(est.h1[0], sxy / sxx, rtol=1e-9)
    np.testing.assert_allclose(est.coherence[0], np.abs(sxy) ** 2 / (sxx * syy), rtol=1e-9, atol=1e-12)


def test_periodic_chirp_whole_periods_no_window_is_exact():
    """A periodic chirp (1 s period, 5..250 Hz) in steady state: rectangular segments of one
    period give the exact FRF at every excited bin (1e-9), averaged over 8 periods."""
    period = int(FS)
    t = np.arange(period) / FS
    chirp = signal.chirp(t, 5.0, t[-1], 250.0)
    x = np.tile(chirp, 8)
    y = periodic_response(x, FS, out=1, kind="accelerance")
    est = FRFMethod("periodic", period).estimate(
        (np.vstack([x[i : i + 700], y[i : i + 700]]) for i in range(0, x.size, 700)), FS
    )
    assert est.n_averages == 8
    f = est.frequency_hz
    sel = (f >= 10) & (f <= 240)
    np.testing.assert_allclose(est.h1[0][sel], _exact_accelerance(f[sel]), rtol=1e-9)
    np.testing.assert_allclose(est.coherence[0][sel], 1.0, atol=1e-9)


def test_burst_random_rectangular_window():
    """Bursts of 25 % random force, then silence while the response decays (exp(-zeta w t) <
    1e-6 by the period end); rectangular windows of one burst period: H1 within 0.5 % (amplitude)
    and 0.005 rad of the exact FRF between 10 and 240 Hz (what remains is the band-limited force
    ringing between its samples into the neighbouring burst's segment, largest at low f)."""
    rng = np.random.default_rng(5)
    period, n_bursts = 2 * int(FS), 40
    x = np.zeros(period * n_bursts)
    for b in range(n_bursts):
        # cosine-tapered edges (Tukey 20 %): a hard edge rings on between the samples of the
        # band-limited force and would leak into the next burst's segment
        x[b * period : b * period + period // 4] = rng.standard_normal(period // 4) * signal.windows.tukey(
            period // 4, 0.2
        )
    y = periodic_response(x, FS, out=1, kind="accelerance")
    est = FRFMethod("burst", period).estimate([np.vstack([x, y])], FS)
    f = est.frequency_hz
    sel = (f >= 10) & (f <= 240)
    ratio = est.h1[0][sel] / _exact_accelerance(f[sel])
    assert np.max(np.abs(np.abs(ratio) - 1)) < 5e-3
    assert np.max(np.abs(np.angle(ratio))) < 5e-3


def test_kind_conversion_of_an_estimate():
    """accelerance -> receptance divides H1 and H2 by -w^2 (exact arithmetic, 1e-12)."""
    _, _, x, y = _random_test(out_noise=0.0, n=2**15)
    acc = one_frf(x, y, FS, "random", 2048)
    rec = acc.as_kind("accelerance", "receptance")
    w = 2 * np.pi * acc.frequency_hz[1:]
    np.testing.assert_allclose(rec.h1[1:], acc.h1[1:] / -(w**2), rtol=1e-12)
    np.testing.assert_allclose(rec.h2[1:], acc.h2[1:] / -(w**2), rtol=1e-12)
    np.testing.assert_array_equal(rec.coherence, acc.coherence)
    with pytest.raises(ValueError, match="h1, h2 or hv"):
        rec.estimator("h3")
