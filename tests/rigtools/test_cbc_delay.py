"""The delay-aware law of the buffered CBC loop (rigtools.procedures.cbc_delay, EnvelopeGains):
identification, the delayed closed loop and the design, held against independent references (the
parameters a synthetic record was made with, eigenvalues set by hand, a step-by-step simulation of
the delayed loop written here)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rigtools.procedures.cbc_delay import (
    BlockModel,
    closed_loop,
    design_envelope_gains,
    fit_block_model,
    spectral_radius,
)
from rigtools.procedures.cbc_iteration import DELAY_GAINS, EnvelopeGains

T = 0.02  # s per block, as on NI and the simulated rig


def _rot(angle: float, scale: float = 1.0) -> np.ndarray:
    return scale * np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])


def _saddle(sigma: float) -> BlockModel:
    """A 2-state orbit model: a saddle growing at ``sigma`` 1/s in one direction, decaying at
    20 1/s in the other, the drive entering turned by 60 deg (m per V per block)."""
    a = np.diag([math.exp(sigma * T), math.exp(-20 * T)])
    a1 = np.zeros((2, 2))
    b = np.stack([_rot(math.radians(60), 4e-4), np.zeros((2, 2)), np.zeros((2, 2))])
    return BlockModel(np.stack([a, a1]), b, T)


def _simulate(model: BlockModel, gains: EnvelopeGains, blocks: int) -> np.ndarray:
    """|x_k| of the delayed loop, stepped by hand from x_0 = (1e-6, 0) m: the law after block k,
    the drive of block k+2 fading from the previous setting to it (its mean: the two halves)."""
    k, d = np.reshape(gains.k, (2, 2)), np.reshape(gains.d, (2, 2))
    x = [np.zeros(2), np.array([1e-6, 0.0])]
    settings_ = [np.zeros(2), np.zeros(2)]  # c_{k-2}, c_{k-1}
    played = [np.zeros(2)] * 3  # u_{k-2}, u_{k-1}, u_k
    out = []
    for _ in range(blocks):
        c = -k @ x[-1] - d @ (x[-1] - x[-2])
        nxt = sum(model.a[i] @ x[-1 - i] for i in range(model.a.shape[0]))
        nxt = nxt + sum(model.b[j] @ played[-1 - j] for j in range(model.b.shape[0]))
        played = [*played[1:], 0.5 * (settings_[0] + settings_[1])]
        settings_ = [settings_[1], c]
        x = [x[-1], nxt]
        out.append(float(np.linalg.norm(nxt)))
    return np.array(out)


def test_fit_recovers_the_model_a_record_was_made_with():
    """An ARX(2, 3) record with a random drive and 1e-9 m of noise (1e-3 of the response's
    variation): the fitted matrices within 2e-3 of the true ones (relative, the noise's share)."""
    rng = np.random.default_rng(3)
    true = _saddle(-3.0)
    true = BlockModel(true.a, np.stack([true.b[0], 0.5 * true.b[0], -0.2 * true.b[0]]), T)
    n = 600
    u = rng.choice([-1.0, 1.0], size=(n, 2)) * 2e-3
    x = np.zeros((n, 2))
    for k in range(3, n - 1):
        x[k + 1] = sum(true.a[i] @ x[k - i] for i in range(2)) + sum(true.b[j] @ u[k - j] for j in range(3))
    x += rng.normal(0, 1e-9, x.shape)
    fit = fit_block_model(x[:, 0] + 1j * x[:, 1] + (3e-4 + 1e-4j), u[:, 0] + 1j * u[:, 1] + 0.37, T)
    assert np.allclose(fit.a, true.a, atol=2e-3)
    assert np.allclose(fit.b, true.b, atol=2e-3 * np.abs(true.b).max())
    assert fit.residual < 0.01


def test_with_growth_moves_the_real_eigenvalue_alone():
    """The saddle's growing eigenvalue moved to exp(10 T); the others stay (to 1e-9)."""
    model = _saddle(2.0)
    before = model.eigenvalues()
    after = model.with_growth(10.0).eigenvalues()
    assert after[0].real == pytest.approx(math.exp(10 * T), rel=1e-9)
    assert np.allclose(np.sort_complex(after[1:]), np.sort_complex(before[1:]), atol=1e-9)
    assert model.with_growth(10.0).growth_rate() == pytest.approx(10.0, rel=1e-9)


def test_closed_loop_radius_is_the_stepped_loops_rate():
    """The spectral radius of closed_loop equals the per-block decay or growth of the loop
    stepped by hand (the ratio of |x| over blocks 300-400, to 1e-3), for the simulated rig's
    gains on a saddle that grows at 8 1/s."""
    model = _saddle(8.0)
    rho = spectral_radius(model, DELAY_GAINS)
    norms = _simulate(model, DELAY_GAINS, 400)
    assert (norms[399] / norms[299]) ** (1 / 100) == pytest.approx(rho, rel=1e-3)
    assert closed_loop(model, DELAY_GAINS).shape == (2 * (2 + 3 + 2),) * 2


def test_design_holds_a_saddle_a_plain_gain_does_not():
    """A saddle growing at 12 1/s (growth x 2.5-block delay = 0.6): the design's loop decays
    (stepped by hand: |x| down by 1e3 in 300 blocks), a proportional gain alone (K = 300 I
    V/m, no lead) does not hold it (radius above 1)."""
    model = _saddle(12.0)
    plain = EnvelopeGains((300.0, 0.0, 0.0, 300.0), (0.0, 0.0, 0.0, 0.0))
    assert spectral_radius(model, plain) > 1.0
    gains, rho = design_envelope_gains([model, model.with_growth(6.0)], trials=3, seed=1)
    assert rho < 0.95
    norms = _simulate(model, gains, 300)
    assert norms[-1] < 1e-3 * norms[0]


@settings(max_examples=25, deadline=None)
@given(
    turn=st.floats(-math.pi, math.pi),
    e=st.complex_numbers(max_magnitude=1e-4),
    d=st.complex_numbers(max_magnitude=1e-4),
)
def test_the_law_does_not_depend_on_the_streams_phase(turn, e, d):
    """Turning the stream's phase (every harmonic, the target and the feedforward alike) turns the
    correction by the same angle: the law is the orbit's, not the clock's (to 1e-12 V)."""
    target, ff = 3.4e-4 * np.exp(-2.3j), 0.373 * np.exp(0.27j)
    r = np.exp(1j * turn)
    base = DELAY_GAINS.correction(e, d, target, ff)
    turned = DELAY_GAINS.correction(e * r, d * r, target * r, ff * r)
    assert abs(turned - base * r) < 1e-12
