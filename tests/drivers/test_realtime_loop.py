"""The real-time inner loop (rigtools.drivers.realtime) as the simulated rig runs it, per sample
inside its integrator:

* the delay is the one stated: a step of the target reaches the loop's output at the first tick
  ``t_k >= T + D`` (D = 0.84 ms + two 0.1 ms ticks), never earlier, and with the value the law gives;
* at a STABLE orbit of the model, with the target equal to it, the loop's output tends to what the
  target's own truncation to 40 harmonics leaves (non-invasive at a true orbit), the response on the orbit;
* at an UNSTABLE orbit of the model (gap 0.5 mm, fe = 64 Hz, F1 5 N, A 0.3534 mm, |mu| 1.098,
  found by the toolkit's shooting, tests/drivers/model_orbits.py) the loop holds the response on
  it; with the loop's output zero it leaves at the rate ln|mu| per period;
* the NI-DAQmx backend says it has no real-time loop;
* the multipliers measured from the transient after a probe (rigtools.analysis.floquet) match
  the model's, for the stable and the unstable orbit.
"""

from __future__ import annotations

import math
from dataclasses import replace

import model_orbits as mo
import numpy as np
import pytest

from rigtools.analysis.floquet import floquet_multipliers, periodic_reference
from rigtools.config import load_rig
from rigtools.drivers.contracts import ConfigurationError
from rigtools.drivers.realtime import CONVERTER_DELAY, NO_REALTIME_LOOP, HarmonicTarget, RealTimeLoop
from rigtools.drivers.simulated import SimulatedRig
from rigtools.sim.delayed_feedback import loop_gain
from rigtools.sim.vibro_impact import OUT_COLUMNS

LAW = {"kp": 2000.0, "kd": 1.0}  # V/m, V*s/m: holds the unstable orbit (kd = 0 does not)


@pytest.fixture(scope="module")
def cfg():
    return load_rig()


def _rig(cfg, loop: RealTimeLoop | None, fs: float, block: int) -> SimulatedRig:
    """The simulated rig at gap 0.5 mm with a noise-free chain and no delay line (the
    converters' delay is the loop's own), configured."""
    p = cfg.to_params()
    p = replace(p, contact=replace(p.contact, gap=mo.GAP))
    rig = SimulatedRig(
        p, cfg.shaker.to_params(), cfg.test_article.to_params().ideal(), seed=0, max_time_to_zero=None
    )
    rig.set_realtime_loop(loop)
    rig.configure(cfg.daq.input_specs(), cfg.daq.output_spec(), fs, block)
    return rig


def _run(rig: SimulatedRig, amplitude: float, blocks: int, block: int, start: int = 0) -> int:
    """Drive ``amplitude * sin(2 pi fe t)`` (t at each sample's end, as the shooting's drive)
    for ``blocks`` blocks from sample ``start`` (priming two blocks when it is 0); the next sample."""
    k = start

    def next_block() -> np.ndarray:
        nonlocal k
        t = (np.arange(k, k + block) + 1) / rig.sample_rate
        k += block
        return amplitude * np.sin(2 * np.pi * mo.FE * t)

    if start == 0:
        rig.write(next_block())
        rig.write(next_block())
        rig.start()
    for _ in range(blocks):
        rig.read()
        rig.write(next_block())
    return k


@pytest.mark.parametrize(
    "block, first_tick_ms",
    [
        (500, 21.1),  # T = 20 ms: T + D = 21.04 ms, the next tick 21.1 ms
        (504, 21.2),  # T = 20.16 ms: T + D = 21.2 ms exactly, that tick
        (505, 21.3),  # T = 20.2 ms: T + D = 21.24 ms, the next tick 21.3 ms
    ],
)
def test_a_step_of_the_target_reaches_the_output_after_exactly_the_delay(cfg, block, first_tick_ms):
    """At rest (no drive), Kp only: the target's mean steps to 10 um at the end of the second
    block read, T = 2 * block / 50 kS/s. (ticks every 0.1 ms). The output is exactly 0 before the first tick
    t_k >= T + D and exactly Kp * 10 um from it (the shroud has not moved yet: the law's value)."""
    loop = RealTimeLoop(kp=100.0)
    assert loop.delay_s == pytest.approx(CONVERTER_DELAY + 2e-4, abs=1e-15)
    fs = 50_000.0
    rig = _rig(cfg, loop, fs, block)
    k = _run(rig, 0.0, 2, block)
    rig.set_loop_target(HarmonicTarget(mo.FE, mean=1e-5))
    _run(rig, 0.0, 2, block, start=k)
    u = rig.loop_log[0]
    first = int(np.flatnonzero(u)[0])
    assert (first + 1) / fs == pytest.approx(first_tick_ms * 1e-3, abs=1e-12)  # column i ends at (i + 1) / fs
    assert u[first] == pytest.approx(100.0 * 1e-5, rel=1e-12)
    rig.stop()


def test_new_gains_act_from_the_next_sample_with_the_target_kept(cfg):
    """set_loop_gains while the stream runs (a gain schedule between blocks): at rest, Kp only,
    the target's mean 10 um; after the gains change from 100 to 300 V/m the output of the next
    block is exactly 300 * 10 um minus what the shroud moved (the law's value with the new gain,
    the target unchanged), and the loop's record says the new gains."""
    fs, block = 50_000.0, 500
    rig = _rig(cfg, RealTimeLoop(kp=100.0, target=HarmonicTarget(mo.FE, mean=1e-5)), fs, block)
    k = _run(rig, 0.0, 2, block)
    rig.set_loop_gains(300.0, 0.0)
    _run(rig, 0.0, 1, block, start=k)
    u, x = rig.loop_log[0, -block:], rig.loop_log[1, -block:]
    assert rig.realtime_loop is not None and rig.realtime_loop.kp == 300.0
    # the loop's measurement D before the tick: the shroud barely moves in 10 ms at 0.1 V, so
    # the output lies within 1 % of 300 V/m * 10 um whatever it moved
    assert np.all(np.abs(u[-100:] - 300.0 * 1e-5) <= 0.01 * 300.0 * 1e-5 + 300.0 * np.max(np.abs(x)))
    assert np.max(np.abs(u[-100:])) > 200.0 * 1e-5  # not the old gain's 100 * 10 um
    rig.stop()


def _orbit_velocity(kind: str) -> np.ndarray:
    _, _, _, pmap = mo.model()
    point = mo.orbit(kind)
    data = pmap.flow(point.state * pmap.scale, point.forcing)[1]
    return data[:, OUT_COLUMNS.index("active_tip_velocity")].copy()


def test_at_a_stable_orbit_the_loop_is_non_invasive(cfg):
    """Target = the model's stable impacting orbit (A 0.310 mm, |mu| 0.80), its drive played: from
    rest the loop pulls the rig onto the orbit (open loop it would settle on the orbit without
    impacts, 0.303 mm, another phase) and its output falls to what the target's truncation to 40
    harmonics leaves: max |u| <= 1.5 (Kp e_x + Kd e_v) (e_x, e_v the truncation's largest errors
    on the orbit's samples; 1.5 for the instants between samples), below 1 % of the drive rms.
    Reference: the orbit by the shooting (rigtools.sim.continuation.solve_orbit)."""
    point = mo.orbit("stable")
    assert point.stable and 0.75 < point.max_multiplier < 0.85  # the model's orbit, as the issue states
    target = mo.orbit_target("stable")
    t = np.arange(1, mo.STEPS + 1) / mo.FS
    tx, tv = target.evaluate(t)
    e_x = np.max(np.abs(tx - mo.orbit_displacement("stable")))
    e_v = np.max(np.abs(tv - _orbit_velocity("stable")))
    rig = _rig(cfg, RealTimeLoop(**LAW, target=target), mo.FS, mo.STEPS)
    _run(rig, point.forcing.force, 96, mo.STEPS)  # 1.5 s
    u, x = rig.loop_log[:, -mo.STEPS :]
    amplitude = point.measures.tip_amplitude_active
    assert np.max(np.abs(x - mo.orbit_displacement("stable"))) < 1e-3 * amplitude
    assert np.max(np.abs(u)) <= 1.5 * (LAW["kp"] * e_x + LAW["kd"] * e_v)
    assert np.sqrt(np.mean(u**2)) < 0.01 * point.forcing.force / np.sqrt(2)
    rig.stop()


def test_the_loop_holds_an_unstable_orbit_which_open_loop_leaves(cfg):
    """Target = the model's unstable orbit between the folds (A 0.3534 mm, |mu| 1.098, a real
    multiplier): held 1.2 s from rest, the response is on it within 0.1 % of A; then the loop's
    output is set to zero (target None: as with zero gains) and the response leaves: its largest
    distance from the orbit per period grows by ln|mu| per period within 10 % (fitted between
    10 nm and 30 um; measured 3 %) and passes 50 um within 1.5 s."""
    point = mo.orbit("unstable")
    assert not point.stable and 1.05 < point.max_multiplier < 1.15
    rig = _rig(cfg, RealTimeLoop(**LAW, target=mo.orbit_target("unstable")), mo.FS, mo.STEPS)
    k = _run(rig, point.forcing.force, 77, mo.STEPS)
    orbit = mo.orbit_displacement("unstable")
    held = rig.loop_log[1, -mo.STEPS :]
    assert np.max(np.abs(held - orbit)) < 1e-3 * point.measures.tip_amplitude_active
    rig.set_loop_target(None)
    _run(rig, point.forcing.force, 96, mo.STEPS, start=k)
    x = rig.loop_log[1, -96 * mo.STEPS :].reshape(96, mo.STEPS)
    d = np.max(np.abs(x - orbit), axis=1)
    fit = (d > 1e-8) & (d < 3e-5)
    fit[:2] = False  # the loop's last outputs still act over the first delay
    slope = np.polyfit(np.flatnonzero(fit), np.log(d[fit]), 1)[0]
    assert slope == pytest.approx(np.log(point.max_multiplier), rel=0.10)
    assert d[-1] > 5e-5
    rig.stop()


def test_contract_errors_are_one_line(cfg):
    """A loop on the linear model, a target without a loop, and a loop without delay are refused
    in one line; NO_REALTIME_LOOP is the one line a procedure prints on a buffered backend."""
    linear = SimulatedRig(cfg.to_params(), cfg.shaker.to_params(), model="linear")
    with pytest.raises(ConfigurationError, match="vibro-impact model only"):
        linear.set_realtime_loop(RealTimeLoop(kp=1.0))
    with pytest.raises(ConfigurationError, match="no real-time loop"):
        linear.set_loop_target(HarmonicTarget(64.0))
    with pytest.raises(ConfigurationError, match="delay must be > 0"):
        RealTimeLoop(converter_delay_s=0.0, compute_samples=0)
    assert "\n" not in NO_REALTIME_LOOP and "real-time target" in NO_REALTIME_LOOP
    assert SimulatedRig.has_realtime_loop


def test_the_ni_backend_has_no_realtime_loop():
    nidaq = pytest.importorskip("rigtools.drivers.nidaq", reason="the nidaqmx package is not installed")
    assert nidaq.NiDaqDevice.has_realtime_loop is False


def _probe_and_release(cfg, kind: str, hold_target, probe_target, probe_blocks: int, after: int):
    """Hold ``hold_target`` 64 periods (1 s) from rest, then ``probe_target`` for
    ``probe_blocks`` periods, then release (target None: open loop at the orbit's drive) for
    ``after`` periods; the loop's displacement record from the release on, and the record."""
    point = mo.orbit(kind)
    rig = _rig(cfg, RealTimeLoop(**LAW, target=hold_target), mo.FS, mo.STEPS)
    k = _run(rig, point.forcing.force, 64, mo.STEPS)
    if probe_blocks:
        rig.set_loop_target(probe_target)
        k = _run(rig, point.forcing.force, probe_blocks, mo.STEPS, start=k)
    rig.set_loop_target(None)
    _run(rig, point.forcing.force, after, mo.STEPS, start=k)
    x = rig.loop_log[1]  # before the stop's ramp
    rig.stop()
    return x, (64 + probe_blocks) * mo.STEPS


def _scaled(target: HarmonicTarget, factor: float) -> HarmonicTarget:
    return HarmonicTarget(
        target.fe_hz,
        tuple(factor * c for c in target.cos),
        tuple(factor * s for s in target.sin),
        target.mean,
    )


def _assert_leading_multipliers_within(measured: np.ndarray, model: np.ndarray, how_many: int, rel: float):
    for mu in model[:how_many]:
        nearest = measured[np.argmin(np.abs(measured - mu))]
        assert abs(nearest - mu) <= rel * abs(mu), (mu, measured)


def test_measured_multipliers_of_the_stable_orbit_match_the_model(cfg):
    """Probe: the loop holds a target 2 % larger than the stable orbit for 1 s, then releases;
    the shroud's displacement (the loop's own channel) decays onto the orbit. The orbit is the
    average of the last 16 periods (rigtools.analysis.floquet.periodic_reference), the fit over
    periods 2-30 after the release (the first two: the impacts' timing still far from the
    orbit's). Reference: the model's multipliers by the shooting's monodromy matrix
    (0.440 +- 0.668j, |mu| 0.80, and 0.556): the three largest within 10 % (measured: the pair
    0.2 %, the real one 7.5 %; the faster ones, |mu| 0.51, decay in a few periods and are not
    resolved)."""
    target = mo.orbit_target("stable")
    x, released = _probe_and_release(cfg, "stable", _scaled(target, 1.02), None, 0, 40)
    ref = periodic_reference(x, mo.FS, mo.FE, x.size - 16 * mo.STEPS, x.size)
    measured = floquet_multipliers((x - ref)[released:], mo.FS, mo.FE, first_period=2, last_period=30)
    _assert_leading_multipliers_within(measured.multipliers, mo.orbit("stable").multipliers, 3, 0.10)
    assert measured.max_modulus < 1.0


def test_measured_multipliers_of_the_unstable_orbit_match_the_model(cfg):
    """The loop holds the unstable orbit (non-invasive: its record over the last 16 held periods
    is the orbit), a 0.1 % larger target for 4 periods probes it, then the loop releases it. The
    fit runs from the first period after the release until the deviation passes 1 % of A (the
    linear range). Reference: the model's multipliers 1.098 and 0.437 +- 0.670j: each within 10 %
    (measured 0.9 % and 0.2 %); the estimate says unstable. It also shows a real 1.03 that the
    model does not have (the probe's slow part; not asserted either way)."""
    target = mo.orbit_target("unstable")
    x, released = _probe_and_release(cfg, "unstable", target, _scaled(target, 1.001), 4, 64)
    ref = periodic_reference(x, mo.FS, mo.FE, 48 * mo.STEPS, 64 * mo.STEPS)
    point = mo.orbit("unstable")
    limit = 0.01 * point.measures.tip_amplitude_active
    measured = floquet_multipliers((x - ref)[released:], mo.FS, mo.FE, first_period=1, limit=limit)
    _assert_leading_multipliers_within(measured.multipliers, point.multipliers, 3, 0.10)
    assert measured.max_modulus > 1.0


def test_the_lowpass_filters_the_law_as_its_biquad(cfg):
    """With the output low-pass (RealTimeLoop.lowpass_hz, 350 Hz) the step of the target's mean
    (10 um, Kp 100 V/m, at rest) shows at the same tick as without it, scaled by the biquad's b0
    (closed form of the bilinear second-order Butterworth with prewarping: K = tan(pi fc / rate),
    b0 = K^2 / (1 + sqrt(2) K + K^2)), and the next tick by b0 (1 + 2 - a1) (b1 = 2 b0; the
    shroud has not moved yet); loop_gain's factor at the corner is 1/sqrt(2) at -90 deg."""
    fc, rate = 350.0, 10_000.0
    kk = math.tan(math.pi * fc / rate)
    norm = 1 + math.sqrt(2) * kk + kk * kk
    b0, a1 = kk * kk / norm, 2 * (kk * kk - 1) / norm
    fs, block = 50_000.0, 500
    rig = _rig(cfg, RealTimeLoop(kp=100.0, lowpass_hz=fc), fs, block)
    k = _run(rig, 0.0, 2, block)
    rig.set_loop_target(HarmonicTarget(mo.FE, mean=1e-5))
    _run(rig, 0.0, 2, block, start=k)
    u = rig.loop_log[0]
    first = int(np.flatnonzero(u)[0])
    assert (first + 1) / fs == pytest.approx(21.1e-3, abs=1e-12)  # as the plain law's (block 500)
    assert u[first] == pytest.approx(100.0 * 1e-5 * b0, rel=1e-9)
    per_tick = round(fs / rate)
    assert u[first + per_tick] == pytest.approx(100.0 * 1e-5 * b0 * (3 - a1), rel=1e-6)
    rig.stop()
    ratio = loop_gain(2000.0, 4.0, 1.04e-3, rate, fc, fc) / loop_gain(2000.0, 4.0, 1.04e-3, rate, fc)
    assert abs(ratio) == pytest.approx(1 / math.sqrt(2), rel=1e-9)
    assert np.angle(ratio, deg=True) == pytest.approx(-90.0, abs=1e-6)


def test_a_lowpass_beyond_half_the_rate_is_one_line():
    with pytest.raises(ConfigurationError, match="low-pass"):
        RealTimeLoop(kp=1.0, lowpass_hz=6000.0)
