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
    for word in (
        "--quick",
        "--out",
        "--json",
        "--seed",
        "deterministic",
        "measured",
        "Exit status",
        "rig demo --quick",
    ):
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


def test_two_demos_write_the_same_findings_and_a_seed_changes_the_noise(tmp_path, monkeypatch):
    """Deterministic by default (seed 0): two runs into two folders give byte-identical
    findings.json; the seed changes the simulated rig's noise (the FRF test's recorded force).
    The first run is ``rig demo --quick --out DIR --json`` (--quick made the tiny settings here):
    it exits 0 and prints findings.json's document with the files named in full (what `rig demo
    --help`'s JSON example asks; README's `rig demo --quick` is run by test_demo_report.py)."""
    import json
    from dataclasses import replace

    import numpy as np
    from cli_helpers import run_cli

    from rigtools.config import load_rig
    from rigtools.demo import settings, steps
    from rigtools.demo.run import run_demo
    from rigtools.recording import open_recording

    tiny = settings.tiny()
    monkeypatch.setattr(settings, "quick", settings.tiny)
    code, out, err = run_cli(["demo", "--quick", "--out", tmp_path / "a", "--json"])
    assert code == 0 and "Traceback" not in err, err
    printed, written = json.loads(out), json.loads((tmp_path / "a" / "findings.json").read_text())
    assert printed["report"] == str(tmp_path / "a" / "report.html")
    assert printed["files"] == [str(tmp_path / "a" / f) for f in written["files"]] and printed["files"]
    assert {k: v for k, v in printed.items() if k not in ("report", "files")} == {
        k: v for k, v in written.items() if k not in ("report", "files")
    }
    run_demo(tmp_path / "b", tiny)
    assert (tmp_path / "a" / "findings.json").read_bytes() == (tmp_path / "b" / "findings.json").read_bytes()
    # another seed: the demo's FRF test (its first recording, steps.modal_step as run_demo calls
    # it) alone, not a third whole demo (~9 s CPU of which only that recording was compared); the
    # step with seed 0 gives the demo's recording bit for bit, so the difference is the seed's
    cfg = load_rig(None)
    for folder, seed in (("c0", 0), ("c", 7)):
        (tmp_path / folder).mkdir()
        steps.modal_step(cfg, tmp_path / folder, replace(tiny, seed=seed))

    def force(folder):
        with open_recording(tmp_path / folder / "frf_test.h5") as rec:
            return np.asarray(rec.points[0]["force"][:4096])

    assert np.array_equal(force("a"), force("b")) and np.array_equal(force("a"), force("c0"))
    assert not np.array_equal(force("a"), force("c"))
