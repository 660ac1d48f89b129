"""identify(): LSCF (sdypy-EMA) with a stabilisation check and peak picking, against the exact
modes of the 2-DOF in tests/analysis/_reference.py; nothing from a pure-sine (dwell) record."""

import numpy as np
import pytest
from _reference import K, M, one_frf, periodic_response, receptance
from _reference import modes as exact_modes
from scipy import linalg

from rigtools.analysis.frf import convert_frf
from rigtools.analysis.modal_id import excitation_support, identify, identify_modes

FS = 512.0


def _h1(seed=1, n=2**18, noise=0.02):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n)
    y = periodic_response(x, FS, out=1, kind="accelerance")
    y = y + noise * np.std(y) * rng.standard_normal(n)
    return one_frf(x, y, FS, "random", 2048)


def _identify_h1(est, method):
    """identify() of an H1 estimate in 10-250 Hz, with its excitation PSD and coherence."""
    return identify(
        est.frequency_hz,
        est.h1,
        kind="accelerance",
        excitation_psd=est.sxx,
        coherence=est.coherence,
        f_min=10,
        f_max=250,
        method=method,
    )


def test_lscf_exact_frf_gives_exact_poles_and_mass_normalised_constants():
    """Noise-free exact accelerance on a 0.25 Hz grid: poles to 1e-6, LSFD constants (as
    receptance-form modal constants phi_1 phi_2 of the mass-normalised modes) to 1e-5."""
    f = np.arange(0, 256.001, 0.25)
    h = -((2 * np.pi * f) ** 2) * receptance(f, 1)
    res = identify(f, h, kind="accelerance", f_min=10, f_max=250)
    fn, zeta = exact_modes()
    assert [m.method for m in res.modes] == ["lscf", "lscf"]
    np.testing.assert_allclose([m.frequency_hz for m in res.modes], fn, rtol=1e-6)
    np.testing.assert_allclose([m.damping_ratio for m in res.modes], zeta, rtol=1e-5)
    _, phi = linalg.eigh(K, M)
    np.testing.assert_allclose([m.residue.real for m in res.modes], phi[0] * phi[1], rtol=1e-5)
    assert res.notes == []
    # the chart holds the stable poles of both modes at many orders
    assert res.chart.stable.sum() > 20


@pytest.mark.parametrize("kind", ["receptance", "mobility"])
def test_lscf_of_a_converted_frf_with_nan_at_0_hz(kind):
    """An accelerance converted to receptance or mobility is nan at 0 Hz (divided by i w); LSCF
    leaves that bin out (below f_min) and finds the exact poles (to 1e-6) as from accelerance
    (`rig analyze FRF.h5 --kind receptance` ended in a LinAlgError traceback)."""
    f = np.arange(0, 256.001, 0.25)
    h = convert_frf(-((2 * np.pi * f) ** 2) * receptance(f, 1), f, "accelerance", kind)
    assert np.isnan(h[0]) and np.all(np.isfinite(h[1:]))
    res = identify(f, h, kind=kind, f_min=10, f_max=250)
    fn, zeta = exact_modes()
    np.testing.assert_allclose([m.frequency_hz for m in res.modes], fn, rtol=1e-6)
    np.testing.assert_allclose([m.damping_ratio for m in res.modes], zeta, rtol=1e-5)


@pytest.mark.parametrize("method", ["lscf", "peak"])
def test_two_dof_from_noisy_h1_within_half_percent_and_five_percent(method):
    """H1 of a random test (2 % output noise, 255 averages, df = 0.25 Hz): natural frequencies
    within 0.5 %, damping ratios within 5 % of the state-space poles."""
    res = _identify_h1(_h1(), method)
    fn, zeta = exact_modes()
    assert len(res.modes) == 2, res.notes
    np.testing.assert_allclose([m.frequency_hz for m in res.modes], fn, rtol=5e-3)
    np.testing.assert_allclose([m.damping_ratio for m in res.modes], zeta, rtol=0.05)


def test_no_mode_from_a_pure_sine_record():
    """A 60 Hz sine force (dwell) through the 2-DOF with 1 % noise on both channels: the H1 peaks
    are noise over leakage; identify() returns no mode and says why. The unguarded peak picker
    does return 'modes' from the same data (the defect this guards against)."""
    rng = np.random.default_rng(2)
    n = 2**17
    t = np.arange(n) / FS
    x = 15.0 * np.sin(2 * np.pi * 60.0 * t)
    y = periodic_response(x, FS, out=1, kind="accelerance")
    x = x + 0.15 * rng.standard_normal(n)
    y = y + 0.01 * np.std(y) * rng.standard_normal(n)
    est = one_frf(x, y, FS, "random", 2048)
    for method in ("lscf", "peak"):
        res = _identify_h1(est, method)
        assert res.modes == []
        assert "sine dwell" in res.notes[0]
    support = excitation_support(est.frequency_hz, est.sxx, est.coherence, f_min=10, f_max=250)
    assert support.fraction < 0.05
    assert len(identify_modes(est.frequency_hz, est.h1, f_min=10, f_max=250)) > 0


def test_broadband_support_is_complete():
    est = _h1(n=2**16)
    support = excitation_support(est.frequency_hz, est.sxx, est.coherence, f_min=10, f_max=250)
    assert support.ok and support.fraction > 0.9  # the anti-resonance bins lose coherence


def test_two_responses_identified_together_with_stable_shapes():
    """Both responses of the 2-DOF (one reference) in one LSCF: exact poles (1e-6), each mode's
    residues at the two points equal phi_out * phi_in of the mass-normalised modes (1e-5), and
    its poles' shapes agree between consecutive orders (MAC >= 0.9 is the stability test; here
    1 - 1e-9). A MAC threshold no shape can meet leaves no stable pole: the shape check is made."""
    f = np.arange(0, 256.001, 0.25)
    h = np.vstack([-((2 * np.pi * f) ** 2) * receptance(f, out) for out in (0, 1)])
    res = identify(f, h, kind="accelerance", f_min=10, f_max=250)
    fn, zeta = exact_modes()
    np.testing.assert_allclose([m.frequency_hz for m in res.modes], fn, rtol=1e-6)
    np.testing.assert_allclose([m.damping_ratio for m in res.modes], zeta, rtol=1e-5)
    _, phi = linalg.eigh(K, M)
    shapes = np.array([m.shape for m in res.modes]).real  # (mode, response)
    np.testing.assert_allclose(shapes, (phi * phi[0]).T, rtol=1e-5)
    assert all(m.mac_min > 1 - 1e-9 for m in res.modes)
    assert res.chart.mac is not None and np.all(res.chart.mac[res.chart.stable] >= 0.9)
    none = identify(f, h, kind="accelerance", f_min=10, f_max=250, min_mac=1.01)
    assert none.modes == [] and not none.chart.stable.any()


def test_a_band_too_narrow_or_too_coarse_for_the_fit_is_one_value_error():
    """Exact accelerance on a coarse 4 Hz grid: a band of 3 lines, or one whose top leaves fewer
    lines from 0 Hz than the lowest LSCF order needs (4: two converged orders), is a ValueError
    naming the band and the grid (sdypy-EMA's IndexError or "Singular matrix" before). The orders
    follow the band's lines (issue 29): the 19 lines of 10-84 Hz are fitted at order 4 and give
    the first mode (it was refused while the orders started at 20); the 2-DOF's modes are all
    found on 10-250 Hz. Frequencies within 0.1 % of the exact eigenvalues (exact data, a grid
    of 4 Hz: the LSCF poles are exact to far better)."""
    f = np.arange(0, 256.001, 4.0)
    h = -((2 * np.pi * f) ** 2) * receptance(f, 1)
    with pytest.raises(
        ValueError, match=r"band 100-108 Hz holds 3 of the FRF's lines \(0-256 Hz, every 4 Hz\)"
    ):
        identify(f, h, kind="accelerance", f_min=100, f_max=108)
    with pytest.raises(
        ValueError, match=r"the FRF has 6 lines from 0 Hz to the band's top 20 Hz \(every 4 Hz\)"
    ):
        identify(f, h, kind="accelerance", f_min=4, f_max=20)
    fn, _ = exact_modes()
    low = identify(f, h, kind="accelerance", f_min=10, f_max=84)
    np.testing.assert_allclose([m.frequency_hz for m in low.modes], fn[:1], rtol=1e-3)
    res = identify(f, h, kind="accelerance", f_min=10, f_max=250)
    np.testing.assert_allclose(sorted(m.frequency_hz for m in res.modes), fn, rtol=1e-3)
