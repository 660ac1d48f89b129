"""Bad recordings give one clear line (RecordingError), never a traceback; `rig check` exit codes.

Files are damaged on purpose: truncated at many offsets, another schema, a newer
schema_version, each required attribute removed in turn, a channel of the wrong shape, uneven
channel lengths, a killed writer outside SWMR mode (consistency flags set).
"""

from __future__ import annotations

import json
import subprocess
import sys

import h5py
import numpy as np
import pytest

from rigtools.cli import main
from rigtools.recording import ChannelSpec, RecordingError, RecordingWriter, open_recording
from rigtools.recording.schema import CHANNEL_ATTRS, POINT_ATTRS, ROOT_ATTRS
from rigtools.recording.superblock import consistency_flags


@pytest.fixture
def good(tmp_path):
    path = tmp_path / "good.h5"
    with RecordingWriter(path, backend="simulated", rig="{}", experiment={"a": 1}) as rec:
        for p in range(2):
            point = rec.begin_point(
                {"fe": 60.0 + p},
                [
                    ChannelSpec("force", "N", "force", 1000.0),
                    ChannelSpec("accel", "m/s^2", "acceleration", 1000.0),
                ],
            )
            point.append(np.ones((2, 3000)) * p)
            point.end()
    return path


def _copy(src, dst, edit=None):
    dst.write_bytes(src.read_bytes())
    if edit:
        with h5py.File(dst, "r+") as f:
            edit(f)
    return dst


def _one_line_error(path) -> str:
    with pytest.raises(RecordingError) as info:
        open_recording(path)
    message = str(info.value)
    assert "\n" not in message and str(path) in message
    return message


def _rig_check(path, capsys, *extra) -> tuple[int, str, str]:
    code = main(["check", *extra, str(path)])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def test_good_file_checks_valid(good, capsys):
    code, out, _ = _rig_check(good, capsys)
    assert code == 0 and "valid rigtools recording (status complete, 2 points, 2 channels)" in out
    code, out, _ = _rig_check(good, capsys, "--json")
    assert code == 0 and json.loads(out)["valid"] is True


def test_truncated_files(good, tmp_path, capsys):
    data = good.read_bytes()
    for cut in [0, 7, 48, 200, 1000, 4096, len(data) // 3, len(data) // 2, len(data) - 1]:
        path = tmp_path / f"cut{cut}.h5"
        path.write_bytes(data[:cut])
        message = _one_line_error(path)
        assert "truncated" in message or "not an HDF5 file" in message, message
        code, _, err = _rig_check(path, capsys)
        assert code == 2 and len(err.strip().splitlines()) == 1


def test_other_schema_and_newer_version(good, tmp_path, capsys):
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f.create_dataset("x", data=np.arange(3))
    assert "not a rigtools recording: no text attribute 'schema'" in _one_line_error(other)
    foreign = _copy(good, tmp_path / "foreign.h5", lambda f: f.attrs.__setitem__("schema", "acme.daq"))
    assert "schema is 'acme.daq'" in _one_line_error(foreign)
    newer = _copy(good, tmp_path / "newer.h5", lambda f: f.attrs.__setitem__("schema_version", np.int64(2)))
    message = _one_line_error(newer)
    assert "schema_version 2 is newer" in message and "upgrade rigtools" in message
    for path in (other, foreign):
        code, out, _ = _rig_check(path, capsys)
        assert code == 1 and out.count("error:") == 1
    # a newer file is not invalid, this rigtools cannot check it: exit 2, one line on stderr
    code, out, err = _rig_check(newer, capsys)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "schema_version 2 is newer" in err and "cannot check it" in err
    code, out, _ = _rig_check(newer, capsys, "--json")
    doc = json.loads(out)
    assert code == 2 and doc["readable"] is False and "newer" in doc["problems"][0]["message"]


@pytest.mark.parametrize(
    "where, name",
    [("/", n) for n in ROOT_ATTRS if n != "schema"]
    + [("/points/0001", n) for n in POINT_ATTRS]
    + [("/points/0001/accel", n) for n in CHANNEL_ATTRS],
)
def test_missing_attributes(good, tmp_path, capsys, where, name):
    path = _copy(good, tmp_path / "missing.h5", lambda f: f[where].attrs.__delitem__(name))
    message = _one_line_error(path)
    assert f"missing attribute '{name}'" in message
    code, out, _ = _rig_check(path, capsys)
    assert code == 1 and f"missing attribute '{name}'" in out


def test_inconsistent_channels_are_reported_and_refused_unless_skipped(good, tmp_path, capsys):
    def damage(f):
        f["points/0000/accel"].attrs["sample_rate"] = 2000.0
        data = f["points/0001/accel"][:100]
        del f["points/0001/accel"]
        ds = f["points/0001"].create_dataset("accel", data=data)
        for key, value in {
            "units": "m/s^2",
            "quantity": "acceleration",
            "sample_rate": 1000.0,
            "t0": 0.0,
        }.items():
            ds.attrs[key] = value

    path = _copy(good, tmp_path / "uneven.h5", damage)
    with pytest.raises(
        RecordingError, match=r"uneven.h5 is damaged: /points/0000: channels differ in sample_rate"
    ):
        open_recording(path)  # the reader contract (issue 30): what check rejects is refused
    with open_recording(path, skip_damaged=True) as rec:  # the rest: both points left out, said
        assert rec.points == [] and [n.split(":")[0] for n in rec.notes] == [
            "point 0 left out",
            "point 1 left out",
        ]
    code, out, _ = _rig_check(path, capsys)
    assert code == 1
    assert "/points/0000: channels differ in sample_rate: force=1000 Hz, accel=2000 Hz" in out
    assert "/points/0001: channels differ in length: force=3000, accel=100" in out


def test_wrong_channel_shape_and_bad_experiment(good, tmp_path):
    def two_d(f):
        del f["points/0000/accel"]
        f["points/0000"].create_dataset("accel", data=np.zeros((2, 2)))

    assert "is not a 1-D floating-point dataset" in _one_line_error(_copy(good, tmp_path / "a.h5", two_d))
    bad_json = _copy(good, tmp_path / "b.h5", lambda f: f.attrs.__setitem__("experiment", "{oops"))
    assert "'experiment' is not a JSON object" in _one_line_error(bad_json)


def test_missing_and_non_hdf5_files(tmp_path, capsys):
    assert "no such file" in _one_line_error(tmp_path / "absent.h5")
    text = tmp_path / "notes.h5"
    text.write_text("not hdf5")
    assert "not an HDF5 file" in _one_line_error(text)
    code, _, err = _rig_check(text, capsys)
    assert code == 2 and err.startswith("rig check: error:")
    assert main(["info", str(text)]) == 2


def test_writer_killed_outside_swmr_mode_still_reads(good, tmp_path, capsys):
    """Simulate a writer killed while adding structure: the file keeps HDF5's 'open for write'
    flag, which plain HDF5 refuses; the reader clears it in memory and reads the data."""
    path = tmp_path / "killed.h5"
    script = (
        "import h5py, os, sys\n"
        "from rigtools.recording.writer import LIBVER\n"
        "f = h5py.File(sys.argv[1], 'r+', libver=LIBVER, locking=False)\n"
        "f.attrs['status'] = 'recording'; f.attrs['ended'] = ''\n"
        "f.flush(); os._exit(0)\n"  # no close: like a kill after the last flush
    )
    path.write_bytes(good.read_bytes())
    subprocess.run([sys.executable, "-c", script, str(path)], check=True)
    assert consistency_flags(path) != 0
    with pytest.raises(OSError, match="already open for write"):
        h5py.File(path, "r")
    with open_recording(path) as rec:
        assert rec.opened_as == "flags-cleared" and rec.status == "recording"
        np.testing.assert_array_equal(rec.points[1]["force"][:], np.ones(3000))
    code, out, _ = _rig_check(path, capsys)
    assert code == 0 and "h5clear -s" in out and "incomplete" in out
    assert consistency_flags(path) != 0  # the reader never modifies the file


def test_rig_info_json(good, capsys):
    assert main(["info", "--json", str(good)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["status"] == "complete" and len(info["points"]) == 2
    assert info["points"][1]["params"] == {"fe": 61.0}
    assert info["points"][0]["n_samples"] == 3000 and info["points"][0]["duration_s"] == 3.0
    assert [c["name"] for c in info["channels"]] == ["force", "accel"]
    assert main(["info", str(good)]) == 0
    assert "complete" in capsys.readouterr().out


def test_cli_subprocess_prints_no_traceback(tmp_path):
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 20)
    run = subprocess.run(
        [sys.executable, "-m", "rigtools.cli", "check", str(bad)], capture_output=True, text=True, check=False
    )
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1


def test_lookup3_matches_published_vectors():
    """Bob Jenkins' lookup3.c driver5 values: hashlittle("", 0) = 0xdeadbeef,
    hashlittle("Four score and seven years ago", 0) = 0x17770551, with initval 1 = 0xcd628161."""
    from rigtools.recording.superblock import lookup3

    assert lookup3(b"") == 0xDEADBEEF
    assert lookup3(b"Four score and seven years ago") == 0x17770551
    assert lookup3(b"Four score and seven years ago", 1) == 0xCD628161
