"""The reader contract for recordings (issue 30, item 1): a recording ``rig check`` rejects is
refused by every reader -- ``rig info``, ``rig report``, ``rig analyze``, ``rig export uff``,
``rig compare`` (either side) and the front door -- in one line naming the file, its first problem
and the way out (exit 2, the exit-status table's "bad input"); with ``--skip-damaged`` (Python:
``skip_damaged=True``) the rest of the file is read, each damaged point or channel left out with
one note. A file with only notes is read as before.

Each damage is written with h5py into a small real recording of the writer (two 60/61 Hz points
on four channels, ``test_bad_input._write_recording``).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
import pytest
from cli_helpers import run_cli
from test_bad_input import _write_recording

import rigtools
from rigtools.errors import EXIT_PROBLEMS, EXIT_STATUSES, EXIT_USAGE
from rigtools.recording import check_recording, open_recording


def _attr(where: str, key: str, value) -> Callable[[h5py.File], None]:
    def damage(f: h5py.File) -> None:
        f[where].attrs[key] = value

    return damage


def _nan(f: h5py.File) -> None:
    f["points/0001/active_shroud_accel"][100:104] = np.nan


def _shorter(f: h5py.File) -> None:
    ds = f["points/0001/drive"]
    data, attrs = ds[:1500], dict(ds.attrs)
    del f["points/0001/drive"]
    f["points/0001"].create_dataset("drive", data=data).attrs.update(attrs)


def _empty(f: h5py.File) -> None:
    attrs = dict(f["points/0001/drive"].attrs)
    del f["points/0001/drive"]
    f["points/0001"].create_dataset("drive", shape=(0,), dtype=float).attrs.update(attrs)


def _no_fe(f: h5py.File) -> None:
    del f["points/0001"].attrs["fe"]


def _no_channels(f: h5py.File) -> None:
    for name in list(f["points/0001"]):
        del f["points/0001"][name]


# damage -> (what rig check's first error says, what the skip leaves out: "point", "channel" or "file")
DAMAGES: dict[str, tuple[Callable[[h5py.File], None], str, str]] = {
    "never ended": (_attr("points/0001", "end_time", ""), "never ended", "point"),
    "NaN samples": (_nan, "4 samples NaN or infinite", "channel"),
    "unequal lengths": (_shorter, "channels differ in length", "point"),
    "unequal rates": (_attr("points/0001/drive", "sample_rate", 2500.0), "differ in sample_rate", "point"),
    "empty channel": (_empty, "hold no samples", "point"),
    "no channels": (_no_channels, "point has no channels", "point"),
    "sine point without fe": (_no_fe, "has no parameter 'fe'", "point"),
    "fe = 0": (_attr("points/0001", "fe", 0.0), "has fe = 0", "point"),
    "aborted without reason": (_attr("/", "status", "aborted"), "abort_reason is empty", "file"),
    "created not a time": (_attr("/", "created", "yesterday"), "is not ISO 8601", "file"),
    "direction code 9": (_attr("points/0001/drive", "direction", 9), "not a UFF direction code", "channel"),
}

# reader -> argv (FILE is the damaged recording, GOOD a sound one, TMP the case's folder)
READERS: dict[str, list[str]] = {
    "info": ["info", "FILE"],
    "info --json": ["info", "--json", "FILE"],
    "analyze": ["analyze", "--json", "FILE"],
    "report": ["report", "FILE", "--out", "TMP/report"],
    "export uff": ["export", "uff", "FILE", "TMP/o.uff"],
    "compare (EM side)": ["compare", "--json", "FILE", "GOOD"],
    "compare (model side)": ["compare", "--json", "GOOD", "FILE"],
}
FRONT_DOOR: dict[str, Callable[..., object]] = {
    "rigtools.open_recording": lambda path, **kw: open_recording(path, **kw).close(),
    "rigtools.analyze_recording": lambda path, **kw: rigtools.analyze_recording(path, **kw),
    "rigtools.compare_with_model": lambda path, good, **kw: rigtools.compare_with_model(path, good, **kw),
}


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    return _write_recording(tmp_path_factory.mktemp("good") / "good.h5")


def _damaged(damage: str, folder: Path) -> Path:
    path = _write_recording(folder / "bad.h5")
    with h5py.File(path, "r+") as f:
        DAMAGES[damage][0](f)
    return path


def _argv(argv: list[str], path: Path, good: Path, tmp: Path) -> list[str]:
    return [a.replace("FILE", str(path)).replace("GOOD", str(good)).replace("TMP", str(tmp)) for a in argv]


def test_the_refusal_is_bad_input_in_the_exit_status_table():
    assert EXIT_USAGE == 2 and "bad input" in EXIT_STATUSES[EXIT_USAGE]


@pytest.mark.parametrize("damage", list(DAMAGES))
def test_check_rejects_each_damage(damage, tmp_path):
    path = _damaged(damage, tmp_path)
    result = check_recording(path)
    errors = [p for p in result.problems if p.severity == "error"]
    assert errors and DAMAGES[damage][1] in errors[0].message, result.problems
    code, _, _ = run_cli(["check", path])
    assert code == EXIT_PROBLEMS


@pytest.mark.parametrize("reader", list(READERS))
@pytest.mark.parametrize("damage", list(DAMAGES))
def test_every_reader_refuses_what_check_rejects(damage, reader, good, tmp_path):
    """damages x CLI readers: exit 2, one line naming the file, the first problem, check's count
    and --skip-damaged; nothing written."""
    path = _damaged(damage, tmp_path)
    code, _, err = run_cli(_argv(READERS[reader], path, good, tmp_path))
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == EXIT_USAGE, (code, err)
    assert len(lines) == 1 and "Traceback" not in err, err
    assert f"{path} is damaged: " in lines[0] and DAMAGES[damage][1] in lines[0], lines[0]
    assert f"(rig check {path} lists " in lines[0] and "--skip-damaged reads the rest)" in lines[0], lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.h5"]  # no report, no UFF


@pytest.mark.parametrize("reader", list(FRONT_DOOR))
@pytest.mark.parametrize("damage", list(DAMAGES))
def test_the_front_door_refuses_what_check_rejects(damage, reader, good, tmp_path):
    """damages x front-door readers: one UserError line, the way out in Python's words."""
    path = _damaged(damage, tmp_path)
    call = FRONT_DOOR[reader]
    args = (path, good) if reader.endswith("compare_with_model") else (path,)
    with pytest.raises(rigtools.UserError) as info:
        call(*args)
    text = str(info.value)
    assert "\n" not in text and f"{path} is damaged: " in text and DAMAGES[damage][1] in text, text
    assert "skip_damaged=True reads the rest" in text, text


@pytest.mark.parametrize("damage", list(DAMAGES))
def test_skip_damaged_reads_the_rest(damage, good, tmp_path):
    """--skip-damaged: the damaged point (or channel) left out with one note, the other point
    analysed as from a sound file; a file-level damage is noted and the file read whole."""
    path = _damaged(damage, tmp_path)
    _, where = DAMAGES[damage][1:]
    with open_recording(path, skip_damaged=True) as rec:
        points = {p.index: sorted(p.channels) for p in rec.points}
        notes = rec.notes
    assert len(notes) == 1, notes
    if where == "point":
        assert list(points) == [0] and notes[0].startswith("point 1 left out: "), (points, notes)
    elif where == "channel":
        assert list(points) == [0, 1] and len(points[1]) == 3 and "point 1 channel " in notes[0], notes
    else:
        assert list(points) == [0, 1] and notes[0].endswith(": read on (skip_damaged)"), notes
    code, out, err = run_cli(["analyze", "--json", "--skip-damaged", path])
    assert code == 0, err
    doc = json.loads(out)
    assert notes[0] in doc["notes"]
    reference = json.loads(run_cli(["analyze", "--json", str(good)])[1])
    force_k1 = [p["dwell"]["channels"]["force"]["harmonics"][0]["amplitude"] for p in doc["points"]]
    expected = [
        reference["points"][p["point"]]["dwell"]["channels"]["force"]["harmonics"][0]["amplitude"]
        for p in doc["points"]
    ]
    # the same samples as the sound file: the same numbers (round-off of one fit: 1e-12)
    assert force_k1 == pytest.approx(expected, rel=1e-12) and len(force_k1) == (1 if where == "point" else 2)


@pytest.mark.parametrize("reader", list(READERS))
def test_skip_damaged_in_every_reader(reader, good, tmp_path):
    """One point-level damage (never ended) through every CLI reader with --skip-damaged: exit
    0, the note in the output (or the report), the output written."""
    path = _damaged("never ended", tmp_path)
    code, out, err = run_cli([*_argv(READERS[reader], path, good, tmp_path), "--skip-damaged"])
    assert code == 0, err
    assert "point 1 left out" in out + err or (tmp_path / "report").is_dir(), out


def test_front_door_skip_damaged(good, tmp_path):
    path = _damaged("NaN samples", tmp_path)
    analysis = rigtools.analyze_recording(path, skip_damaged=True)
    assert [p.index for p in analysis.points] == [0, 1]
    assert any("point 1 channel active_shroud_accel left out" in n for n in analysis.notes)
    cmp = rigtools.compare_with_model(path, good, skip_damaged=True)
    assert any("point 1 channel active_shroud_accel left out" in n for n in cmp.notes)
    with pytest.raises(rigtools.UserError, match="skip_damaged = 'yes': give True or False"):
        rigtools.analyze_recording(path, skip_damaged="yes")


def test_a_rig_attribute_that_does_not_validate_matters_to_the_model_builders_only(good, tmp_path):
    """Decision: check rejects it (exit 1); the data readers read the intact samples with a note;
    the readers that build the model from it refuse it naming --rig."""
    path = _write_recording(tmp_path / "bad.h5")
    with h5py.File(path, "r+") as f:
        f.attrs["rig"] = json.dumps({"contact": {"gap": -1}})
    assert run_cli(["check", path])[0] == EXIT_PROBLEMS
    code, out, err = run_cli(["info", "--json", path])
    assert code == 0, err
    assert any("attribute 'rig' does not validate" in n for n in json.loads(out)["notes"])
    code, out, err = run_cli(["analyze", "--json", path])
    assert code == 0 and any("(the samples are read)" in n for n in json.loads(out)["notes"]), err
    code, _, err = run_cli(["compare", "--json", path, "--simulate"])
    assert code == EXIT_USAGE and "rig" in err and len(err.strip().splitlines()) == 1, err


def test_a_file_with_notes_only_is_read(good, tmp_path):
    """A killed writer's file (status 'recording', the last point never ended): check notes it,
    is valid, and every reader reads it without --skip-damaged."""
    path = _write_recording(tmp_path / "killed.h5")
    with h5py.File(path, "r+") as f:
        f.attrs["status"] = "recording"
        f.attrs["ended"] = ""
        f["points/0001"].attrs["end_time"] = ""
    assert check_recording(path).valid
    for argv in (["info", path], ["analyze", "--json", path]):
        code, _, err = run_cli(argv)
        assert code == 0, err
