"""Operational modal analysis (rigtools.analysis.oma, ssi, tones) on records with known modes.

The reference: a 3-DOF chain (masses on springs, fixed-free) with modal damping, driven by white
noise at every mass, simulated by modal superposition with each mode discretised exactly (zero-
order hold: the discrete poles are exp(lambda dt)), plus 5 % sensor noise and, where stated, a pure
sine on every channel (a harmonic). Its natural frequencies and damping ratios are the ones put in.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from rigtools.analysis.oma import averaged_spectra, operational_modes
from rigtools.analysis.ssi import output_covariances
from rigtools.analysis.tones import band_kurtosis, harmonic_family

FS = 40.0
MODES_HZ = (2.0, 5.0, 7.5)
ZETA = (0.02, 0.015, 0.01)
TONE_HZ = 4.0


def chain_response(seed: int, seconds: float = 300.0, tone_hz: float | None = TONE_HZ) -> np.ndarray:
    """(3, N) displacements of the chain (see the module docstring)."""
    rng = np.random.default_rng(seed)
    k = 2 * np.eye(3) - np.eye(3, k=1) - np.eye(3, k=-1)
    k[-1, -1] = 1
    _, phi = np.linalg.eigh(k)
    u = rng.normal(size=(3, int(FS * seconds)))
    q = np.empty_like(u)
    for r, (f, z) in enumerate(zip(MODES_HZ, ZETA, strict=True)):
        w = 2 * np.pi * f
        b, a, _ = signal.cont2discrete(([1.0], [1, 2 * z * w, w * w]), 1 / FS, method="zoh")
        q[r] = signal.lfilter(b[0], a, phi[:, r] @ u)
    y = phi @ q
    if tone_hz is not None:
        t = np.arange(y.shape[1]) / FS
        y += np.outer(np.array([0.5, 0.3, 0.4]) * y.std(axis=1), np.sin(2 * np.pi * tone_hz * t + 0.3))
    return y + 0.05 * y.std(axis=1, keepdims=True) * rng.normal(size=y.shape)


def _check_modes(res, what: str) -> None:
    """Each mode put in comes out once, within 3 stated spreads (frequency and damping) and
    within 1 % in frequency; nothing else is called a mode."""
    assert len(res.modes) == len(MODES_HZ), (what, [m.frequency_hz for m in res.modes])
    for m, f, z in zip(res.modes, MODES_HZ, ZETA, strict=True):
        assert abs(m.frequency_hz - f) <= min(3 * m.frequency_spread_hz, 0.01 * f), (what, m.frequency_hz, f)
        assert abs(m.damping_ratio - z) <= 3 * m.damping_spread, (what, m.damping_ratio, z, m.damping_spread)


@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 10_000), order=st.permutations([0, 1, 2]))
def test_modes_come_out_and_the_sine_is_a_harmonic(seed, order):
    """Known modes within their spread, whatever the seed and the channel order (metamorphic:
    the order of the channels must not change a mode); the sine flagged, never a mode."""
    y = chain_response(seed)[list(order)]
    res = operational_modes(y, FS, band=(0.5, 10.0))
    _check_modes(res, f"seed {seed}, order {order}")
    assert [round(h.frequency_hz, 2) for h in res.harmonics] == [TONE_HZ]
    assert "tone" in res.harmonics[0].reason
    # the shapes follow the channels: the first mode of a chain has all components in phase
    assert np.all(np.real(res.modes[0].shape) > 0)


def test_fe_flags_the_sine_as_its_multiple():
    """With fe given, the line at 2 fe is named as that multiple."""
    res = operational_modes(chain_response(7), FS, band=(0.5, 10.0), fe=TONE_HZ / 2)
    assert [(round(h.frequency_hz, 2), h.multiple) for h in res.harmonics] == [(TONE_HZ, 2)]
    assert "fe" in res.harmonics[0].reason


def test_halves_agree_within_their_spread():
    """Metamorphic: the two halves of one record give each mode within 3 root-sum-squared
    spreads of each other."""
    y = chain_response(11, seconds=600.0)
    half = y.shape[1] // 2
    a = operational_modes(y[:, :half], FS, band=(0.5, 10.0))
    b = operational_modes(y[:, half:], FS, band=(0.5, 10.0))
    assert len(a.modes) == len(b.modes) == len(MODES_HZ)
    for x, z in zip(a.modes, b.modes, strict=True):
        assert abs(x.frequency_hz - z.frequency_hz) <= 3 * np.hypot(
            x.frequency_spread_hz, z.frequency_spread_hz
        )


def test_a_band_around_one_mode_finds_that_mode():
    """Metamorphic: a band holding one mode with a few half-power bandwidths to spare gives
    that mode as the full band does, within 3 spreads."""
    y = chain_response(3, tone_hz=None)
    full = operational_modes(y, FS, band=(0.5, 10.0))
    one = operational_modes(y, FS, band=(4.0, 6.0))
    assert [round(m.frequency_hz) for m in one.modes] == [5]
    m5 = next(m for m in full.modes if abs(m.frequency_hz - 5.0) < 0.2)
    assert abs(one.modes[0].frequency_hz - m5.frequency_hz) <= 3 * np.hypot(
        one.modes[0].frequency_spread_hz, m5.frequency_spread_hz
    )


def test_white_noise_has_no_mode():
    """Noise alone: no mode, and the result says so (found false, a note with what would help)."""
    rng = np.random.default_rng(5)
    res = operational_modes(rng.normal(size=(3, 12000)), FS, band=(0.5, 10.0))
    assert res.modes == [] and res.to_dict()["found"] is False
    assert any("would help" in n for n in res.notes)


def test_bad_inputs_are_one_line_errors():
    y = chain_response(1, seconds=30.0)
    with pytest.raises(ValueError, match="must lie inside"):
        operational_modes(y, FS, band=(5.0, 30.0))
    with pytest.raises(ValueError, match="constant channel"):
        operational_modes(np.vstack([y[0], np.ones(y.shape[1])]), FS, channels=["a", "b"])


def test_covariances_equal_the_direct_sum():
    """R_k[i, j] = sum_t y_i(t + k) y_j(t) / (N - k), against numpy's direct sums."""
    rng = np.random.default_rng(2)
    y = rng.normal(size=(2, 500))
    r = output_covariances(y, 7)
    for k in (0, 3, 7):
        direct = y[:, k:] @ y[:, : y.shape[1] - k].T / (y.shape[1] - k)
        np.testing.assert_allclose(r[k], direct, rtol=1e-10, atol=1e-12)


def test_averaged_spectra_equal_scipy_csd():
    """Singular values of the averaged cross-spectral matrix against scipy.signal.csd's."""
    rng = np.random.default_rng(4)
    y = rng.normal(size=(3, 4000))
    y[1] += y[0]
    f, s = averaged_spectra(y, 100.0, 256)
    g = np.array([[signal.csd(y[i], y[j], fs=100.0, nperseg=256)[1] for j in range(3)] for i in range(3)])
    ref = np.linalg.svd(np.moveaxis(g, 2, 0), compute_uv=False)
    np.testing.assert_allclose(s, ref, rtol=1e-9)
    np.testing.assert_allclose(f, signal.csd(y[0], y[0], fs=100.0, nperseg=256)[0])


def test_kurtosis_of_a_sine_and_of_noise():
    """A sine reads 1.5; band-limited Gaussian noise reads 3 within 3 standard errors."""
    rng = np.random.default_rng(8)
    t = np.arange(20000) / 20.0
    k_sine, _ = band_kurtosis(np.sin(2 * np.pi * 3.0 * t), 20.0, 2.8, 3.2)
    assert abs(k_sine - 1.5) < 0.02
    k_noise, err = band_kurtosis(rng.normal(size=t.size), 20.0, 2.8, 3.2)
    assert abs(k_noise - 3.0) < 3 * err


def test_harmonic_family():
    """Lines on 1, 2, 5 times 0.8 Hz (within the tolerance) and one off it."""
    f0, ks = harmonic_family([0.8, 1.601, 2.9, 4.0], 0.01, min_members=3)
    assert f0 == pytest.approx(0.8, abs=1e-3)
    assert ks == [1, 2, None, 5]
    assert harmonic_family([0.8, 1.3], 0.01, min_members=3)[0] is None
