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
        [sys.executable, str(EXAMPLES / script), str(out)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert check_recording(out).valid
    with open_recording(out) as rec:
        assert rec.status == "complete" and len(rec.points) == points
    assert "finished" in done.stdout or "peak" in done.stdout or "Hz" in done.stdout


def test_linear_response_example_peaks_at_the_first_flexural_frequency():
    """The gallery's model example (no recording): the passive shroud's largest FEM displacement
    lies at the passive blade's first flexural frequency, within the 1 Hz grid spacing."""
    from rigtools.config import load_rig
    from rigtools.sim.modal import flexural_frequencies
    from rigtools.sim.rig_model import build_rig_model

    done = subprocess.run(
        [sys.executable, str(EXAMPLES / "linear_response.py")], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    peak = float(done.stdout.split("largest FEM displacement at")[1].split("Hz")[0])
    f1 = flexural_frequencies(build_rig_model(load_rig().to_params()).passive, 1)[0]
    assert abs(peak - f1) < 1.0, (peak, f1)


def test_every_example_is_tested():
    tested = {
        "force_controlled_dwell.py",
        "gap_study.py",
        "stepped_sine.py",
        "frf_test.py",
        "tap_test.py",
        "linear_response.py",
    }
    assert {p.name for p in EXAMPLES.glob("*.py")} == tested
