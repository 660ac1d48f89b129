"""``rig simulate`` and ``rig study`` through rigtools.cli.main: JSON shape, the recorded file,
and one-line refusals of invalid physical input (exit 2)."""

import json

import numpy as np
import pytest

from analysis.harmonics import harmonic_amplitudes
from rigtools.cli import main
from rigtools.recording import open_recording

FAST = ["--duration", "0.1 s", "--max-settle", "4 s"]


def assert_png(path, width, height):
    """A non-empty PNG (signature bytes) that decodes to width x height pixels."""
    from matplotlib.image import imread

    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert imread(path).shape[:2] == (height, width)


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """One default run (fe 60 Hz, 15 N, gap 0.5 mm) with --json, and its file."""
    import contextlib
    import io

    out = tmp_path_factory.mktemp("sim") / "run.h5"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(["simulate", "--fe", "60", "--force", "15", "--gap", "0.5 mm", "--out", str(out), "--json", *FAST])
    return code, json.loads(buf.getvalue()), out


def test_simulate_json_shape(simulated):
    code, doc, _ = simulated
    assert code == 0
    assert set(doc) == {"harmonics", "contact", "steady_state", "plot"}
    assert doc["steady_state"] is True
    assert set(doc["contact"]) == {"peak_force_n", "impacts_per_period"}
    assert doc["contact"]["peak_force_n"] > 10 and doc["contact"]["impacts_per_period"] == 1
    assert {"active_shroud_accel", "passive_shroud_accel", "force"} <= set(doc["harmonics"])
    for rows in doc["harmonics"].values():
        assert [r["k"] for r in rows] == list(range(1, 31))
        assert all(set(r) == {"k", "frequency_hz", "amplitude"} for r in rows)
        assert rows[5]["frequency_hz"] == pytest.approx(360.0)
    assert doc["harmonics"]["force"][0]["amplitude"] == pytest.approx(15.0, rel=1e-9)


def test_simulate_writes_the_plot_beside_the_file(simulated):
    """12 x 9 in at 100 dpi (rigtools.figures.DPI)."""
    _, doc, out = simulated
    assert doc["plot"] == str(out.with_suffix(".png"))
    assert_png(out.with_suffix(".png"), 1200, 900)


def test_simulate_file_holds_the_run(simulated):
    """The recorded channels reproduce the JSON: the fundamental of the recorded active shroud
    acceleration equals the reported one (0.5 %: point samples vs the velocity route)."""
    _, doc, out = simulated
    with open_recording(out) as rec:
        assert rec.backend == "fem" and rec.status == "complete" and len(rec.points) == 1
        p = rec.points[0]
        assert p.params["fe"] == 60.0 and p.params["gap"] == pytest.approx(5e-4)
        assert p.params["settled"] is True or p.params["settled"] == 1
        for name, units in (("active_shroud_accel", "m/s^2"), ("passive_shroud_accel", "m/s^2"), ("force", "N"),
                            ("contact_force", "N"), ("active_shroud_disp", "m"), ("passive_shroud_vel", "m/s")):
            assert p.channels[name].units == units
        a = np.asarray(p["active_shroud_accel"])
        fs = p.sample_rate
        assert len(a) == round(0.1 * fs)
        fit = harmonic_amplitudes(a, fs, 60.0, 10)
        assert fit.at(1) == pytest.approx(doc["harmonics"]["active_shroud_accel"][0]["amplitude"], rel=5e-3)
        assert np.max(p["contact_force"][:]) == pytest.approx(doc["contact"]["peak_force_n"])


@pytest.mark.parametrize("argv, needle", [
    (["--gap", "-0.2 mm"], "gap"),
    (["--force", "-5"], "force"),
    (["--fe", "0"], "frequency"),
    (["--duration", "10 ms"], "shorter than one excitation period"),
    (["--steps-per-period", "150"], "too coarse for the contact stiffness"),
    (["--gap", "half a mm"], "--gap"),
])
def test_simulate_refuses_invalid_input_with_one_line(tmp_path, capsys, argv, needle):
    code = main(["simulate", "--out", str(tmp_path / "x.h5"), *argv])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("rig simulate: error:") and needle in err and err.count("\n") == 1
    assert not (tmp_path / "x.h5").exists()


def test_simulate_refuses_to_overwrite(simulated, capsys):
    _, _, out = simulated
    assert main(["simulate", "--out", str(out), *FAST]) == 2
    assert "--overwrite" in capsys.readouterr().err


def test_study_writes_one_point_per_value(tmp_path, capsys):
    out = tmp_path / "gap.h5"
    code = main(["study", "gap", "--values", "0.3 mm:0.5 mm:0.2 mm", "--out", str(out), "--json", *FAST])
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["kind"] == "gap" and doc["fixed"] == {"fe": 60.0, "force": 15.0}
    assert [p["value"] for p in doc["points"]] == pytest.approx([3e-4, 5e-4])
    with open_recording(out) as rec:
        assert [p.params["gap"] for p in rec.points] == pytest.approx([3e-4, 5e-4])
        assert rec.experiment["procedure"] == "gap study"
        assert [pt["peak_contact_force_n"] for pt in doc["points"]] == pytest.approx(
            [float(np.max(p["contact_force"][:])) for p in rec.points])
    assert doc["plot"] == str(tmp_path / "gap.png")
    assert_png(tmp_path / "gap.png", 1100, 1000)     # 11 x (3.6 + 2 x 3.2) in at 100 dpi


def test_study_both_directions_and_bad_values(tmp_path, capsys):
    out = tmp_path / "f.h5"
    assert main(["study", "frequency", "--values", "60 Hz,75 Hz", "--direction", "both", "--out", str(out),
                 "--json", "--no-plot", *FAST]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["plot"] is None and not (tmp_path / "f.png").exists()
    assert [(p["value"], p["direction"]) for p in doc["points"]] == [(60.0, "up"), (75.0, "up"), (60.0, "down")]
    assert main(["study", "gap", "--values", "0.3,0.5", "--out", str(tmp_path / "g.h5")]) == 2
    assert "units" in capsys.readouterr().err
    assert main(["study", "frequency", "--values", "-5 Hz", "--out", str(tmp_path / "g.h5")]) == 2
    assert "frequencies must be > 0" in capsys.readouterr().err
