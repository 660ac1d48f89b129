"""The end status of a procedure in the file: root attributes end_status (finished / aborted /
failed) and end_reason, optional in schema v1; `rig check` validates them against status and
abort_reason, `rig info` shows them."""

import contextlib
import io
import json

import h5py
import numpy as np
import pytest

from rigtools.cli import main
from rigtools.recording import ChannelSpec, RecordingWriter, check_recording
from rigtools.recording.schema import END_STATUSES, OPTIONAL_ROOT_ATTRS


def _file(path, abort: str | None = None, **attrs):
    w = RecordingWriter(path, backend="simulated", rig="{}", experiment={"procedure": "test"})
    p = w.begin_point(params={"fe": 60.0}, channels=[ChannelSpec("force", "N", "force", 1000.0)])
    p.append(np.zeros((1, 10)))
    p.end()
    if abort is None:
        w.close()
    else:
        w.abort(abort)
    with h5py.File(path, "r+") as f:
        for k, v in attrs.items():
            f.attrs[k] = v
    return path


def _errors(path):
    return [p.message for p in check_recording(path).problems if p.severity == "error"]


def test_schema_lists_the_end_attributes():
    assert END_STATUSES == ("finished", "aborted", "failed")
    assert set(OPTIONAL_ROOT_ATTRS) == {"end_status", "end_reason"}


@pytest.mark.parametrize(
    "abort, attrs",
    [
        (None, {}),
        (None, {"end_status": "finished", "end_reason": ""}),
        (
            "aborted: signal SIGINT (Ctrl-C)",
            {"end_status": "aborted", "end_reason": "signal SIGINT (Ctrl-C)"},
        ),
        ("failed: amplifier timeout", {"end_status": "failed", "end_reason": "amplifier timeout"}),
    ],
)
def test_consistent_end_status_is_valid(tmp_path, abort, attrs):
    path = _file(tmp_path / "ok.h5", abort, **attrs)
    assert _errors(path) == [] and check_recording(path).valid


@pytest.mark.parametrize(
    "abort, attrs, message",
    [
        (
            None,
            {"end_status": "done", "end_reason": ""},
            "end_status 'done' is not one of finished, aborted, failed",
        ),
        (
            None,
            {"end_status": "failed", "end_reason": "x"},
            "end_status is 'failed' but status is 'complete'",
        ),
        (
            "failed: x",
            {"end_status": "finished", "end_reason": ""},
            "end_status is 'finished' but status is 'aborted'",
        ),
        (
            "failed: x",
            {"end_status": "aborted", "end_reason": "x"},
            "end_status is 'aborted' but abort_reason does not start with 'aborted: ' ('failed: x')",
        ),
        (
            "failed: x",
            {"end_status": "failed", "end_reason": ""},
            "end_status is 'failed' but end_reason is empty",
        ),
        (None, {"end_status": 3}, "attribute 'end_status' = 3 is not text"),
    ],
)
def test_inconsistent_end_status_is_reported(tmp_path, abort, attrs, message):
    path = _file(tmp_path / "bad.h5", abort, **attrs)
    assert message in [p.message for p in check_recording(path).problems]


def _cli(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def test_rig_info_and_check_show_the_end_status(tmp_path):
    path = _file(
        tmp_path / "f.h5", "failed: amplifier timeout", end_status="failed", end_reason="amplifier timeout"
    )
    code, out, _ = _cli(["info", str(path), "--json"])
    doc = json.loads(out)
    assert code == 0 and doc["end_status"] == "failed" and doc["end_reason"] == "amplifier timeout"
    code, out, _ = _cli(["info", str(path)])
    assert "procedure failed" in " ".join(out.split())
    old = _file(tmp_path / "old.h5")
    code, out, _ = _cli(["info", str(old), "--json"])
    assert json.loads(out)["end_status"] is None
    bad = _file(tmp_path / "b.h5", None, end_status="done")
    code, out, err = _cli(["check", str(bad)])
    assert code != 0 and "end_status 'done'" in out + err
