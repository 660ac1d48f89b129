"""Two runs never write one file; `rig info`/`rig check` on a file being written.

The first writer is a separate process (``recording_crash_writer.py``: streams 4 channels in
0.05 s blocks, a new point every 0.4 s, until killed). A second writer on the same path, in this
process, is refused with one line, ``overwrite=True`` included, and the first writer's file stays
valid. The lock dies with the process: after SIGKILL a new writer may replace the file.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from rigtools.cli import main
from rigtools.recording import (
    ChannelSpec,
    RecordingError,
    RecordingWriter,
    check_recording,
    open_recording,
    writer_alive,
)
from rigtools.recording.lock import lock_path

HERE = Path(__file__).parent
POINT_BLOCKS = 8  # 0.4 s points: checks below cross many point boundaries

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs POSIX signals")


@pytest.fixture
def live(tmp_path):
    """A recording being written by another process; yields (path, process)."""
    path = tmp_path / "live.h5"
    proc = subprocess.Popen(
        [sys.executable, str(HERE / "recording_crash_writer.py"), str(path), "7", str(POINT_BLOCKS)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    line = proc.stdout.readline()
    assert line.startswith("S"), proc.stderr.read()
    yield path, proc
    if proc.poll() is None:
        proc.kill()
    proc.communicate(timeout=30)


def _channels():
    return [ChannelSpec("force", "N", "force", 1000.0)]


def test_second_writer_is_refused_and_first_file_stays_valid(live, capsys):
    path, proc = live
    time.sleep(0.6)
    size_before = path.stat().st_size
    for overwrite in (False, True):
        with pytest.raises(RecordingError) as info:
            RecordingWriter(path, backend="simulated", rig="{}", overwrite=overwrite)
        message = str(info.value)
        assert "\n" not in message and str(path) in message
        assert "being written by another run" in message and f"pid {proc.pid}" in message
    assert proc.poll() is None  # the first writer never noticed
    assert path.stat().st_size >= size_before  # nothing truncated the file
    time.sleep(0.5)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    with open_recording(path) as rec:
        assert rec.status == "recording" and rec.writer is None
        assert rec.experiment == {"procedure": "crash-test", "seed": 7}
        assert len(rec.complete_points) >= 2
        for point in rec.complete_points:
            assert point.params["settled"] is True and point.n_samples == POINT_BLOCKS * 1000
    assert check_recording(path).valid
    # the lock died with the killed process: a new run may replace the file
    assert writer_alive(path) is None
    with RecordingWriter(path, backend="simulated", rig="{}", overwrite=True) as rec:
        point = rec.begin_point({"fe": 1.0}, _channels())
        point.append(np.arange(10.0))
    with open_recording(path) as rec:
        assert rec.complete and rec.points[0]["force"][:].tolist() == list(range(10))
    assert not lock_path(path).exists()  # removed on close


def test_two_writers_in_one_process_and_the_lock_is_released(tmp_path):
    path = tmp_path / "one.h5"
    first = RecordingWriter(path, backend="simulated", rig="{}")
    with pytest.raises(RecordingError, match="being written by another run"):
        RecordingWriter(path, backend="simulated", rig="{}", overwrite=True)
    first.close()
    with pytest.raises(RecordingError, match="exists; give overwrite=True"):
        RecordingWriter(path, backend="simulated", rig="{}")
    RecordingWriter(path, backend="simulated", rig="{}", overwrite=True).close()


def test_info_and_check_on_a_file_being_written(live, capsys):
    """Repeated reads while the writer streams and crosses point boundaries: never invalid,
    never unreadable; the live writer is named and its open point shown in progress."""
    path, proc = live
    time.sleep(0.3)
    seen_points = set()
    for _ in range(12):
        code = main(["info", "--json", str(path)])
        out, err = capsys.readouterr()
        assert code == 0, err
        info = json.loads(out)
        assert info["status"] == "recording" and f"pid {proc.pid}" in info["writer"]
        states = [p["state"] for p in info["points"]]
        assert set(states[:-1]) <= {"complete"} and states[-1] in ("complete", "in progress")
        seen_points.add(len(states))
        code = main(["check", str(path)])
        out, err = capsys.readouterr()
        assert code == 0, out + err
        assert "valid rigtools recording (status recording" in out
        assert "being written now" in out and "Traceback" not in out + err
        assert main(["info", str(path)]) == 0
        assert "being written now" in capsys.readouterr().out
        time.sleep(0.1)
    assert len(seen_points) >= 2  # the reads spanned point boundaries
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    assert main(["info", "--json", str(path)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["writer"] is None
    assert info["points"][-1]["state"] in ("incomplete", "complete")
    assert main(["check", str(path)]) == 0
    assert "stopped without closing" in capsys.readouterr().out


def test_a_writer_that_ends_while_a_reader_opens_is_looked_at_again(tmp_path, monkeypatch):
    """Issue 19: `rig info` during a model study once read "attribute 'end_time' cannot be read":
    the study ended (its writer trims the file as it closes) while info opened it, and the retry
    asked for a writer still alive. A writer alive when the attempt began now earns one more look
    (open_recording and check_recording); a file no writer held is refused at once."""
    import rigtools.recording.lock as lock_module
    from rigtools.recording import reader, validate

    path = tmp_path / "r.h5"
    with RecordingWriter(path, backend="simulated", rig="{}") as rec:
        point = rec.begin_point({"fe": 60.0}, _channels())
        point.append(np.zeros((1, 10)))
        point.end()
    real_open, real_check = reader._open_once, validate._check_once
    for module, name, real, run in (
        (reader, "_open_once", real_open, lambda: open_recording(path).close()),
        (validate, "_check_once", real_check, lambda: check_recording(path)),
    ):
        probes = iter(["pid 1 on labpc since now"])  # alive for the first probe, then gone
        for where in (reader, validate, lock_module):  # each imports writer_alive at its head
            monkeypatch.setattr(where, "writer_alive", lambda p, probes=probes: next(probes, None))
        calls = []

        def flaky(*args, real=real, calls=calls):
            calls.append(1)
            if len(calls) == 1:
                raise RecordingError(f"{path}: /points/0000: attribute 'end_time' cannot be read")
            return real(*args)

        monkeypatch.setattr(module, name, flaky)
        run()
        assert len(calls) == 2
        # no writer at all: the first answer stands
        calls.clear()
        for where in (reader, validate, lock_module):
            monkeypatch.setattr(where, "writer_alive", lambda p: None)
        with pytest.raises(RecordingError, match="end_time"):
            run()
        assert len(calls) == 1


def test_info_during_a_model_study_never_fails(tmp_path, capsys):
    """`rig info` read over and over while `rig study` writes (a subprocess) and as it ends: every
    read exits 0; the study finishes complete with every point."""
    out = tmp_path / "study.h5"
    argv = ["study", "gap", "--values", "0.3 mm:0.9 mm:0.01 mm", "--direction", "both"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "rigtools.cli", *argv, "--duration", "0.05 s", "--no-plot", "--out", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ, OPENBLAS_NUM_THREADS="1"),
    )
    reads, live, deadline = 0, 0, time.monotonic() + 60
    try:
        while time.monotonic() < deadline:
            running = proc.poll() is None
            if out.exists():
                code = main(["info", "--json", str(out)])
                text, err = capsys.readouterr()
                assert code == 0, err
                reads += 1
                live += json.loads(text)["status"] == "recording"
            if not running:
                break
            time.sleep(0.01)
    finally:
        if proc.poll() is None:
            proc.kill()
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert live >= 3 and reads > live  # read while it wrote, and after it ended
    with open_recording(out) as rec:
        assert rec.status == "complete" and len(rec.points) == 121
