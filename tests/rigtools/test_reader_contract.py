"""One reader contract per file kind (issue 30, item 1): what ``rig check`` verifies is what every
reader relies on. Each damage is run through every reader of its kind: ``rig check`` reports it
(exit 1), and ``info``, ``info --json``, ``analyze``, ``export uff`` and the front door refuse the
file with one line and a non-zero exit (2), never a traceback and never an answer from a file
``check`` rejects."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest
from cli_helpers import run_cli
from test_cli_continuation import no_contact, sweep  # noqa: F401 -- fixtures: a good branches file, a sweep
from test_frf_set_info_check import frf_set  # noqa: F401 -- the pytest fixture: a good FRF set

import rigtools
from rigtools.errors import UserError


def _attr(name, value):
    def damage(f):
        f.attrs[name] = value

    return damage


def _resize(lines):
    def damage(f):
        for name in ("frf_real", "frf_imag", "coherence"):
            data = f[name][:, :lines]
            del f[name]
            f[name] = data
        freq = f["frequency"][:lines]
        del f["frequency"]
        f["frequency"] = freq

    return damage


def _one_d_frf(f):
    row = f["frf_real"][0]
    del f["frf_real"]
    f["frf_real"] = row


def _coherence_five(f):
    f["coherence"][0, :] = np.linspace(0.0, 5.0, f["coherence"].shape[1])


def _frequency_group(f):
    del f["frequency"]
    f.create_group("frequency")


FRF_SET_DAMAGES = {
    "schema_version text": _attr("schema_version", "two"),
    "responses a string": _attr("responses", json.dumps("abc")),
    "responses longer than the rows": _attr("responses", json.dumps(["a", "b", "c"])),
    "responses not JSON": _attr("responses", "[a, b"),
    "points of numbers": _attr("points", json.dumps([1, 2])),
    "kind unknown": _attr("kind", "inertance?"),
    "one line": _resize(1),
    "no line": _resize(0),
    "1-D FRF": _one_d_frf,
    "coherence up to 5": _coherence_five,
    "frequency a group": _frequency_group,
}
READERS = {
    "info": lambda p, tmp: ["info", p],
    "info --json": lambda p, tmp: ["info", p, "--json"],
    "analyze": lambda p, tmp: ["analyze", p],
    "export uff": lambda p, tmp: ["export", "uff", p, tmp / "out.uff"],
}


@pytest.mark.parametrize("damage", list(FRF_SET_DAMAGES))
def test_every_frf_set_reader_refuses_what_check_rejects(frf_set, tmp_path, damage):  # noqa: F811
    bad = tmp_path / "bad.h5"
    shutil.copy(frf_set, bad)
    with h5py.File(bad, "r+") as f:
        FRF_SET_DAMAGES[damage](f)
    code, out, err = run_cli(["check", bad])
    assert code == 1 and "INVALID FRF set" in out, (out, err)
    for reader, argv in READERS.items():
        code, out, err = run_cli(argv(bad, tmp_path))
        assert code == 2, (reader, code, out, err)
        assert "Traceback" not in err and len(err.strip().splitlines()) == 1, (reader, err)
        assert str(bad) in err and ("damaged FRF set" in err or "not an FRF set" in err), (reader, err)
    assert not (tmp_path / "out.uff").exists()
    with pytest.raises(UserError, match="damaged FRF set"):
        rigtools.analyze_recording(bad)


def test_every_frf_set_reader_reads_what_check_passes(frf_set, tmp_path):  # noqa: F811
    code, out, _ = run_cli(["check", frf_set])
    assert code == 0, out
    for reader, argv in READERS.items():
        code, out, err = run_cli(argv(frf_set, tmp_path))
        assert code == 0, (reader, err)


# ---------------------------------------------------------------------------- branches files
def _branches_dataset(f):
    del f["branches"]
    f["branches"] = np.zeros(3)


def _short_values(f):
    value = f["branches/00/value"][:-2]
    del f["branches/00/value"]
    f["branches/00/value"] = value


def _two_d_values(f):
    value = f["branches/00/value"][()]
    del f["branches/00/value"]
    f["branches/00/value"] = np.vstack([value, value])


def _short_labels(f):
    f["branches/00"].attrs["labels"] = json.dumps(json.loads(f["branches/00"].attrs["labels"])[:-3])


BRANCHES_DAMAGES = {
    "schema_version text": _attr("schema_version", "two"),
    "experiment null": _attr("experiment", "null"),
    "experiment a list": _attr("experiment", json.dumps(["fe"])),
    "branches a dataset": _branches_dataset,
    "values shorter than the points": _short_values,
    "2-D values": _two_d_values,
    "labels shorter than the points": _short_labels,
}


@pytest.mark.parametrize("damage", list(BRANCHES_DAMAGES))
def test_every_branches_reader_refuses_what_check_rejects(no_contact, sweep, tmp_path, damage):  # noqa: F811 -- the fixture
    _, good, _ = no_contact
    bad = tmp_path / "bad.h5"
    shutil.copy(good, bad)
    with h5py.File(bad, "r+") as f:
        BRANCHES_DAMAGES[damage](f)
    code, out, err = run_cli(["check", bad])
    assert code == 1 and "INVALID" in out, (out, err)
    readers = {
        "info": ["info", bad],
        "info --json": ["info", bad, "--json"],
        "report --branches": ["report", sweep, "--branches", bad, "--out", tmp_path / "rep"],
    }
    for reader, argv in readers.items():
        code, out, err = run_cli(argv)
        assert code == 2, (reader, code, out, err)
        assert "Traceback" not in err and len(err.strip().splitlines()) == 1, (reader, err)
        assert "a damaged branches file" in err and str(bad) in err, (reader, err)
    assert not (tmp_path / "rep").exists()


# ------------------------------------------------------------------ continuation resources
def test_a_continuation_beyond_the_model_or_the_memory_is_refused_up_front(tmp_path):
    """1 Hz to 1 MHz ran silently past 1.8 GB: now one line before any orbit (the model's range;
    an orbit at 0.001 Hz would need millions of steps per period: the memory estimate)."""
    out = tmp_path / "b.h5"
    code, _, err = run_cli(
        ["continuation", "--param", "fe", "--from", "1 Hz", "--to", "1 MHz", "--gap", "5 mm", "--out", out]
    )
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "--to = 1000 kHz is more than 10 x the model's highest mode" in err
    code, _, err = run_cli(
        [
            "continuation",
            "--param",
            "fe",
            "--from",
            "0.001 Hz",
            "--to",
            "50 Hz",
            "--gap",
            "5 mm",
            "--out",
            out,
        ]
    )
    assert code == 2 and "an orbit at 0.001 Hz" in err and "of memory" in err and "higher frequency" in err
    assert not list(tmp_path.iterdir())


@pytest.mark.skipif(os.geteuid() != 0, reason="mounting a small tmpfs needs root")
def test_branches_on_a_full_disk_exit_4_and_leave_nothing(tmp_path):
    """The branches writer on a full disk ended in a segmentation fault and left b.h5.partial:
    now the file is built in memory and written whole or not at all (exit 4, one line)."""
    full = tmp_path / "full"
    full.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=12k", "tmpfs", str(full)], check=False).returncode:
        pytest.skip("cannot mount a tmpfs here")
    try:
        cmd = [
            sys.executable,
            "-m",
            "rigtools.cli",
            "continuation",
            "--param",
            "fe",
            "--from",
            "60",
            "--to",
            "61",
        ]
        proc = subprocess.run(
            [*cmd, "--gap", "5 mm", "--no-switch", "--out", str(full / "b.h5")],
            capture_output=True, text=True, timeout=600, check=False,
        )  # fmt: skip
        assert proc.returncode == 4, proc.stderr
        assert "cannot write" in proc.stderr and "No space left on device" in proc.stderr
        assert "Traceback" not in proc.stderr and list(full.iterdir()) == []
    finally:
        subprocess.run(["umount", str(full)], check=False)


def test_export_uff_refuses_nan_samples_it_would_write_as_numbers(tmp_path):
    """NaN samples went into the UFF as 0.0 and inf as 1.797e308, exit 0 (pyuff's writer); the
    recording is refused at open as every reader refuses it (the reader contract), and
    --skip-damaged writes the rest without that channel."""
    from test_bad_input import _write_recording

    src = _write_recording(tmp_path / "nan.h5", nan=True)
    code, _, err = run_cli(["export", "uff", src, tmp_path / "o.uff"])
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert f"{src} is damaged: /points/0001/active_shroud_accel: 4 samples NaN or infinite" in err
    assert not (tmp_path / "o.uff").exists()
    code, out, err = run_cli(["export", "uff", src, tmp_path / "o.uff", "--skip-damaged"])
    assert code == 0, err
    assert "point 1 channel active_shroud_accel left out: 4 samples NaN or infinite" in out
    assert "7 time" in out  # 4 channels of point 0, 3 of point 1


def test_a_frf_set_starting_below_0_hz_or_labels_not_names_are_rejected(frf_set, tmp_path):  # noqa: F811
    bad = tmp_path / "neg.h5"
    shutil.copy(frf_set, bad)
    with h5py.File(bad, "r+") as f:
        f["frequency"][:] = f["frequency"][:] - 1000.0
    code, out, _ = run_cli(["check", bad])
    assert code == 1 and "/frequency: starts at -1000 Hz, below 0 Hz" in out
    assert run_cli(["analyze", bad])[0] == 2


def test_compare_leaves_out_a_point_whose_channels_differ_in_length(tmp_path):
    """rig compare of a point with one channel cut to 100 samples ended in a traceback
    ('passive_acceleration has (141312,) samples, active_acceleration (100,)')."""
    from test_bad_input import _write_recording

    em = _write_recording(tmp_path / "em.h5")
    other = _write_recording(tmp_path / "model.h5")
    with h5py.File(em, "r+") as f:
        attrs = dict(f["points/0000/active_shroud_accel"].attrs)
        data = f["points/0000/active_shroud_accel"][:100]
        del f["points/0000/active_shroud_accel"]
        f["points/0000/active_shroud_accel"] = data
        f["points/0000/active_shroud_accel"].attrs.update(attrs)
    code, out, err = run_cli(["compare", "--json", em, other])
    assert code == 2 and f"{em} is damaged: /points/0000: channels differ in length" in err, err
    code, out, err = run_cli(["compare", "--json", em, other, "--skip-damaged"])
    assert code == 0, err
    notes = json.loads(out)["notes"]
    assert any("EM: point 0 left out: channels differ in length" in n for n in notes), notes


@pytest.mark.skipif(os.geteuid() != 0, reason="mounting a small tmpfs needs root")
def test_acquisition_on_a_full_disk_claims_no_sample_it_did_not_keep(tmp_path):
    """A dwell onto a 2.5 MB disk ended 'exit 4 ... 13312 samples per channel (0.260 s) kept'
    while those samples were never flushed (NaN), and rig check rejected the file (end_status
    'failed' but abort_reason 'RecordingWriteError: ...')."""
    full = tmp_path / "full"
    full.mkdir()
    if subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=2500k", "tmpfs", str(full)], check=False
    ).returncode:
        pytest.skip("cannot mount a tmpfs here")
    try:
        out = full / "a.h5"
        cmd = [sys.executable, "-m", "rigtools.cli", "acquire", "dwell", "--backend", "sim", "--fe", "60 Hz"]
        proc = subprocess.run(
            [*cmd, "--force", "5 N", "--gap", "5 mm", "--periods", "400", "--out", str(out)],
            capture_output=True, text=True, timeout=600, check=False,
        )  # fmt: skip
        assert proc.returncode == 4 and "No space left on device" in proc.stderr, proc.stderr
        assert "samples per channel" not in proc.stderr and "everything flushed before is kept" in proc.stderr
        code, text, _ = run_cli(["check", out])
        assert code == 0 and "status aborted" in text, text  # a valid aborted recording
        with h5py.File(out, "r") as f:
            assert str(f.attrs["abort_reason"]).startswith("failed: RecordingWriteError")
    finally:
        subprocess.run(["umount", str(full)], check=False)
