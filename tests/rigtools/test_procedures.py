"""Lab procedures on the simulated rig (unpaced), checked against independent references:
force control at 60 Hz with impacts and at the measured first resonance, a stepped sine's
peak against the test article's own FE frequency, jumps up and down, stop requests and faults.

Fixed simulated-rig seed; every figure quoted in a docstring was measured with these settings.
"""

import numpy as np
import pytest

from rigtools.config import load_rig
from rigtools.errors import TargetNotReached
from rigtools.procedures import RigStudy, SineDwell, Status, SteppedSine, detect_jumps
from rigtools.procedures.frf import FrfTest, quick_check
from rigtools.recording import check_recording, open_recording
from rigtools.recording.summary import summary

RATE = 51200.0
WIDE = 5e-3  # a gap no response here closes below 2 N: no impacts


@pytest.fixture(scope="module")
def cfg():
    return load_rig()


def _article_flexural(cfg, n=2):
    """The test article's own flexural frequencies (FE model with the [test_article] deviations)."""
    from rigtools.sim.modal import blade_modes
    from rigtools.sim.rig_model import build_rig_model

    ta = cfg.test_article.to_params()
    modes = blade_modes(build_rig_model(ta.apply(cfg.to_params())).active, 6)
    return modes.frequencies_hz[np.array(modes.kinds) == "flexural"][:n]


def test_force_control_with_impacts_at_60_hz(cfg, tmp_path):
    """15 N at 60 Hz, gap 0.5 mm (impacts: the force holds harmonics up to 40 % of its
    fundamental): the fundamental within 1 % (control tolerance 0.5 %) in at most 10 updates
    after the ramp (measured: 3), approached from below, no safety warning."""
    r = SineDwell(
        cfg,
        {"fe": 60.0, "force": 15.0, "gap": 5e-4, "record_periods": 12},
        tmp_path / "d.h5",
        backend="sim",
        seed=1,
    ).run()
    p = r.points[0]
    assert r.status is Status.FINISHED
    assert p.force_amplitude_measured == pytest.approx(15.0, rel=0.01)
    assert p.control_updates <= 10 and p.settled and p.extra["safety_warnings"] == 0
    forces = [f for _, f in p.extra["control_history"]]
    assert max(forces[:-1]) < 15.0 * 1.05  # never far above the target
    force_h = p.harmonics["force"]
    assert max(force_h[1:]) > 0.2 * force_h[0]  # impacts: force rich in harmonics


def test_force_control_at_the_measured_first_resonance(cfg, tmp_path):
    """The first resonance measured by a periodic-chirp FRF test (1 Hz lines: 52.0 Hz; the
    article's FE first flexural frequency is 52.01 Hz) -- a dwell there with the gap wide open
    holds 2 N within 1 % (measured 2.00005 N; force drop-out: 2.2 N/V instead of ~15 N/V at
    60 Hz) in at most 10 updates (4) without a warning. 15 N is out of reach there on the
    default rig: it needs 6.9 V (2.18 N/V, measured with raised limits in
    test_force_control_reaches_15_n_at_the_first_resonance_with_raised_drive_limits), above the
    drive warning (4.5 V) -- the controller stops at 0.98 x 4.5 V and names the limit, and the
    run ends failed (TargetNotReached, issue 19) with the point kept."""
    FrfTest(
        cfg,
        {"signal": "chirp", "band": (20.0, 200.0), "level": 0.2, "frame": 1.0, "averages": 3, "gap": WIDE},
        tmp_path / "frf.h5",
        backend="sim",
        seed=1,
    ).run()
    chk = quick_check(tmp_path / "frf.h5")
    f1 = min(pk["frequency_hz"] for pk in chk["peaks"] if pk["h1"] > 10)
    f1_fe = _article_flexural(cfg, 1)[0]
    assert f1 == pytest.approx(f1_fe, rel=0.02)
    r = SineDwell(
        cfg,
        {"fe": f1, "force": 2.0, "gap": WIDE, "record_periods": 12},
        tmp_path / "r.h5",
        backend="sim",
        seed=1,
    ).run()
    p = r.points[0]
    assert p.force_amplitude_measured == pytest.approx(2.0, rel=0.01)
    assert p.control_updates <= 10 and p.settled and p.extra["safety_warnings"] == 0
    assert p.force_amplitude_measured / p.drive_amplitude < 3.0  # force drop-out
    with pytest.raises(TargetNotReached, match="15 N cannot be reached"):
        SineDwell(
            cfg,
            {"fe": f1, "force": 15.0, "gap": WIDE, "record_periods": 6},
            tmp_path / "h.h5",
            backend="sim",
            seed=1,
        ).run()
    with open_recording(tmp_path / "h.h5") as rec:
        assert rec.attrs["end_status"] == "failed"
        q = rec.points[0].params
    assert q["control_limited_by"] == "drive warning" and q["safety_warnings"] == 0
    assert q["drive_amplitude"] <= 0.98 * 4.5 + 1e-9 and not q["settled"]


def test_force_control_reaches_15_n_at_the_first_resonance_with_raised_drive_limits(cfg, tmp_path):
    """Issue 9: 15 N +-1 % at the measured first resonance with the gap wide open, in <= 10
    updates after the ramp, no safety warning. A lab raises its drive limits for this test:
    [safety] max_drive 8 V, drive warning 7.5 V / abort 8.5 V, and opens the gap to 30 mm (the
    shroud swings ~14 mm). The first resonance from a periodic-chirp FRF test on that rig
    (52.0 Hz, 1 Hz lines); measured: 14.9996 N after 4 updates at 6.88 V, peak active shroud
    acceleration 1504 m/s^2 (warning 2500), force peak 15.01 N (warning 40 N)."""
    import tomllib

    import tomli_w

    from rigtools.config import default_rig_text

    data = tomllib.loads(default_rig_text())
    data["safety"]["max_drive"] = "8 V"
    data["safety"]["limits"]["drive"] = {"warning": "7.5 V", "abort": "8.5 V"}
    data["contact"]["gap"] = "30 mm"
    path = tmp_path / "raised.toml"
    path.write_text(tomli_w.dumps(data))
    raised = load_rig(path)
    FrfTest(
        raised,
        {"signal": "chirp", "band": (20.0, 200.0), "level": 0.2, "frame": 1.0, "averages": 3},
        tmp_path / "frf.h5",
        backend="sim",
        seed=1,
    ).run()
    chk = quick_check(tmp_path / "frf.h5")
    f1 = min(pk["frequency_hz"] for pk in chk["peaks"] if pk["h1"] > 10)
    assert f1 == pytest.approx(_article_flexural(cfg, 1)[0], rel=0.02)
    r = SineDwell(
        raised, {"fe": f1, "force": 15.0, "record_periods": 12}, tmp_path / "r.h5", backend="sim", seed=1
    ).run()
    p = r.points[0]
    assert r.status is Status.FINISHED and p.gap == pytest.approx(0.03)
    assert p.force_amplitude_measured == pytest.approx(15.0, rel=0.01)
    assert p.control_updates <= 10 and p.settled and p.extra["safety_warnings"] == 0
    assert p.drive_amplitude > 4.5  # beyond the default rig's warning
    limits = raised.safety.limits
    for name in ("active_shroud_accel", "passive_shroud_accel", "force"):
        assert p.extra["peaks"][name] < limits[name].warning


def test_stepped_sine_peak_is_the_articles_second_flexural_frequency(cfg, tmp_path):
    """2 N stepped sine 340-380 Hz (2 Hz steps, no impacts): the peak of the active shroud's
    acceleration per newton (parabola through the top three steps) within 0.3 % of the test
    article's own 2nd flexural frequency (FE, with the [test_article] root, masses)."""
    freqs = list(np.arange(340.0, 380.001, 2.0))
    out = tmp_path / "s.h5"
    r = SteppedSine(
        cfg,
        {"frequencies": freqs, "force": 2.0, "gap": WIDE, "record_periods": 30},
        out,
        backend="sim",
        seed=1,
    ).run()
    f2 = _article_flexural(cfg, 2)[1]
    assert r.summary["peak_hz"] == pytest.approx(f2, rel=0.003)
    assert all(abs(p.force_amplitude_measured / 2.0 - 1) <= 0.01 for p in r.points)
    assert check_recording(out).valid
    with open_recording(out) as rec:
        assert [p.params["fe"] for p in rec.points] == freqs
        amp = rec.points[0].params["active_shroud_accel_harmonic_amplitude"]
        assert len(amp) == 10


def test_up_and_down_stepped_sine_jumps_differ(cfg, tmp_path):
    """15 N, gap 0.7 mm, 57-79 Hz in 2 Hz steps up then down: the impacting branch is followed
    up to a jump down between 69 and 71 Hz, and on the way down the response jumps up again
    only between 65 and 63 Hz (measured with 1 Hz steps: 70->71 up, 64->63 down; with these
    2 Hz steps the up jump, 108 -> 80 m/s^2, is 2.9 times its neighbouring step)."""
    r = SteppedSine(
        cfg,
        {
            "frequencies": list(np.arange(57.0, 79.001, 2.0)),
            "force": 15.0,
            "gap": 7e-4,
            "direction": "both",
            "record_periods": 10,
        },
        tmp_path / "j.h5",
        backend="sim",
        seed=1,
    ).run()
    up, down = r.summary["jumps"]["up"], r.summary["jumps"]["down"]
    assert len(up) == 1 and len(down) == 1
    # the shroud accelerations say why: the impacts end on the way up and begin on the way down
    assert up[0]["evidence"] == "contact vanishes" and down[0]["evidence"] == "contact appears"
    assert up[0]["from_hz"] < up[0]["to_hz"] and down[0]["from_hz"] > down[0]["to_hz"]
    assert up[0]["frequency_hz"] > down[0]["frequency_hz"] + 2  # hysteresis
    assert all(abs(p.force_amplitude_measured / 15.0 - 1) <= 0.01 for p in r.points)


def test_detect_jumps_needs_evidence_beyond_the_change():
    """A big step is a jump only with evidence the rig is not linear across it: the steep flank
    of a resonance in contact is not (its neighbours change as much); the same 35 % drop is a
    jump when the contact vanishes across it or when it stands out in contact, and never when
    the shrouds touch on neither side or the contact is unknown (one direction)."""
    f = [55, 56, 57, 58, 59, 60]
    steep = [223.0, 150.8, 114.3, 95.4, 89.8, 80.1]
    assert detect_jumps(f, steep, 0.25, contact=[True] * 6) == []
    jump = [100.0, 104.0, 108.0, 70.0, 68.0, 66.0]
    vanishes = detect_jumps(f, jump, 0.25, contact=[True, True, True, False, False, False])
    assert [(j["from_hz"], j["to_hz"], j["evidence"]) for j in vanishes] == [(57, 58, "contact vanishes")]
    (in_contact,) = detect_jumps(f, jump, 0.25, contact=[True] * 6)
    assert in_contact["evidence"] == "discontinuity in contact"
    assert detect_jumps(f, jump, 0.25, contact=[False] * 6) == []
    assert detect_jumps(f, jump, 0.25) == []


def test_linear_stepped_sine_in_coarse_steps_reports_no_jump(cfg, tmp_path):
    """The issue's case: 2 N, gap 5 mm (no impacts), 340-380 Hz in 10 Hz steps across the
    second flexural mode: the response more than doubles from 340 to 350 Hz (the resonance
    passes between the steps) and falls by 60 % from 360 to 370 Hz, yet the shrouds never touch:
    no jump (the old rule called 340 -> 350 Hz one)."""
    r = SteppedSine(
        cfg,
        {"frequencies": [340.0, 350.0, 360.0, 370.0, 380.0], "force": 2.0, "gap": WIDE, "record_periods": 30},
        tmp_path / "lin.h5",
        backend="sim",
        seed=1,
    ).run()
    amp = [p.extra["response_per_newton"] for p in r.points]
    assert amp[1] / amp[0] > 2.0 and amp[2] / amp[3] > 2.0  # steps a threshold of 0.3 sees
    assert r.summary["jumps"] == {"up": []}


def test_stop_request_from_a_script_ramps_down_and_keeps_the_data(cfg, tmp_path):
    """stop() at the first control update: status aborted, the drive ramped to exactly 0 V over
    the abort ramp (50 ms) after the two queued blocks, everything recorded kept: the record
    ends at most 0.4 s (simulated) after the request (the block in progress, two queued
    blocks, the ramp and the DAQ delay within one more block)."""
    out = tmp_path / "stop.h5"
    proc = SineDwell(cfg, {"fe": 60.0, "force": 15.0, "gap": 5e-4}, out, backend="sim", seed=1)
    stop_at = []

    def progress(event):
        if event.kind == "control" and not stop_at:
            stop_at.append(proc.session.sink.total)
            proc.stop("stop requested by the lab script")

    proc._progress = progress
    r = proc.run()
    assert r.status is Status.ABORTED and r.reason == "stop requested by the lab script"
    with open_recording(out) as rec:
        assert rec.status == "aborted" and rec.abort_reason == "aborted: stop requested by the lab script"
        p = rec.points[0]
        drive = np.asarray(p["drive"])
        assert drive[-1] == 0.0 and p.n_samples >= stop_at[0]
        assert (p.n_samples - stop_at[0]) / RATE <= 0.4 + 1e-9
        moving = np.flatnonzero(np.abs(drive) > 1e-9)
        assert moving[-1] + 1 < p.n_samples  # it ends at rest, recorded


def test_safety_abort_during_the_ramp_keeps_the_peak_and_the_ramp(cfg, tmp_path):
    """A force abort limit of 3 N trips during the first ramp (target force 15 N): status
    failed with the reason; the samples before it, the block holding the peak that tripped it
    and the recorded ramp to 0 V are kept (not 0 samples)."""
    import tomllib

    import tomli_w

    from rigtools.config import default_rig_text

    data = tomllib.loads(default_rig_text())
    data["safety"]["limits"]["force"] = {"warning": "2 N", "abort": "3 N"}
    rig = tmp_path / "low.toml"
    rig.write_text(tomli_w.dumps(data))
    low = load_rig(rig)
    out = tmp_path / "abort.h5"
    proc = SineDwell(
        low,
        {"fe": 60.0, "force": 15.0, "gap": 5e-4, "control": {"initial_drive": 1.0}},
        out,
        backend="sim",
        seed=1,
    )
    with pytest.raises(Exception) as info:
        proc.run()
    assert "safety abort" in str(info.value)
    with open_recording(out) as rec:
        assert rec.status == "aborted" and rec.abort_reason.startswith("failed: ")
        assert "force" in rec.abort_reason and rec.attrs["end_status"] == "failed"
        p = rec.points[0]
        force, drive = np.asarray(p["force"]), np.asarray(p["drive"])
        assert p.n_samples > 0 and np.max(np.abs(force)) >= 3.0
        assert drive[-1] == 0.0


def test_fault_mid_study_fails_with_the_reason_and_keeps_the_points_before(cfg, tmp_path):
    """A gap study 0.3-0.9 mm with an amplifier timeout injected at 5 s: status failed with the
    fault named, and every point completed before it valid and intact."""
    from rigtools.drivers.simulated import Fault

    out = tmp_path / "fault.h5"
    proc = RigStudy(
        cfg,
        {"kind": "gap", "values": [3e-4, 5e-4, 7e-4, 9e-4], "force": 15.0, "fe": 60.0, "record_periods": 12},
        out,
        backend="sim",
        seed=1,
        faults=[Fault("amplifier_timeout", at_time=5.0)],
    )
    with pytest.raises(Exception) as info:
        proc.run()
    assert "amplifier timeout" in str(info.value)
    done = proc.result.points
    assert 1 <= len(done) < 4
    with open_recording(out) as rec:
        assert rec.status == "aborted" and rec.abort_reason.startswith("failed: ")
        assert "amplifier timeout" in rec.abort_reason
        for i, res in enumerate(done):
            p = rec.points[i]
            assert p.ended and bool(p.params["point_complete"]) and p.params["gap"] == res["gap"]
            assert p.params["force_amplitude_measured"] == pytest.approx(15.0, rel=0.01)
            assert np.all(np.isfinite(np.asarray(p["force"])))
        assert not bool(rec.points[len(done)].params["point_complete"])


class _HandGapRig:
    """The simulated rig seen as the real one: no ``set_gap``; the 'operator' sets it."""

    def __init__(self, rig):
        self._rig = rig

    def __getattr__(self, name):
        if name == "set_gap":
            raise AttributeError(name)
        return getattr(self._rig, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._rig.close()


def test_real_rig_gap_study_asks_the_operator_with_the_drive_at_zero(cfg, tmp_path):
    """Without set_gap (the NI rig) the study ramps the drive to zero, asks for each gap (the
    callback, the CLI's prompt) and stores the gap asked for; the drive is at 0 V whenever the
    operator is asked, and each point still reaches its force."""
    from rigtools.drivers.simulated import SimulatedRig

    sim = SimulatedRig.from_config(cfg, seed=1)
    asked = []

    def operator(gap, index):
        asked.append((index, gap, sim.running))
        sim.set_gap(gap)

    out = tmp_path / "hand.h5"
    r = RigStudy(
        cfg,
        {"kind": "gap", "values": [4e-4, 8e-4], "force": 15.0, "fe": 60.0, "record_periods": 12},
        out,
        device=_HandGapRig(sim),
        confirm_gap=operator,
    ).run()
    assert r.status is Status.FINISHED
    assert [(i, g) for i, g, _ in asked] == [(0, 4e-4), (1, 8e-4)]
    assert all(not running for _, _, running in asked)  # asked with the stream stopped
    with open_recording(out) as rec:
        assert [p.params["gap"] for p in rec.points] == [4e-4, 8e-4]
        for p in rec.points:
            assert p.params["force_amplitude_measured"] == pytest.approx(15.0, rel=0.01)
            drive = np.asarray(p["drive"])
            assert abs(drive[0]) < 1e-6  # each point starts from rest


def test_simulation_diverging_mid_acquisition_is_a_fault(cfg, tmp_path):
    """Issue 8: rigtools.sim.vibro_impact.SimulationDivergedError raised by the simulated rig's physics
    mid-run (here the stepper is made to raise it from 0.5 s on, with the stepper's own message)
    is a fault: status failed with the reason, the drive ramped to exactly 0 V on a model at
    rest, everything read before kept, exit 4 (AcquisitionAborted)."""
    from rigtools.drivers.simulated import SimulatedRig
    from rigtools.sim.vibro_impact import SimulationDivergedError, diverged_message

    rig = SimulatedRig.from_config(cfg, seed=1)
    rig.configure(cfg.daq.input_specs(), cfg.daq.output_spec(), cfg.daq.sample_rate, cfg.daq.block_size())
    stepper = rig._physics._stepper
    real_advance = stepper.advance

    def advance(u, out):
        if stepper.time > 0.5:
            raise SimulationDivergedError(diverged_message(stepper.system, stepper.dt, stepper.time))
        return real_advance(u, out)

    stepper.advance = advance
    out = tmp_path / "div.h5"
    with pytest.raises(Exception) as info:
        SineDwell(cfg, {"fe": 60.0, "force": 15.0, "gap": 5e-4}, out, device=rig).run()
    assert getattr(info.value, "exit_code", None) == 4
    assert "simulation diverged" in str(info.value)
    with open_recording(out) as rec:
        assert rec.status == "aborted" and rec.abort_reason.startswith("failed: ")
        assert "simulation diverged" in rec.abort_reason and rec.attrs["end_status"] == "failed"
        p = rec.points[0]
        assert p.n_samples / RATE == pytest.approx(0.5, abs=0.05)
        assert np.all(np.isfinite(np.asarray(p["force"])))
    drive = rig.drive_log
    assert drive[-1] == 0.0 and not rig._running
    ramp = int(cfg.safety.abort_ramp_time * RATE)
    assert np.all(np.abs(np.diff(drive[-ramp - 50 :])) < 0.01)  # a ramp, not a step


def test_frf_test_cut_by_a_scripts_keyboard_interrupt_records_the_ramp_to_zero(tmp_path):
    """A KeyboardInterrupt raised by the script's own progress callback while the chirp plays
    (the 12th settling block, the drive at about 0.2 V): the drive's ramp to zero is recorded in
    the point it cut, as a signal's is (the file's last drive sample 0 V, exactly: the ramp ends
    on zeros), the file valid with status aborted, and ``rig info`` calls the point ``stopped``
    as the monitor does (it said ``complete``). Before the fix the point's drive stopped at
    -0.2 V (the device was zeroed, unrecorded)."""
    out = tmp_path / "frf.h5"
    seen: list[str] = []

    def stop(event) -> None:
        seen.append(event.kind)
        if len(seen) == 12:
            raise KeyboardInterrupt

    proc = FrfTest(
        load_rig(),
        {"signal": "chirp", "band": (20.0, 200.0), "level": 0.5, "frame": 1.0, "averages": 3},
        out,
        backend="sim",
        progress=stop,
    )
    with pytest.raises(KeyboardInterrupt):
        proc.run()
    assert check_recording(out).valid
    with open_recording(out) as rec:
        assert rec.status == "aborted"
        drive = rec.points[0]["drive"].read()
        assert np.max(np.abs(drive[:-2048])) > 0.1  # the chirp was playing when it was cut
        assert drive[-1] == 0.0
        assert summary(rec)["points"][0]["state"] == "stopped"
