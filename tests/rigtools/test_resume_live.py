"""``rig acquire study --resume`` against a study that is still writing (issue 19, item 3): the
resume takes the writer lock before touching anything, is refused in one line (exit 2), and the
live study finishes with a valid, complete file."""

from __future__ import annotations

import os
import subprocess
import sys
import time

from cli_helpers import acquire_gap_study, run_cli

from rigtools.procedures.rig_study import complete_points
from rigtools.recording import check_recording, open_recording

STUDY = acquire_gap_study("0.5 mm:0.9 mm:0.2 mm", fe="60 Hz", periods=12, pace=True)


def test_resume_while_the_study_writes_is_refused_and_the_study_finishes(tmp_path):
    out = tmp_path / "study.h5"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    live = subprocess.Popen(
        [sys.executable, "-m", "rigtools.cli", *STUDY, "--out", str(out)],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    end = time.monotonic() + 300  # only stops a hung child
    while live.poll() is None and time.monotonic() < end:
        try:
            if complete_points(out) >= 1:
                break
        except Exception:  # noqa: BLE001, S110 - the writer is between flushes: try again
            pass
        time.sleep(0.05)
    assert live.poll() is None, "the study ended before --resume was tried"
    before = sorted(p.name for p in tmp_path.iterdir())
    code, _, err = run_cli([*STUDY, "--out", str(out), "--resume"])
    assert code == 2 and "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert "being written" in err and "--resume" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no .resume-source, lock kept
    assert live.poll() is None
    _, live_err = live.communicate(timeout=300)
    assert live.returncode == 0, live_err
    assert check_recording(out).valid
    with open_recording(out) as rec:
        assert rec.status == "complete" and len(rec.points) == 3
        assert [round(p.params["gap"] * 1e3, 6) for p in rec.points] == [0.5, 0.7, 0.9]
