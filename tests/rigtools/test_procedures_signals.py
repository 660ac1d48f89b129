"""Procedures run as the `rig` command in a child process: killed with SIGKILL mid-study and
resumed; interrupted with SIGINT during a dwell. What is on disk is checked, never timings."""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from cli_helpers import acquire_dwell, acquire_gap_study

from rigtools.procedures.rig_study import complete_points
from rigtools.recording import check_recording, open_recording

RATE = 51200.0
STUDY = acquire_gap_study("0.3 mm:0.9 mm:0.2 mm", fe="60", periods=12)


def _rig(args, **kw):
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    return subprocess.Popen(
        [sys.executable, "-m", "rigtools.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        **kw,
    )


def _wait_for(predicate, proc, limit=600.0):
    """Poll until ``predicate()`` (a safety net of ``limit`` s against a hung child, not a timing)."""
    end = time.monotonic() + limit
    while time.monotonic() < end:
        if proc.poll() is not None:
            return False
        try:
            if predicate():
                return True
        except Exception:  # noqa: BLE001, S110 - the writer is between phases: try again
            pass
        time.sleep(0.05)
    return False


def _samples(path):
    with open_recording(path) as rec:
        return rec.points[0].n_samples if rec.points else 0


def test_study_killed_after_two_points_resumes_with_every_point_once(tmp_path):
    out = tmp_path / "s.h5"
    child = _rig([*STUDY, "--out", str(out)])
    assert _wait_for(lambda: complete_points(out) >= 2, child)
    child.send_signal(signal.SIGKILL)
    child.wait()
    kept = complete_points(out)
    assert kept >= 2
    with open_recording(out) as rec:
        before = [(p.params["gap"], np.asarray(p["force"]).copy()) for p in rec.points[:kept]]
    done = _rig([*STUDY, "--out", str(out), "--resume", "--json"])
    _stdout, stderr = done.communicate()
    assert done.returncode == 0, stderr
    assert check_recording(out).valid
    assert not out.with_name(out.name + ".resume-source").exists()
    with open_recording(out) as rec:
        assert rec.status == "complete" and rec.experiment["resumed"] is True
        gaps = [p.params["gap"] for p in rec.points]
        assert gaps == pytest.approx([3e-4, 5e-4, 7e-4, 9e-4])  # every point once, in order
        assert [int(p.params["study_index"]) for p in rec.points] == [0, 1, 2, 3]
        for p in rec.points:
            assert p.ended and bool(p.params["point_complete"])
            assert p.params["force_amplitude_measured"] == pytest.approx(15.0, rel=0.01)
        for (gap, force), p in zip(before, rec.points[:kept], strict=True):  # kept bit for bit
            assert p.params["gap"] == gap
            np.testing.assert_array_equal(np.asarray(p["force"]), force)
    check = subprocess.run(
        [sys.executable, "-m", "rigtools.cli", "check", str(out)], capture_output=True, text=True, check=False
    )
    assert check.returncode == 0, check.stdout + check.stderr


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM", "SIGHUP"])
def test_signal_during_a_dwell_ramps_down_and_keeps_the_data(tmp_path, sig):
    out = tmp_path / "d.h5"
    child = _rig([*acquire_dwell(periods=6000), "--out", str(out)])
    # wait until the dwell is recording (past the ramp and the force control): > 3 s on disk
    assert _wait_for(lambda: _samples(out) > 3.0 * RATE, child)
    at = _samples(out)
    child.send_signal(getattr(signal, sig))
    _stdout, stderr = child.communicate()
    assert child.returncode == 128 + getattr(signal, sig)  # 130, 143, 129
    assert stderr.count("\n") == 1 and "interrupted" in stderr
    with open_recording(out) as rec:
        assert rec.status == "aborted" and rec.attrs["end_status"] == "aborted"
        assert rec.abort_reason.startswith(f"aborted: signal {sig}")
        p = rec.points[0]
        drive = np.asarray(p["drive"])
        assert p.n_samples >= at and drive[-1] == 0.0
        # the drive ramps to zero inside the record: full amplitude, then a ramp, then rest
        amp = np.max(np.abs(drive[:at][-2000:]))
        tail = drive[-int(0.3 * RATE) :]
        assert amp > 0.5 and np.max(np.abs(tail[-500:])) < 1e-9
        assert np.all(np.isfinite(np.asarray(p["force"])))
