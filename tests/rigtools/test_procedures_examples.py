"""Every lab script in docs/examples runs on the simulated rig: the procedure scripts write a valid
recording (given as an argument, or in a temporary folder without one), the offline-analysis
scripts read one and print what they found, and the lab script of the front door fits in 20 lines."""

import re
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


def _run(script: str, *args: str, cwd: Path) -> str:
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / script), *args], capture_output=True, text=True, cwd=cwd, check=False
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def _numbers(pattern: str, text: str) -> list[float]:
    return [float(x) for x in re.findall(pattern, text)]


def test_procedure_example_runs_without_arguments(tmp_path):
    out = _run("frf_test.py", cwd=tmp_path)  # the recording goes to a temporary folder
    assert "peak" in out and not list(tmp_path.iterdir())


def test_lab_script_dwell_spectrum_frf_comparison_in_20_lines(tmp_path):
    script = EXAMPLES / "lab_dwell_to_comparison.py"
    assert len(script.read_text().splitlines()) <= 20
    text = script.read_text()
    assert '"60 Hz"' in text and '"15 N"' in text and '"0.5 mm"' in text  # quantity strings
    out = _run(script.name, cwd=tmp_path)
    (f1,) = _numbers(r"F1 = ([\d.]+) N", out)
    assert abs(f1 - 15.0) < 0.15  # force control holds F0 within 1 %
    modes = _numbers(r"[\[ ]([\d.]+)[,\]]", out.split("modes (Hz):")[1].splitlines()[0])
    assert any(abs(m - 52.0) < 3.0 for m in modes)  # the active blade's first mode, rig file ~52 Hz
    (score,) = _numbers(r"agreement score: ([\d.]+)", out)
    assert 0.3 < score <= 1.0


def test_read_a_recording(tmp_path):
    out = _run("read_a_recording.py", cwd=tmp_path)
    assert "complete, backend simulated, 1 point(s)" in out
    start, stop = (int(x) for x in re.search(r"samples (\d+)\.\.(\d+)", out).groups())
    (n,) = (int(x) for x in re.findall(r"force: (\d+) samples", out))
    assert n == stop - start > 0


def test_spectrum_of_a_point(tmp_path):
    out = _run("spectrum_of_a_point.py", cwd=tmp_path)
    force = _numbers(r"k=\d: ([\d.e+-]+)", out.splitlines()[0])
    assert abs(force[0] - 15.0) < 0.15  # the controlled fundamental, N peak
    accel = _numbers(r"k=\d: ([\d.e+-]+)", out.splitlines()[1])
    assert accel[1] > 0.05 * accel[0]  # impacts put energy into 2 fe


def test_harmonics_of_a_dwell(tmp_path):
    out = _run("harmonics_of_a_dwell.py", cwd=tmp_path)
    (f0,) = _numbers(r"force fundamental ([\d.]+) N", out)
    assert abs(f0 - 15.0) < 0.15
    assert _numbers(r"impacts per period: ([\d.]+)", out)[0] >= 0.9  # the 0.5 mm gap closes


def test_frf_of_a_test(tmp_path):
    out = _run("frf_of_a_test.py", cwd=tmp_path)
    modes = _numbers(r"active_shroud_accel:\s+([\d.]+) Hz", out)
    assert any(abs(m - 52.0) < 3.0 for m in modes) and any(abs(m - 356.0) < 10.0 for m in modes)


def test_compare_with_fem(tmp_path):
    out = _run("compare_with_fem.py", cwd=tmp_path)
    (score,) = _numbers(r"agreement score ([\d.]+)", out)
    assert 0.3 < score <= 1.0
    assert re.search(r"force\s+1\s+60\.0\s+1[45]\.\d+", out)  # EM force fundamental ~15 N


def test_every_example_is_tested():
    tested = {
        "force_controlled_dwell.py",
        "gap_study.py",
        "stepped_sine.py",
        "frf_test.py",
        "tap_test.py",
        "linear_response.py",
        "lab_dwell_to_comparison.py",
        "read_a_recording.py",
        "spectrum_of_a_point.py",
        "harmonics_of_a_dwell.py",
        "frf_of_a_test.py",
        "compare_with_fem.py",
    }
    assert {p.name for p in EXAMPLES.glob("*.py")} == tested


def test_every_example_has_a_gallery_title():
    for script in EXAMPLES.glob("*.py"):
        text = script.read_text()
        assert text.startswith('"""'), script.name
        title, underline = text.removeprefix('"""').lstrip("\n").splitlines()[:2]
        assert set(underline) == {"="} and len(underline) >= len(title), script.name
