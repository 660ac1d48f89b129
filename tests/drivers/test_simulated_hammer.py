"""The simulated impact hammer: its half-sine impulses against the closed form, block by block,
and its force as the simulated rig's hammer channel reads it."""

import math

import numpy as np
import pytest

from rigtools.drivers.contracts import ConfigurationError, InputChannelSpec
from rigtools.drivers.simulated import SimulatedHammer, SimulatedRig


def test_impulses_integrate_the_half_sine_exactly_across_blocks():
    """Each hit carries peak * 2 * duration / pi (the half-sine's integral) whatever the block
    boundaries; hits start at first + i * interval; the peaks scatter within +-scatter."""
    dt = 1 / 51200
    h = SimulatedHammer(peak=20.0, duration=5e-4, interval=0.25, first=0.1, scatter=0.1, seed=3)
    n = int(1.0 / dt)
    whole = h.impulses(0, n, dt)
    pieces = np.concatenate([h.impulses(k, min(777, n - k), dt) for k in range(0, n, 777)])
    np.testing.assert_allclose(pieces, whole, rtol=0, atol=1e-15)
    starts = np.flatnonzero(np.diff((whole > 0).astype(int)) == 1) + 1
    np.testing.assert_allclose(starts * dt, 0.1 + 0.25 * np.arange(4), atol=dt)
    per_hit = [whole[s : s + 40].sum() for s in starts]
    for i, total in enumerate(per_hit):
        assert total == pytest.approx(h._peak(i) * 2 * 5e-4 / math.pi, rel=1e-12)
        assert abs(h._peak(i) / 20.0 - 1) <= 0.1
    assert SimulatedHammer(hits=2, interval=0.25, first=0.1).impulses(0, n, dt).astype(bool).sum() <= 2 * 27


def test_the_hammer_channel_reads_the_pulse_and_the_linear_model_refuses_a_hammer():
    from rigtools.config import load_rig

    cfg = load_rig()
    ta = cfg.test_article.to_params().ideal()
    hammer = SimulatedHammer(
        blade="passive", position=0.085, peak=20.0, duration=5e-4, interval=1.0, first=0.05, scatter=0.0
    )
    rig = SimulatedRig(cfg.to_params(), cfg.shaker.to_params(), ta, seed=1, hammer=hammer)
    spec = InputChannelSpec("hammer", "Dev1/ai3", "force", 2.25, "mV/N", 0.004, -2200.0, 2200.0)
    fs = rig.configure([spec], cfg.daq.output_spec(), 51200.0, 1024)
    rig.write(np.zeros(1024))
    rig.start()
    x = np.concatenate([rig.read(1024)[0] for _ in range(4) if rig.write(np.zeros(1024)) is None])
    # the interval means of the half-sine, quantised by the 24-bit ADC over +-2200 N
    assert x.max() == pytest.approx(20.0, abs=0.05)
    assert x.sum() / fs == pytest.approx(20.0 * 2 * 5e-4 / math.pi, rel=1e-3)
    with pytest.raises(ConfigurationError, match="needs the vibro-impact model"):
        SimulatedRig(cfg.to_params(), model="linear", hammer=hammer).configure(
            [spec], cfg.daq.output_spec(), 51200.0, 1024
        )
    with pytest.raises(ConfigurationError, match="not on the passive blade"):
        SimulatedRig(cfg.to_params(), hammer=SimulatedHammer(position=0.3)).configure(
            [spec], cfg.daq.output_spec(), 51200.0, 1024
        )
