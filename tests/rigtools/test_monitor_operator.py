"""The monitor for an operator (issue 31, item 5): it never outlives its run by more than its
linger however the run ended; a stop from the page is said in the terminal with exit status 6;
a refused request gets the helpful sentence; the trend is the response against fe, up and down;
"settled" agrees with the phase. Simulated rig, paced where a run must last while it is watched."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from rigtools.monitor.control_files import request_stop
from rigtools.monitor.page import settled_text, trend_series
from rigtools.monitor.server import REFUSED

ROOT = Path(__file__).resolve().parents[2]
LINGER_S = 2.0
#: Margin over the linger: the monitor looks at the parent between looks at the recording (a look
#: analysing an ended point takes a few seconds on a loaded machine) and checks its linger twice a
#: second; a bound on an event, not a speed.
MARGIN_S = 45.0


def _monitors(recording: Path) -> list[int]:
    """Process ids of ``rig monitor`` processes following ``recording``."""
    found = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            argv = (d / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"monitor" in argv and str(recording).encode() in argv:
            found.append(int(d.name))
    return found


def _acquire(out: Path, *extra: str) -> tuple[subprocess.Popen, str]:
    cmd = [sys.executable, "-m", "rigtools.cli", "acquire", "dwell", "--backend", "sim", "--pace"]
    cmd += ["--fe", "60", "--force", "15 N", "--gap", "0.5 mm", "--periods", "3000", "--out", str(out)]
    cmd += ["--monitor", "--monitor-linger", str(LINGER_S), *extra]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    assert proc.stderr is not None
    for line in proc.stderr:
        if "monitor at" in line:
            return proc, line
    raise AssertionError(f"no monitor address (exit {proc.wait()})")


def _wait_gone(recording: Path, bound: float) -> float:
    start = time.monotonic()
    while _monitors(recording) and time.monotonic() - start < bound:
        time.sleep(0.2)
    return time.monotonic() - start


def test_a_killed_run_leaves_no_monitor_beyond_its_linger(tmp_path):
    """The reported case: the run's process gone (here SIGKILL, so the recording stays
    "recording" and nothing says it ended) used to leave its monitor serving for ever (31 min seen).
    Now the monitor sees its parent gone and exits within --monitor-linger + a margin."""
    out = tmp_path / "killed.h5"
    proc, _ = _acquire(out)
    try:
        assert _monitors(out), "the monitor is running beside the run"
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
        waited = _wait_gone(out, LINGER_S + MARGIN_S)
    finally:
        for pid in _monitors(out):
            os.kill(pid, signal.SIGKILL)
    assert waited < LINGER_S + MARGIN_S, f"monitor still serving {waited:.0f} s after its run was killed"


def test_a_finished_recordings_monitor_exits_after_its_linger(tmp_path):
    """rig monitor FILE --linger: it used to hang for ever in h5py's teardown (its follower
    thread held h5py's lock when the interpreter exited); now it exits 0."""
    from rigtools.config import load_rig
    from rigtools.procedures import SineDwell

    out = tmp_path / "done.h5"
    SineDwell(
        load_rig(), {"fe": 60.0, "force": 15.0, "gap": 5e-4, "record_periods": 10}, out, backend="sim"
    ).run()
    cmd = [sys.executable, "-m", "rigtools.cli", "monitor", str(out), "--port", "0", "--linger", "0.5"]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=120, cwd=ROOT, check=False)
    assert run.returncode == 0, run.stderr


def test_a_stop_from_the_page_is_said_and_exits_6(tmp_path):
    """What the page's stop button does (the stop request beside the recording): the terminal
    says "stopped from the monitor" in one line and the exit status is 6, not Ctrl-C's 130."""
    out = tmp_path / "stopped.h5"
    proc, _ = _acquire(out, "--allow-stop")
    timer = threading.Timer(120, proc.kill)
    timer.start()
    try:
        request_stop(out)
        _, err = proc.communicate(timeout=120)
    finally:
        timer.cancel()
        for pid in _monitors(out):
            os.kill(pid, signal.SIGKILL)
    assert proc.returncode == 6, err
    assert (
        f"rig acquire: stopped from the monitor; drive ramped to zero; {out} kept with status aborted" in err
    )


def test_a_refused_request_gets_the_helpful_sentence(tmp_path):
    out = tmp_path / "none.h5"
    cmd = [sys.executable, "-m", "rigtools.cli", "monitor", str(out), "--host", "0.0.0.0", "--port", "0"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, cwd=ROOT)
    timer = threading.Timer(60, proc.kill)
    timer.start()
    try:
        assert proc.stdout is not None
        port = int(proc.stdout.readline().split("?token=")[0].rsplit(":", 1)[1].split("/")[0])
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/monitor", timeout=20)
        assert refused.value.code == 403
        assert REFUSED in refused.value.read().decode()
    finally:
        timer.cancel()
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)


def test_trend_is_the_response_against_fe_split_up_and_down():
    rows = [
        {"point": 0, "fe": 70.0, "direction": "up", "response": 90.0},
        {"point": 1, "fe": 71.0, "direction": "up", "response": 60.0},
        {"point": 2, "fe": 70.0, "direction": "down", "response": 61.0},
        {"point": 3, "fe": 5.0, "direction": None, "response": 1.0},
    ]
    series = trend_series(rows, "fe", 1.0)
    assert series["up"] == {"x": [70.0, 71.0], "y": [90.0, 60.0]}
    assert series["down"] == {"x": [70.0], "y": [61.0]}
    assert series["points"] == {"x": [5.0], "y": [1.0]}


@pytest.mark.parametrize(
    ("control", "shown"),
    [
        ({"settled": None, "phase": "control"}, "not yet"),
        ({"settled": None, "phase": "recording"}, "judged at the end of the record"),
        ({"settled": None, "phase": "stopped"}, "– (stopped before its record)"),
        ({"settled": True, "phase": "done"}, "yes"),
    ],
)
def test_settled_agrees_with_the_phase(control, shown):
    assert settled_text(control) == shown
