"""``rig acquire`` through rigtools.cli.main on the simulated rig: the recording it writes, the
force it measures against the closed form of shaker + blade, injected faults (exit 4, file kept
as "aborted"), the missing NI-DAQmx driver (exit 3) and one-line refusals of bad input (exit 2)."""

import contextlib
import io
import json
import tomllib

import numpy as np
import pytest
import tomli_w

from rigtools.cli import main
from rigtools.config import default_rig_text, load_rig
from rigtools.recording import open_recording
from sim.modal import blade_modes
from sim.rig_model import build_rig_model

RATE = 51200.0                     # [daq] sample_rate of the default rig
DWELL = ["--simulated", "--seed", "1", "--fe", "60", "--drive", "1 V", "--duration", "1",
         "--settle", "0.2"]
# recording starts after the ramp (0.5 s), the settle (0.2 s) and the simulated DAQ delay (0.8 ms)
START = int(np.ceil((0.5 + 0.2 + 8e-4) * RATE - 1e-9))


def run_cli(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def dwell(tmp_path_factory):
    """The default rig (impacts at 0.5 mm), 1 V at 60 Hz, 1 s recorded, --json."""
    path = tmp_path_factory.mktemp("acq") / "run.h5"
    code, out, err = run_cli(["acquire", *DWELL, "--out", str(path), "--json"])
    return code, json.loads(out) if out else None, err, path


def test_dwell_writes_a_complete_recording(dwell):
    code, doc, err, path = dwell
    assert code == 0 and err == ""
    cfg = load_rig()
    specs = {s.name: s for s in cfg.daq.input_specs()}
    with open_recording(path) as rec:
        assert rec.status == "complete" and rec.backend == "simulated" and len(rec.points) == 1
        assert rec.experiment["procedure"] == "sine dwell"
        p = rec.points[0]
        assert p.params["fe"] == 60.0 and p.params["drive_amplitude"] == 1.0
        assert p.params["gap"] == pytest.approx(5e-4)
        assert p.params["record_start"] == pytest.approx(START / RATE)
        assert p.params["measured_force_amplitude"] == pytest.approx(doc["measured_force_amplitude_n"], rel=1e-12)
        assert bool(p.params["settled"]) is doc["settled"] is True
        assert list(p.channels) == [*specs, "drive"]
        for name, spec in specs.items():
            ch = p.channels[name]
            assert (ch.units, ch.quantity, ch.sample_rate) == (spec.units, spec.quantity, RATE)
            assert (ch.sensitivity, ch.physical_channel, ch.location) == (
                spec.sensitivity, spec.physical_channel, spec.location)
            assert len(ch) == round(1.0 * RATE)             # duration x rate
        drive = np.asarray(p["drive"])
        # recorded after the ramp: the drive is the full 1 V sine (peak of 853 samples/period)
        assert np.max(np.abs(drive)) == pytest.approx(1.0, abs=1e-4) and len(drive) == round(RATE)
        force = np.asarray(p["force"])
        assert np.all(np.isfinite(force)) and np.max(np.abs(force)) == pytest.approx(doc["channels"]["force"]["peak"])


def test_dwell_writes_the_plot_beside_the_file(dwell):
    """Four channel rows: 12 x (2.4 x 4 + 1) in at 100 dpi (rigtools.figures.DPI)."""
    from matplotlib.image import imread

    _, doc, _, path = dwell
    png = path.with_suffix(".png")
    assert doc["plot"] == str(png)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert imread(png).shape[:2] == (1060, 1200)


def test_dwell_json_shape(dwell):
    _, doc, _, path = dwell
    assert {"file", "backend", "fe", "measured_force_amplitude_n", "channels", "status"} <= set(doc)
    assert doc["file"] == str(path) and doc["backend"] == "simulated" and doc["status"] == "complete"
    assert doc["fe"] == 60.0 and doc["sample_rate"] == RATE and doc["duration_s"] == 1.0
    assert set(doc["channels"]) == {"force", "active_shroud_accel", "passive_shroud_accel", "drive"}
    for ch in doc["channels"].values():
        assert set(ch) == {"units", "peak", "harmonics"}
        assert [h["k"] for h in ch["harmonics"]] == list(range(1, 31))
        assert ch["harmonics"][4]["frequency_hz"] == pytest.approx(300.0)
    # the drive written is a pure 1 V sine: harmonic 1 exact, nothing at k >= 2
    h = doc["channels"]["drive"]["harmonics"]
    assert h[0]["amplitude"] == pytest.approx(1.0, rel=1e-9) and max(r["amplitude"] for r in h[1:]) < 1e-9
    # impacts at the 0.5 mm gap make harmonics of the shroud accelerations
    acc = doc["channels"]["passive_shroud_accel"]["harmonics"]
    assert max(r["amplitude"] for r in acc[1:]) > 0.1 * acc[0]["amplitude"]


def _closed_form_force(cfg, fe, drive):
    """Force amplitude through the sensor for a drive amplitude (V), closed form of
    ``drivers.shaker.ShakerParams.sensor_force_per_drive`` with the driving-point receptance of
    the test article's active blade summed over ALL its FE modes (modal damping ratio of
    [test_article]), times the IEPE high-pass of the force channel."""
    ta = cfg.test_article.to_params()
    model = build_rig_model(ta.apply(cfg.to_params()))
    modes = blade_modes(model.active)
    w, wn = 2 * np.pi * fe, modes.omegas
    receptance = np.sum(modes.shapes[model.force_dof] ** 2 / (wn**2 - w**2 + 2j * ta.damping_ratio * wn * w))
    highpass = 1j * w / (1j * w + 2 * np.pi * ta.iepe_highpass)
    return abs(cfg.shaker.to_params().sensor_force_per_drive(fe, receptance) * highpass) * drive


def _linear_rig(tmp_path, **safety):
    """The default rig with a 50 mm gap (no impacts: linear) and optional [safety] changes."""
    data = tomllib.loads(default_rig_text())
    data["contact"]["gap"] = "50 mm"
    data["safety"].update(safety)
    rig = tmp_path / "linear.toml"
    rig.write_text(tomli_w.dumps(data))
    return rig


def test_measured_force_matches_the_shaker_closed_form_without_impacts(tmp_path):
    """Gap 50 mm (no impacts, linear): the measured force amplitude at 60 Hz (15 % above the
    first flexural mode, where the force depends on the coupling) is within 0.5 % of the closed
    form (measured 0.03 %: the simulated rig keeps a reduced blade model and integrates with a
    first-order hold; sensor noise 5 mN rms adds ~1e-5 relative)."""
    rig = _linear_rig(tmp_path)
    code, text, err = run_cli(["acquire", "--rig", str(rig), "--simulated", "--seed", "2", "--fe", "60",
                               "--drive", "0.5 V", "--duration", "1", "--settle", "0.5",
                               "--out", str(tmp_path / "linear.h5"), "--json", "--no-plot"])
    assert code == 0, err
    doc = json.loads(text)
    assert doc["plot"] is None and not (tmp_path / "linear.png").exists()
    expected = _closed_form_force(load_rig(rig), 60.0, 0.5)
    assert doc["measured_force_amplitude_n"] == pytest.approx(expected, rel=0.005)
    assert doc["settled"] is True
    # linear: no harmonics above the noise in the force
    h = doc["channels"]["force"]["harmonics"]
    assert max(r["amplitude"] for r in h[1:]) < 2e-3 * h[0]["amplitude"]


def test_unsettled_response_is_reported(tmp_path):
    """A 10 ms ramp and no settling time: the blade's free vibration (zeta 1.2 %, decaying as
    e^-3.9t) is still in the record, so "settled" must be false (it is true above with 0.5 s)."""
    rig = _linear_rig(tmp_path, ramp_time="10 ms")
    code, text, err = run_cli(["acquire", "--rig", str(rig), "--simulated", "--seed", "2", "--fe", "60",
                               "--drive", "0.5 V", "--duration", "1", "--settle", "0",
                               "--out", str(tmp_path / "early.h5"), "--json"])
    assert code == 0, err
    assert json.loads(text)["settled"] is False
    with open_recording(tmp_path / "early.h5") as rec:
        assert bool(rec.points[0].params["settled"]) is False


def test_injected_fault_exits_4_names_it_and_keeps_the_data_before_it(dwell, tmp_path):
    """input overflow at t = 1.2 s (0.5 s into the recording): exit 4, one line naming the
    fault, the file "aborted" with exactly the samples before the fault, bit for bit those of
    the undisturbed run with the same seed."""
    _, _, _, clean_path = dwell
    out = tmp_path / "fault.h5"
    code, text, err = run_cli(["acquire", *DWELL, "--out", str(out), "--fault", "input-overflow@1.2 s"])
    assert code == 4 and text == ""
    assert err.count("\n") == 1 and err.startswith("rig acquire: error: input overflow: injected at t = 1.2000 s")
    kept = round(1.2 * RATE) - START
    assert f"{kept / RATE:.3f} s recorded" in err
    with open_recording(out) as rec, open_recording(clean_path) as clean:
        assert rec.status == "aborted" and "input overflow" in rec.abort_reason
        assert not out.with_suffix(".png").exists()        # no plot of an aborted run
        p = rec.points[0]
        assert p.n_samples == kept
        for name in ("force", "active_shroud_accel", "passive_shroud_accel", "drive"):
            np.testing.assert_array_equal(p[name][:], clean.points[0][name][:kept])


def test_fault_on_a_channel_and_unknown_faults(tmp_path):
    code, _, err = run_cli(["acquire", *DWELL, "--out", str(tmp_path / "n.h5"),
                            "--fault", "nan-samples@0.9:passive_shroud_accel"])
    assert code == 4 and err.count("\n") == 1 and "NaN samples on passive_shroud_accel" in err
    for fault, message in (("melt@1", "unknown kind 'melt'"), ("nan-samples", "write KIND@TIME"),
                           ("nan-samples@1:strain", "no input channel 'strain'")):
        code, _, err = run_cli(["acquire", *DWELL, "--out", str(tmp_path / "u.h5"), "--fault", fault])
        assert code == 2 and err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "u.h5").exists()
    code, _, err = run_cli(["acquire", "--fe", "60", "--drive", "1 V", "--duration", "1",
                            "--out", str(tmp_path / "u.h5"), "--fault", "input-overflow@1"])
    assert code == 2 and err.count("\n") == 1 and "add --simulated" in err


def test_without_the_ni_driver_exit_3_in_one_line(tmp_path):
    import nidaqmx
    from nidaqmx.errors import DaqNotFoundError, DaqNotSupportedError

    try:
        nidaqmx.system.System.local().driver_version
    except (DaqNotFoundError, DaqNotSupportedError):
        pass
    else:  # pragma: no cover - only on a machine with NI-DAQmx
        pytest.skip("NI-DAQmx is installed here")
    out = tmp_path / "hw.h5"
    code, text, err = run_cli(["acquire", "--fe", "60", "--drive", "1 V", "--duration", "1", "--out", str(out)])
    assert code == 3 and text == "" and err.count("\n") == 1
    assert "NI-DAQmx driver not found" in err and "--simulated" in err
    assert not out.exists()


@pytest.mark.parametrize("change, message", [
    (["--duration", "-1"], "--duration = '-1': must be > 0 s"),
    (["--duration", "10 ms"], "shorter than one excitation period"),
    (["--drive", "6 V"], "above the maximum drive 5 V"),
    (["--drive", "-1 V"], "must be > 0 V"),
    (["--drive", "1 N"], "is a force, expected a voltage"),
    (["--fe", "0"], "must be > 0 Hz"),
    (["--fe", "-60 Hz"], "must be > 0 Hz"),
    (["--fe", "30 kHz"], "below half the sample rate"),
    (["--settle", "-1 s"], "--settle"),
])
def test_bad_input_exit_2_in_one_line(tmp_path, change, message):
    args = dict(zip(DWELL[3::2], DWELL[4::2]))
    args.update(dict(zip(change[::2], change[1::2])))
    argv = ["acquire", "--simulated", *(x for kv in args.items() for x in kv), "--out", str(tmp_path / "x.h5")]
    code, text, err = run_cli(argv)
    assert code == 2 and text == "" and err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "x.h5").exists()


def test_existing_file_needs_overwrite(tmp_path):
    out = tmp_path / "old.h5"
    out.write_bytes(b"keep me")
    code, _, err = run_cli(["acquire", *DWELL, "--out", str(out)])
    assert code == 2 and err.count("\n") == 1 and "--overwrite" in err
    assert out.read_bytes() == b"keep me"


def test_help_teaches_units_examples_and_exit_codes(capsys):
    with pytest.raises(SystemExit):
        main(["acquire", "--help"])
    text = capsys.readouterr().out
    for needle in ('"1 V"', "max_drive", "examples:", "Exit status", "3 NI-DAQmx", "4 a fault",
                   "--fault", "abort_ramp_time"):
        assert needle in text
