"""Safety limits and drive ramps, against closed forms.

The drive is checked sample by sample against a(t) sin(2 pi f t) written out independently:
a(t) = A (1 - cos(pi k / n)) / 2 on a ramp of n samples (k = 1..n). Tolerances: 1e-12 absolute
(double-precision round-off of the phase accumulation over < 1e5 samples); 1e-15 for the bare
envelope (a few ulps of values <= 2).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigtools.config import load_rig
from rigtools.drivers.contracts import ConfigurationError, InputChannelSpec, LimitExceeded, SafetyAbort
from rigtools.drivers.safety import AmplitudeEnvelope, ChannelLimit, SafetyMonitor, SineDrive, raised_cosine

FS = 51200.0


def test_raised_cosine_closed_form_and_smooth_ends():
    n = 400
    r = raised_cosine(n)
    k = np.arange(1, n + 1)
    np.testing.assert_allclose(r, np.sin(np.pi * k / (2 * n)) ** 2, atol=1e-15)  # same function
    assert r[-1] == 1.0 and np.all(np.diff(r) > 0)
    # slope continuous: first and last steps are O(1/n^2), the middle one O(1/n)
    assert r[0] < 2e-5 and 1 - r[-2] < 2e-5 and np.max(np.diff(r)) == pytest.approx(np.pi / (2 * n), rel=1e-4)
    assert raised_cosine(0).size == 0


def test_ramp_up_follows_the_raised_cosine_envelope_across_blocks():
    f, amp, ramp = 60.0, 2.0, 0.25
    drive = SineDrive(FS, f, max_drive=5.0, ramp_time=ramp)
    drive.set_target(amp)
    sizes = [100, 3000, 7, 5120, 9000, 5120]
    out = np.concatenate([drive.next_block(s) for s in sizes])
    n_ramp = math.ceil(ramp * FS)
    i = np.arange(out.size)
    envelope = np.where(i < n_ramp, amp * 0.5 * (1 - np.cos(np.pi * (i + 1) / n_ramp)), amp)
    expected = envelope * np.sin(2 * np.pi * f * i / FS)
    np.testing.assert_allclose(out, expected, atol=1e-12)
    assert drive.settled and drive.amplitude == amp
    assert drive.samples_written == out.size


def test_no_step_onto_the_shaker():
    # |d/dt a sin(wt)| <= A w + pi A / (2 T): the largest sample-to-sample change is bounded by it
    f, amp, ramp = 400.0, 5.0, 0.1
    drive = SineDrive(FS, f, max_drive=5.0, ramp_time=ramp)
    out = [np.zeros(1)]
    drive.set_target(amp)
    out.append(drive.next_block(8000))
    drive.set_target(1.0)  # mid-course change starts a new ramp
    out.append(drive.next_block(3000))
    out.append(drive.stop_block())
    x = np.concatenate(out)
    bound = (amp * 2 * np.pi * f + np.pi * amp / (2 * ramp)) / FS
    assert np.max(np.abs(np.diff(x))) <= bound * 1.001
    assert x[-1] == 0.0


@pytest.mark.parametrize("ramp", [0.01, 0.05, 0.5])
def test_stop_ramps_down_along_the_raised_cosine_to_exactly_zero(ramp):
    drive = SineDrive(FS, 60.0, max_drive=5.0, ramp_time=ramp)
    drive.set_target(3.0)
    before = drive.next_block(40000)  # fully ramped up (<= 0.5 s = 25600 samples)
    tail = drive.stop_block()
    assert tail.size == math.ceil(ramp * FS)
    assert tail[-1] == 0.0 and drive.amplitude == 0.0 and drive.settled
    # the envelope of the tail is a raised cosine from 3 V down to 0
    n = tail.size
    k = np.arange(1, n + 1)
    phase = 2 * np.pi * 60.0 * (40000 + k - 1) / FS
    np.testing.assert_allclose(
        tail, 3.0 * (1 - 0.5 * (1 - np.cos(np.pi * k / n))) * np.sin(phase), atol=1e-12
    )
    assert np.all(drive.next_block(100) == 0.0)
    assert np.max(np.abs(before[-100:])) > 2.9


def test_retarget_mid_ramp_starts_from_the_present_amplitude():
    """Closed form: 0 -> 2 V over n1 samples, cut after m; then a -> 0.5 V over n2 samples."""
    env = AmplitudeEnvelope(1000.0, 0.1, 5.0)
    assert env.set_target(2.0) == 100
    first = env.take(30)
    a = 2.0 * 0.5 * (1 - np.cos(np.pi * 30 / 100))
    assert env.amplitude == pytest.approx(a, abs=1e-15) and not env.settled
    assert env.set_target(0.5, ramp_time=0.02) == 20
    second = np.concatenate([env.take(7), env.take(0), env.take(20)])
    k1, k2 = np.arange(1, 31), np.arange(1, 21)
    np.testing.assert_allclose(first, 2.0 * 0.5 * (1 - np.cos(np.pi * k1 / 100)), atol=1e-15)
    np.testing.assert_allclose(second[:20], a + (0.5 - a) * 0.5 * (1 - np.cos(np.pi * k2 / 20)), atol=1e-15)
    assert np.all(second[20:] == 0.5) and env.settled and env.target == 0.5
    with pytest.raises(ConfigurationError, match="ramp time"):
        AmplitudeEnvelope(1000.0, 0.0, 5.0)


def test_drive_targets_are_limited():
    drive = SineDrive(FS, 60.0, max_drive=5.0, ramp_time=0.5)
    for bad in (5.01, -0.1, float("nan"), float("inf")):
        with pytest.raises(LimitExceeded, match="maximum drive"):
            drive.set_target(bad)
    with pytest.raises(LimitExceeded, match="Nyquist"):
        drive.set_frequency(FS)


def test_frequency_change_keeps_the_phase_continuous():
    drive = SineDrive(FS, 60.0, max_drive=5.0, ramp_time=0.01)
    drive.set_target(1.0)
    a = drive.next_block(10000)
    drive.set_frequency(120.0)
    b = drive.next_block(10000)
    phase0 = 2 * np.pi * 60.0 * 10000 / FS
    np.testing.assert_allclose(b, np.sin(phase0 + 2 * np.pi * 120.0 * np.arange(10000) / FS), atol=1e-12)
    assert abs(b[0] - a[-1]) < 2 * np.pi * 120.0 / FS


def channels():
    return [
        InputChannelSpec("force", "Dev1/ai0", "force", 11.24, "mV/N", 0.004, -200, 200),
        InputChannelSpec("accel", "Dev1/ai1", "accel", 10.0, "mV/g", 0.004, -4900, 4900),
    ]


def monitor():
    return SafetyMonitor(
        [
            ChannelLimit("force", 40.0, 60.0),
            ChannelLimit("accel", 2500.0, 4000.0),
            ChannelLimit("drive", 4.5, 5.5),
        ],
        channels(),
        max_drive=5.0,
    )


def test_monitor_passes_quiet_blocks_and_warns_by_channel():
    mon = monitor()
    t = np.arange(5120) / FS
    quiet = np.vstack([30 * np.sin(2 * np.pi * 60 * t), 1000 * np.sin(2 * np.pi * 360 * t)])
    assert mon.check(quiet, drive=4.0 * np.sin(2 * np.pi * 60 * t)) == []
    loud = quiet.copy()
    loud[0, 100] = -45.0  # one sample above the warning (peak |value|)
    w = mon.check(loud, drive=np.full(10, 4.6))
    assert [(x.channel, x.value, x.limit) for x in w] == [("force", 45.0, 40.0), ("drive", 4.6, 4.5)]
    assert str(w[0]) == "force peak 45 N is above the warning limit 40 N"


def test_monitor_aborts_naming_channel_value_and_limit_and_keeps_the_block():
    mon = monitor()
    block = np.zeros((2, 100))
    block[1, 50] = 4100.0
    with pytest.raises(SafetyAbort) as info:
        mon.check(block)
    err = info.value
    assert (err.channel, err.value, err.limit) == ("accel", 4100.0, 4000.0)
    assert str(err) == "safety abort: accel peak 4100 m/s^2 reached the abort limit 4000 m/s^2"
    assert err.partial is block
    block[1, 50] = np.nan
    with pytest.raises(SafetyAbort, match="accel is not finite"):
        mon.check(block)
    with pytest.raises(SafetyAbort, match=r"drive peak 5.2 V exceeds the maximum drive 5 V"):
        mon.check(np.zeros((2, 10)), drive=np.array([0.0, 5.2]))


def test_monitor_refuses_unknown_channels_and_bad_limits():
    with pytest.raises(ConfigurationError, match="unknown channel 'torque'"):
        SafetyMonitor([ChannelLimit("torque", 1.0, 2.0)], channels())
    with pytest.raises(ConfigurationError, match="warning"):
        ChannelLimit("force", 60.0, 40.0)
    with pytest.raises(ValueError, match="does not match"):
        monitor().check(np.zeros((3, 10)))


def test_monitor_from_the_default_rig_file():
    cfg = load_rig()
    mon = SafetyMonitor(
        [ChannelLimit(n, l.warning, l.abort) for n, l in cfg.safety.limits.items()],
        cfg.daq.input_specs(),
        cfg.safety.max_drive,
    )
    assert mon.limits["force"].units == "N" and mon.limits["drive"].units == "V"
    block = np.zeros((3, 10))
    block[0, 0] = cfg.safety.limits["force"].abort
    with pytest.raises(SafetyAbort, match="force"):
        mon.check(block)
