"""``rig demo`` input errors: one line, exit 2, nothing run."""

from __future__ import annotations

import subprocess
import sys


def test_out_that_is_a_file_is_refused(tmp_path):
    f = tmp_path / "taken"
    f.write_text("x")
    proc = subprocess.run(
        [sys.executable, "-m", "rigtools.cli", "demo", "--quick", "--out", str(f)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [f"rig demo: error: --out {f}: exists and is not a folder"]
    assert f.read_text() == "x"


def test_help_teaches_the_options():
    proc = subprocess.run(
        [sys.executable, "-m", "rigtools.cli", "demo", "--help"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0
    for word in ("--quick", "--out", "--json", "Exit status", "rig demo --quick"):
        assert word in proc.stdout


def test_out_holding_other_files_is_refused(tmp_path):
    (tmp_path / "mine.h5").write_text("x")
    proc = subprocess.run(
        [sys.executable, "-m", "rigtools.cli", "demo", "--quick", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 2
    assert "holds files that a demo did not write" in proc.stderr
    assert (tmp_path / "mine.h5").read_text() == "x"
