"""``rig acquire dwell|sweep|study|frf`` through rigtools.cli.main on the simulated rig: the
force-controlled dwell's recording and JSON, the force it holds against the shaker closed form,
injected faults (exit 4, file kept, status failed), the missing NI-DAQmx driver (exit 3, one
line offering --backend sim) and one-line refusals of bad input (exit 2)."""

import json
import tomllib

import numpy as np
import pytest
import tomli_w
from cli_helpers import acquire_dwell, acquire_frf, run_cli

from rigtools.cli import main
from rigtools.config import default_rig_text, load_rig
from rigtools.recording import check_recording, open_recording

RATE = 51200.0  # [daq] sample_rate of the default rig
DWELL = acquire_dwell(periods=12)


@pytest.fixture(scope="module")
def dwell(sim_recording):
    """The default rig (impacts at 0.5 mm), 15 N at 60 Hz, 12 periods recorded, --json (the
    session's shared recording: test_cli_report.py reads it too)."""
    path = sim_recording([*DWELL, "--json"], "dwell.h5")
    out, err = sim_recording.output(path)
    return 0, json.loads(out) if out else None, err, path


def test_dwell_holds_15_newtons_and_writes_a_complete_recording(dwell):
    code, doc, err, path = dwell
    assert code == 0 and err == ""
    assert doc["status"] == "finished" and doc["backend"] == "sim"
    # the fundamental of the force channel, within 1 % of F0, in at most 10 updates
    assert doc["force_amplitude_measured"] == pytest.approx(15.0, rel=0.01)
    assert doc["force_amplitude"] == 15.0 and 1 <= doc["control_updates"] <= 10
    assert doc["settled"] is True and doc["warnings"] == 0
    assert check_recording(path).valid
    cfg = load_rig()
    with open_recording(path) as rec:
        assert rec.status == "complete" and rec.backend == "simulated" and len(rec.points) == 1
        assert rec.experiment["procedure"] == "sine dwell"
        assert rec.attrs["end_status"] == "finished"
        p = rec.points[0]
        assert p.params["fe"] == 60.0 and p.params["force_amplitude"] == 15.0
        assert p.params["gap"] == pytest.approx(5e-4)
        assert p.params["force_amplitude_measured"] == pytest.approx(
            doc["force_amplitude_measured"], rel=1e-12
        )
        assert p.params["drive_amplitude"] == pytest.approx(doc["drive_amplitude"], rel=1e-12)
        assert list(p.channels) == [*(s.name for s in cfg.daq.input_specs()), "drive"]
        start, n = round(p.params["record_start"] * RATE), int(p.params["record_samples"])
        assert n == round(12 * RATE / 60)
        # the record window, refitted from the file, gives the reported fundamental
        from rigtools.analysis.harmonics import harmonic_amplitudes

        force = p["force"][start : start + n]
        assert harmonic_amplitudes(force, RATE, 60.0, 1).at(1) == pytest.approx(
            doc["force_amplitude_measured"], rel=1e-9
        )
        drive = np.asarray(p["drive"])
        # the whole stream is kept: the ramp up from 0 V, and the ramp down to exactly 0 V at the end
        assert drive[0] == pytest.approx(0.0, abs=1e-6) and drive[-1] == 0.0
        assert np.max(np.abs(drive[-500:])) < 1e-9


def test_dwell_json_harmonics(dwell):
    _, doc, _, _ = dwell
    assert set(doc["channels"]) == {"force", "active_shroud_accel", "passive_shroud_accel", "drive"}
    for ch in doc["channels"].values():
        assert [h["k"] for h in ch["harmonics"]] == list(range(1, 11))
    # phases are relative to the force fundamental: the force's own k = 1 phase is 0
    assert doc["channels"]["force"]["harmonics"][0]["phase"] == pytest.approx(0.0, abs=1e-12)
    # the drive written is a pure sine: nothing at k >= 2
    h = doc["channels"]["drive"]["harmonics"]
    assert max(r["amplitude"] for r in h[1:]) < 1e-9 * h[0]["amplitude"]
    # impacts at the 0.5 mm gap: harmonics in the shroud accelerations
    acc = doc["channels"]["passive_shroud_accel"]["harmonics"]
    assert max(r["amplitude"] for r in acc[1:]) > 0.1 * acc[0]["amplitude"]


def _linear_rig(tmp_path, **safety):
    """The default rig with a 50 mm gap (no impacts: linear) and optional [safety] changes."""
    data = tomllib.loads(default_rig_text())
    data["contact"]["gap"] = "50 mm"
    data["safety"].update(safety)
    rig = tmp_path / "linear.toml"
    rig.write_text(tomli_w.dumps(data))
    return rig


def test_held_force_needs_the_drive_of_the_shaker_closed_form(tmp_path):
    """No impacts (gap 50 mm): the drive the controller settles on for 2 N at 60 Hz equals
    2 N over the closed-form sensor force per volt of rigtools.drivers.shaker (the shaker coupled to the
    test article's active blade, all FE modes, the IEPE high-pass) within 0.6 % (the 0.5 %
    control tolerance plus the simulated rig's reduced model)."""
    from rigtools.sim.modal import blade_modes
    from rigtools.sim.rig_model import build_rig_model

    rig = _linear_rig(tmp_path)
    code, text, err = run_cli(
        [
            "acquire",
            "dwell",
            "--rig",
            str(rig),
            "--backend",
            "sim",
            "--seed",
            "2",
            "--fe",
            "60",
            "--force",
            "2 N",
            "--periods",
            "12",
            "--out",
            str(tmp_path / "linear.h5"),
            "--json",
        ]
    )
    assert code == 0, err
    doc = json.loads(text)
    cfg = load_rig(rig)
    ta = cfg.test_article.to_params()
    model = build_rig_model(ta.apply(cfg.to_params()))
    modes = blade_modes(model.active)
    w, wn = 2 * np.pi * 60.0, modes.omegas
    receptance = np.sum(modes.shapes[model.force_dof] ** 2 / (wn**2 - w**2 + 2j * ta.damping_ratio * wn * w))
    highpass = 1j * w / (1j * w + 2 * np.pi * ta.iepe_highpass)
    per_volt = abs(cfg.shaker.to_params().sensor_force_per_drive(60.0, receptance) * highpass)
    assert doc["drive_amplitude"] == pytest.approx(doc["force_amplitude_measured"] / per_volt, rel=0.006)
    assert doc["force_amplitude_measured"] == pytest.approx(2.0, rel=0.01)
    h = doc["channels"]["force"]["harmonics"]
    assert max(r["amplitude"] for r in h[1:]) < 2e-3 * h[0]["amplitude"]


def test_injected_fault_exits_4_names_it_and_keeps_the_data_before_it(tmp_path):
    """An input overflow at t = 0.3 s, during the first ramp: exit 4, one line naming the fault,
    the file kept with status failed and the samples up to the fault (not 0)."""
    out = tmp_path / "fault.h5"
    code, text, err = run_cli([*DWELL, "--out", str(out), "--fault", "input-overflow@0.3 s"])
    assert code == 4 and text == ""
    assert err.count("\n") == 1 and "input overflow" in err
    with open_recording(out) as rec:
        assert rec.status == "aborted" and rec.abort_reason.startswith("failed: ")
        assert "input overflow" in rec.abort_reason and rec.attrs["end_status"] == "failed"
        assert rec.points[0].n_samples == round(0.3 * RATE)


def test_without_the_ni_driver_exit_3_in_one_line(tmp_path):
    import nidaqmx
    from nidaqmx.errors import DaqNotFoundError, DaqNotSupportedError

    try:
        _ = nidaqmx.system.System.local().driver_version  # raises without the NI driver
    except (DaqNotFoundError, DaqNotSupportedError):
        pass
    else:  # pragma: no cover - only on a machine with NI-DAQmx
        pytest.skip("NI-DAQmx is installed here")
    out = tmp_path / "hw.h5"
    code, text, err = run_cli(["acquire", "dwell", "--fe", "60", "--force", "15 N", "--out", str(out)])
    assert code == 3 and text == "" and err.count("\n") == 1
    assert "NI-DAQmx driver not found" in err and "--backend sim" in err
    assert not out.exists()


@pytest.mark.parametrize(
    "change, message",
    [
        (["--force", "-1 N"], "force"),
        (["--force", "1 V"], "is a voltage, expected a force"),
        (["--fe", "0"], "fe"),
        (["--fe", "30 kHz"], "fe"),
        (["--gap", "5 m"], "gap"),
        (["--periods", "0"], "--periods = 0"),  # was "record_periods": the Python name, not the option
        (["--max-updates", "0"], "--max-updates"),
        (["--fault", "melt@1"], "unknown kind 'melt'"),
    ],
)
def test_bad_input_exit_2_in_one_line(tmp_path, change, message):
    argv = [*DWELL, *change, "--out", str(tmp_path / "x.h5")]
    code, text, err = run_cli(argv)
    assert code == 2 and text == "" and err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "x.h5").exists()


def test_fault_needs_the_simulated_rig(tmp_path):
    code, _, err = run_cli(
        [
            "acquire",
            "dwell",
            "--fe",
            "60",
            "--force",
            "1 N",
            "--out",
            str(tmp_path / "u.h5"),
            "--fault",
            "input-overflow@1",
        ]
    )
    assert code == 2 and err.count("\n") == 1 and "--backend sim" in err


def test_existing_file_needs_overwrite(tmp_path):
    out = tmp_path / "old.h5"
    out.write_bytes(b"keep me")
    code, _, err = run_cli([*DWELL, "--out", str(out)])
    assert code == 2 and err.count("\n") == 1 and "--overwrite" in err
    assert out.read_bytes() == b"keep me"


@pytest.mark.parametrize("proc", ["dwell", "sweep", "study", "frf"])
def test_help_teaches_units_examples_and_exit_codes(capsys, proc):
    with pytest.raises(SystemExit):
        main(["acquire", proc, "--help"])
    text = capsys.readouterr().out
    for needle in ("examples:", "Exit status", "3 NI-DAQmx", "--backend sim", "abort_ramp_time", '"15 N"'):
        assert needle in text


def test_frf_prints_the_h1_peaks_with_their_coherence(tmp_path):
    """Periodic chirp 20-500 Hz, gap 5 mm (no impacts): the H1 peaks of the active shroud over
    the force lie at the test article's first two flexural frequencies (FE with the
    [test_article] deviations: 52.0 and 355.6 Hz) within one 2 Hz line, coherence > 0.99."""
    from rigtools.sim.modal import blade_modes
    from rigtools.sim.rig_model import build_rig_model

    out = tmp_path / "frf.h5"
    code, text, err = run_cli(
        [
            *acquire_frf("chirp", band="20 Hz:500 Hz", averages=4, seed=1),
            "--gap",
            "5 mm",
            "--out",
            str(out),
            "--json",
        ]
    )
    assert code == 0, err
    doc = json.loads(text)
    assert doc["status"] == "finished" and check_recording(out).valid
    cfg = load_rig()
    ta = cfg.test_article.to_params()
    modes = blade_modes(build_rig_model(ta.apply(cfg.to_params())).active, 6)
    flex = modes.frequencies_hz[np.array(modes.kinds) == "flexural"][:2]
    peaks = sorted(doc["check"]["peaks"], key=lambda p: -p["h1"])[:2]
    for f, pk in zip(flex, sorted(peaks, key=lambda p: p["frequency_hz"]), strict=True):
        assert abs(pk["frequency_hz"] - f) <= 2.0 and pk["coherence"] > 0.99
    # no peak at the excited band's edges (two 2 Hz lines kept clear of 20 and 500 Hz); |H1| has its unit
    assert all(22.0 <= pk["frequency_hz"] <= 498.0 for pk in doc["check"]["peaks"]), doc["check"]["peaks"]
    assert doc["check"]["h1_units"] == "(m/s^2)/(N)"
    with open_recording(out) as rec:
        p = rec.points[0]
        assert p.params["frame_samples"] == round(0.5 * RATE) and p.params["averages"] == 4
        assert np.asarray(p["drive"])[-1] == 0.0


def test_frf_help_has_no_force_control_and_shows_defaults(capsys):
    """An FRF test is not force-controlled: its help says nothing of force control, and every
    option with a default shows it."""
    with pytest.raises(SystemExit):
        main(["acquire", "frf", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "Force control" not in text and "--max-updates" not in text
    for shown in ("(default chirp)", 'default "1 s"', "(default 10)", "TIME s from the start"):
        assert shown in text, shown
    with pytest.raises(SystemExit):
        main(["acquire", "dwell", "--help"])
    assert "Force control" in capsys.readouterr().out


def test_sweep_json_and_resume_refusals(tmp_path):
    out = tmp_path / "sw.h5"
    code, text, err = run_cli(
        [
            "acquire",
            "sweep",
            "--backend",
            "sim",
            "--seed",
            "1",
            "--frequencies",
            "100 Hz:104 Hz:2 Hz",
            "--force",
            "2 N",
            "--gap",
            "5 mm",
            "--periods",
            "20",
            "--out",
            str(out),
            "--json",
        ]
    )
    assert code == 0, err
    doc = json.loads(text)
    assert [p["fe"] for p in doc["points"]] == [100.0, 102.0, 104.0]
    assert all(abs(p["force_amplitude_measured"] / 2.0 - 1) <= 0.01 for p in doc["points"])
    assert doc["jumps"] == {"up": []}
    study = ["acquire", "study", "gap", "--backend", "sim", "--values", "0.3 mm,0.5 mm", "--resume"]
    code, _, err = run_cli([*study, "--out", tmp_path / "none.h5"])
    assert code == 2 and err.count("\n") == 1 and "does not exist" in err
    code, _, err = run_cli([*study, "--out", out, "--yes"])
    assert code == 2 and err.count("\n") == 1 and "different study" in err
    with open_recording(out) as rec:  # the sweep's file is untouched
        assert rec.status == "complete" and len(rec.points) == 3
