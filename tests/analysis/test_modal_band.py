"""Modal identification that follows the band (issue 29): a mode found on the whole grid is found,
with the same frequency and damping, in any band that holds it with a few half-power bandwidths
to spare; a band with no mode says so.

The FRF is a closed-form modal sum (accelerance of three well-separated, lightly damped modes)
with 0.5 % complex noise on every line (seeded), so the truth is known exactly.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from rigtools.analysis.modal_id import identify

FN = np.array([40.0, 75.0, 120.0])  # Hz
ZETA = np.array([0.010, 0.015, 0.008])
RESIDUE = np.array([1.0, -0.7, 1.3])  # 1/kg
F = np.arange(0.0, 200.0001, 0.25)  # 801 lines, as a 4 s frame


def _accelerance(noise: float = 0.005, seed: int = 1) -> np.ndarray:
    w, wn = 2 * np.pi * F, 2 * np.pi * FN
    h = sum(-(w**2) * a / (x**2 - w**2 + 2j * z * x * w) for a, x, z in zip(RESIDUE, wn, ZETA, strict=True))
    rng = np.random.default_rng(seed)
    return h + noise * np.abs(h) * (rng.standard_normal(F.size) + 1j * rng.standard_normal(F.size)) / np.sqrt(
        2
    )


H = _accelerance()


@pytest.fixture(scope="module")
def full_band():
    """The whole grid's modes: the three modes, near the truth (0.05 % in frequency, 3 % in
    damping: the noise moves the poles by about that)."""
    res = identify(F, H, kind="accelerance")
    fn = np.array([m.frequency_hz for m in res.modes])
    zeta = np.array([m.damping_ratio for m in res.modes])
    np.testing.assert_allclose(fn, FN, rtol=5e-4)
    np.testing.assert_allclose(zeta, ZETA, rtol=0.03)
    return fn, zeta


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    k=st.integers(0, FN.size - 1),
    below=st.floats(3.0, 40.0),
    above=st.floats(3.0, 40.0),
)
# found by this test in CI-like runs: the band's 180 lines capped LSCF at order 18, where the 120 Hz
# pole missed the stability tolerances (now retried at twice the cap: converged_selection)
@example(k=2, below=20.25, above=3.25)
def test_a_band_around_a_mode_finds_it_as_the_whole_grid_does(full_band, k, below, above):
    """Moves the band's edges: ``below`` and ``above`` half-power bandwidths (2 zeta fn) from
    mode ``k`` (3 to 40, clipped to the grid). The mode is found in the band; its frequency is
    within 0.2 % of the whole grid's and of the truth (the must-show's tolerance; measured up to
    0.09 % with a band edge 3 bandwidths away, where the neighbours' tails are cut), its damping
    within 15 % (measured up to 7 %: the damping is the weaker estimate of the two, the
    half-power band holds 4-8 lines here)."""
    bw = 2 * ZETA[k] * FN[k]
    lo, hi = max(FN[k] - below * bw, F[1]), min(FN[k] + above * bw, F[-1])
    res = identify(F, H, kind="accelerance", f_min=lo, f_max=hi)
    near = [m for m in res.modes if abs(m.frequency_hz - FN[k]) < bw]
    assert len(near) == 1, (lo, hi, res.notes, res.tried)
    m = near[0]
    fn_full, zeta_full = full_band
    for ref in (FN[k], fn_full[k]):
        assert abs(m.frequency_hz / ref - 1) < 2e-3, (lo, hi, m.frequency_hz, ref)
    for ref in (ZETA[k], zeta_full[k]):
        assert abs(m.damping_ratio / ref - 1) < 0.15, (lo, hi, m.damping_ratio, ref)
    assert res.no_mode == ""


def test_a_band_without_a_mode_says_so_with_what_was_tried():
    """A band between two modes (50-65 Hz: 10 and 20 half-power bandwidths from the nearest)
    holds no peak: no mode, a ``no_mode`` sentence naming the band and what would help, and the
    lines the band holds in ``tried`` (61 lines of 0.25 Hz)."""
    res = identify(F, H, kind="accelerance", f_min=50.0, f_max=65.0)
    assert res.modes == []
    assert res.no_mode.startswith("no mode between 50 and 65 Hz: the band (61 lines) holds no peak")
    assert "would help" in res.no_mode and res.no_mode in res.notes
    assert res.tried["lines"] == 61 and res.tried["peaks"] == 0
