"""Every lab script in docs/examples runs on the simulated rig and writes a valid recording."""

import subprocess
import sys
from pathlib import Path

import pytest

from rigtools.recording import check_recording, open_recording

EXAMPLES = Path(__file__).resolve().parents[2] / "docs" / "examples"


@pytest.mark.parametrize(
    "script, points",
    [
        ("force_controlled_dwell.py", 1),
        ("gap_study.py", 3),
        ("stepped_sine.py", 11),
        ("frf_test.py", 1),
        ("tap_test.py", 5),
    ],
)
def test_example_runs(tmp_path, script, points):
    out = tmp_path / "run.h5"
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / script), str(out)], capture_output=True, text=True, cwd=tmp_path
    )
    assert done.returncode == 0, done.stderr
    assert check_recording(out).valid
    with open_recording(out) as rec:
        assert rec.status == "complete" and len(rec.points) == points
    assert "finished" in done.stdout or "peak" in done.stdout or "Hz" in done.stdout


def test_every_example_is_tested():
    tested = {"force_controlled_dwell.py", "gap_study.py", "stepped_sine.py", "frf_test.py", "tap_test.py"}
    assert {p.name for p in EXAMPLES.glob("*.py")} == tested
