"""``rig modal`` and ``rig harmonic`` through rigtools.cli.main: output shapes and one-line errors."""

import json
import tomllib

import numpy as np
import pytest
import tomli_w

from rigtools.cli import main
from rigtools.config import default_rig_text


def test_modal_json_shape(capsys):
    assert main(["modal", "--json", "--modes", "5"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert set(doc) == {"fem", "am"}
    for model in ("fem", "am"):
        assert set(doc[model]) == {"active", "passive"}
        for entries in doc[model].values():
            assert len(entries) == 5
            assert [e["mode"] for e in entries] == [1, 2, 3, 4, 5]
            assert all(set(e) == {"mode", "frequency_hz", "kind"} for e in entries)
            f = [e["frequency_hz"] for e in entries]
            assert f == sorted(f)
    assert {e["kind"] for e in doc["am"]["active"]} == {"flexural"}
    assert {e["kind"] for e in doc["fem"]["active"]} >= {"flexural", "torsional"}


def test_modal_table_pairs_flexural_modes(capsys):
    assert main(["modal"]) == 0
    out = capsys.readouterr().out
    assert "active blade" in out and "passive blade" in out and "diff %" in out
    assert "361.8" in out or "361.9" in out


def _write_rig(tmp_path, change):
    data = tomllib.loads(default_rig_text())
    change(data)
    path = tmp_path / "rig.toml"
    path.write_text(tomli_w.dumps(data))
    return str(path)


@pytest.mark.parametrize(
    "change, words",
    [
        (lambda d: d["blade"].__setitem__("thicknes", "3 mm"), ["unknown key", "blade.thicknes"]),
        (lambda d: d["blade"].__setitem__("thickness", "-3.2 mm"), ["blade.thickness", "-3.2 mm"]),
        (
            lambda d: d["force_sensor"].__setitem__("position", "200 mm"),
            ["force_sensor.position", "beyond the blade"],
        ),
    ],
)
@pytest.mark.parametrize("command", [["modal"], ["harmonic", "--out", "x.csv"]])
def test_bad_rig_file_gives_one_line_and_status_2(tmp_path, capsys, change, words, command):
    path = _write_rig(tmp_path, change)
    argv = [command[0], "--rig", path, *command[1:]]
    if command[0] == "harmonic":
        argv[-1] = str(tmp_path / "x.csv")
    assert main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"rig {command[0]}: error:")
    assert all(w in lines[0] for w in words), lines[0]
    assert "Traceback" not in captured.err and captured.out == ""


def test_missing_rig_file(capsys, tmp_path):
    assert main(["modal", "--rig", str(tmp_path / "nope.toml")]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_harmonic_writes_csv_json_and_png(tmp_path, capsys):
    out = tmp_path / "curves.csv"
    assert main(["harmonic", "--out", str(out), "--points", "40", "--fmin", "300", "--fmax", "420 Hz"]) == 0
    assert (tmp_path / "curves.png").stat().st_size > 10_000
    header = out.read_text().splitlines()[0].split(",")
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (40, 17) and header[0] == "frequency_hz"
    assert (
        "fem_active_shroud_acceleration_m_s2" in header and "am_passive_force_point_displacement_m" in header
    )
    f = data[:, 0]
    acc = data[:, header.index("fem_active_shroud_acceleration_m_s2")]
    disp = data[:, header.index("fem_active_shroud_displacement_m")]
    assert acc == pytest.approx((2 * np.pi * f) ** 2 * disp, rel=1e-6)
    js = tmp_path / "curves.json"
    assert main(["harmonic", "--out", str(js), "--points", "10", "--force", "10 N"]) == 0
    doc = json.loads(js.read_text())
    assert doc["force_amplitude_n"] == 10.0 and len(doc["am"]["active_shroud"]["acceleration_m_s2"]) == 10


@pytest.mark.parametrize(
    "extra",
    [
        ["--out", "x.txt"],
        ["--force", "-5"],
        ["--force", "3 m"],
        ["--fmin", "500", "--fmax", "100"],
        ["--points", "1"],
    ],
)
def test_harmonic_bad_options(tmp_path, capsys, extra):
    argv = ["harmonic", "--out", str(tmp_path / "c.csv"), *extra]
    if extra[0] == "--out":
        argv = ["harmonic", "--out", str(tmp_path / extra[1])]
    assert main(argv) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
