"""Modal identification against exact references: synthetic 2-DOF FRFs with known poles on a
coarse grid, and the poles of a digital filter identified from H1 of white-noise data."""

import numpy as np
import pytest
from _reference import one_frf
from scipy import signal

from rigtools.analysis.frf import sdof_frf
from rigtools.analysis.modal_id import (
    fit_sdof,
    half_power_damping,
    identify_modes,
    parabolic_peak,
    pick_peaks,
)


def _two_dof(f, kind="accelerance"):
    # two modes of a lightly damped 2-DOF system in modal form, opposite-sign modal constants
    return sdof_frf(f, 100.0, 0.01, 0.5, kind) - sdof_frf(f, 131.0, 0.02, 0.8, kind)


@pytest.mark.parametrize("kind", ["receptance", "mobility", "accelerance"])
def test_two_dof_exact_on_coarse_grid(kind):
    """df = 1 Hz is half the 100 Hz mode's 2 Hz half-power band. With 1 % complex noise the local
    fit must return fn within 0.05 % and zeta within 10 %; the raw peak alone is only good to
    df/2 = 0.5 %."""
    rng = np.random.default_rng(3)
    f = np.arange(0.0, 400.0, 1.0) + 0.37  # peaks fall between bins
    h = _two_dof(f, kind)
    h = h * (1 + 0.01 * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) / np.sqrt(2))
    modes = identify_modes(f, h, kind=kind, f_min=20, f_max=300)
    assert [m.method for m in modes] == ["sdof-fit", "sdof-fit"]
    assert modes[0].frequency_hz == pytest.approx(100.0, rel=5e-4)
    assert modes[1].frequency_hz == pytest.approx(131.0, rel=5e-4)
    assert modes[0].damping_ratio == pytest.approx(0.01, rel=0.10)
    assert modes[1].damping_ratio == pytest.approx(0.02, rel=0.10)
    # receptance-form modal constants 1/m: 2 and -1/0.8. 5 % for mode 1; 15 % for mode 2, whose
    # wider fit band sees mode 1's tail vary more than the fitted constant residual can absorb
    assert modes[0].residue.real == pytest.approx(2.0, rel=0.05)
    assert modes[1].residue.real == pytest.approx(-1.25, rel=0.15)


def test_parabolic_and_half_power_on_fine_sdof():
    """Fine grid (df = 0.01 Hz vs 2 Hz bandwidth): half-power zeta within 1 %, parabola within 1e-4."""
    f = np.arange(0.0, 200.0, 0.01) + 0.003
    h = sdof_frf(f, 100.0, 0.01, 1.0, "receptance")
    i = int(np.argmax(np.abs(h)))
    # receptance peaks at wn sqrt(1 - 2 zeta^2)
    assert parabolic_peak(f, h, i) == pytest.approx(100.0 * np.sqrt(1 - 2e-4), rel=1e-5)
    assert half_power_damping(f, h, i) == pytest.approx(0.01, rel=0.01)
    assert fit_sdof(f, h, i, kind="receptance").frequency_hz == pytest.approx(100.0, rel=1e-7)


def test_poles_of_digital_filter_identified_from_white_noise_h1():
    """Two resonators in parallel driven by white noise; reference: the filter's own poles
    (fn = |ln z| fs / 2 pi, zeta = -Re ln z / |ln z|). Coarse df = 0.49 Hz vs 2 Hz / 9 Hz bands;
    fn within 0.1 %, zeta within 15 %."""
    fs = 2000.0
    rng = np.random.default_rng(4)
    systems = [
        signal.cont2discrete(
            ([1.0], [1.0, 2 * z * 2 * np.pi * fn, (2 * np.pi * fn) ** 2]), 1 / fs, "bilinear"
        )
        for fn, z in ((100.0, 0.01), (450.0, 0.01))
    ]
    x = rng.standard_normal(2**16)
    y = sum(signal.lfilter(np.ravel(num), den, x) for num, den, _ in systems)
    y = y + 0.02 * np.std(y) * rng.standard_normal(x.size)
    est = one_frf(x, y, fs, "random", 4096)
    modes = identify_modes(est.frequency_hz, est.h1, kind="receptance", f_min=20, f_max=900, n_modes=2)
    assert len(modes) == 2
    for mode, (_, den, _) in zip(modes, systems, strict=True):
        z = np.roots(den)
        s = np.log(z[np.argmax(z.imag)]) * fs
        assert mode.frequency_hz == pytest.approx(abs(s) / (2 * np.pi), rel=1e-3)
        assert mode.damping_ratio == pytest.approx(-s.real / abs(s), rel=0.15)


def test_pick_peaks_ignores_small_ripples_and_keeps_most_prominent():
    f = np.arange(0.0, 400.0, 0.5)
    h = _two_dof(f) * (1 + 0.001 * np.sin(f))  # ripple far below 6 dB
    idx = pick_peaks(f, h, f_min=20)
    assert f[idx] == pytest.approx([100.0, 131.0], abs=0.5)
    assert f[pick_peaks(f, h, f_min=20, n_peaks=1)] == pytest.approx([100.0], abs=0.5)
