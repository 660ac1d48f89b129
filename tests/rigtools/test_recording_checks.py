"""`rig check` on NaN samples and incomplete points; the reader and `rig info` stay light."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import h5py
import numpy as np

from rigtools.cli import main
from rigtools.recording import ChannelSpec, RecordingWriter, open_recording
from rigtools.recording.writer import LIBVER

CHANNELS = [ChannelSpec("force", "N", "force", 1000.0), ChannelSpec("acc", "m/s^2", "acceleration", 1000.0)]


def _write(path, block):
    with RecordingWriter(path, backend="simulated", rig="{}") as rec:
        point = rec.begin_point({"fe": 60.0}, CHANNELS)
        point.append(block)
    return path


def test_nan_in_a_complete_file_is_an_error(tmp_path, capsys):
    block = np.ones((2, 1000))
    block[1, 10:13] = np.nan
    block[0, 999] = np.inf
    path = _write(tmp_path / "nan.h5", block)
    assert main(["check", str(path)]) == 1
    out = capsys.readouterr().out
    assert "INVALID" in out
    assert "/points/0000/acc: 3 samples NaN or infinite" in out
    assert "/points/0000/force: 1 sample NaN or infinite" in out
    assert main(["check", "--quick", str(path)]) == 0  # --quick reads no samples
    clean = _write(tmp_path / "clean.h5", np.ones((2, 1000)))
    assert main(["check", str(clean)]) == 0


def _kill_mid_point(path, tail_nan: int, inner_nan: bool = False):
    """A file whose writer died mid-point: point 0 ended, point 1 open, its last samples NaN."""
    with RecordingWriter(path, backend="simulated", rig="{}", compression="none") as rec:
        p0 = rec.begin_point({"fe": 60.0}, CHANNELS)
        p0.append(np.ones((2, 100)))
        p0.set_attrs(settled=True)
        p0.end()
        rec.begin_point({"fe": 61.0}, CHANNELS).append(np.ones((2, 100)))
    with h5py.File(path, "r+", libver=LIBVER) as f:  # as if killed: point 1 never ended
        f.attrs["status"] = "recording"
        f.attrs["ended"] = ""
        f["points/0001"].attrs["end_time"] = ""
        for name in ("force", "acc"):
            ds = f[f"points/0001/{name}"]
            ds.resize((100 + tail_nan,))  # extent grew, samples never written
            if inner_nan:
                ds[50] = np.nan
    return path


def test_point_cut_off_is_incomplete_and_its_nan_tail_only_noted(tmp_path, capsys):
    path = _kill_mid_point(tmp_path / "killed.h5", tail_nan=30)
    with open_recording(path) as rec:
        assert [p.complete for p in rec.points] == [True, False]
        assert [p.index for p in rec.complete_points] == [0]
        assert rec.points[0].params["settled"] is True
        assert np.isnan(rec.points[1]["force"][100:]).all()
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "last 30 samples are NaN: not flushed" in out and "stopped without closing" in out
    assert main(["info", "--json", str(path)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert [p["state"] for p in info["points"]] == ["complete", "incomplete"]
    assert [p["complete"] for p in info["points"]] == [True, False]
    assert main(["info", str(path)]) == 0
    assert "incomplete" in capsys.readouterr().out


def test_nan_before_the_unflushed_tail_is_an_error(tmp_path, capsys):
    path = _kill_mid_point(tmp_path / "inner.h5", tail_nan=5, inner_nan=True)
    assert main(["check", str(path)]) == 1
    assert "1 sample NaN or infinite before the unflushed tail" in capsys.readouterr().out


def test_reader_and_info_do_not_import_scipy(tmp_path):
    path = _write(tmp_path / "light.h5", np.ones((2, 100)))
    code = textwrap.dedent(f"""
        import argparse, sys
        from rigtools.recording import open_recording, check_recording
        from rigtools.commands import info, check
        from rigtools.recording.summary import summary
        with open_recording({str(path)!r}) as rec:
            summary(rec)
        info.run(argparse.Namespace(file={str(path)!r}, json=False))
        check.run(argparse.Namespace(file={str(path)!r}, json=False, quick=False))
        heavy = sorted(m for m in sys.modules if m.split(".")[0] in
                       ("scipy", "numba", "matplotlib", "nidaqmx", "pyvisa"))
        print("HEAVY", heavy)
    """)
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stderr
    assert "HEAVY []" in run.stdout


def test_info_json_into_a_closed_pipe_prints_no_traceback(tmp_path):
    path = tmp_path / "big.h5"
    with RecordingWriter(path, backend="simulated", rig="{}") as rec:
        point = rec.begin_point({"curve": np.arange(30000.0)}, CHANNELS)  # > 64 KiB of JSON
        point.append(np.ones((2, 10)))
    run = subprocess.run(
        f'"{sys.executable}" -m rigtools.cli info --json "{path}" | head -1',
        shell=True,
        capture_output=True,
        text=True,
        check=False,
    )
    assert run.stdout == "{\n"
    assert "Traceback" not in run.stderr and "BrokenPipe" not in run.stderr


def test_info_shows_numbers_to_four_digits_and_summarises_arrays():
    from rigtools.recording.summary import format_params, format_value

    assert format_value(0.123456789) == "0.1235"  # rigtools.readable.DIGITS, as every table
    assert format_value(list(range(100))) == "[100 values, 0 .. 99]"
    assert format_value([1.0, 2.5]) == "[1, 2.5]"
    assert format_params({"gap": 0.000512345, "fe": 60.000001, "settled": True}) == (
        "gap=0.5123 mm, fe=60 Hz, settled=yes"
    )
