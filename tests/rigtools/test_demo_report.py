"""``rig demo --quick`` end to end (once, as the README runs it, with every other README command):
recordings, the findings, and the report opened in headless Chromium with every figure drawn and
its axes labelled."""

from __future__ import annotations

import contextlib
import json
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_cli
from headless_chromium import figure_is_drawn, screenshot_page

from rigtools.recording import open_recording

# FRF, harmonic; waveforms + spectra per point; the gap trend, six studies; the FEM's branches in fe
# and in gap at the paper's point
N_FIGURES = 2 + 2 * 2 + 1 + 6 + 2


ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
# set-up, the suite itself, and the contributing checks (.ci/run runs those before the suite)
SKIP = (
    "python3 -m venv",
    "pip install",
    "-m pytest",
    "ruff ",
    "mypy_installed",
    "sphinx-build",
    "pre-commit",
)


def blocks(lang: str) -> list[str]:
    """The fenced code blocks of one language in the README draft (tagged exactly ``lang``; a
    block tagged ``sh cluster`` or ``python cluster`` needs a compute cluster, ``python lab`` the
    NI rig: shown, not run)."""
    return re.findall(rf"```{lang}\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.DOTALL)


def shell_commands() -> list[str]:
    """Every command of the README's sh blocks, install and test steps left out, as run here:
    ``.venv/bin/`` is this interpreter's folder, repository paths are absolute."""
    bindir = str(Path(sys.executable).parent) + "/"
    out = []
    for block in blocks("sh"):
        for line in block.splitlines():
            line = line.split("  #")[0].strip()
            if not line or line.startswith("#"):
                continue
            for part in line.split(" && "):
                if not any(s in part for s in SKIP):
                    out.append(
                        part.replace(".venv/bin/", bindir).replace("rigtools/data/", f"{ROOT}/rigtools/data/")
                    )
    return out


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """Run every README command in order in a fresh folder (``rig demo --quick`` among them): the
    demo's line in a shell as written (README's executable, a second demo beside it), every other
    plain ``rig`` line in this process (:func:`_rig_here`), the rest (``cp``) in a shell."""
    cwd = tmp_path_factory.mktemp("readme")
    ran = []
    second = None
    for cmd in shell_commands():
        if " demo --quick" in cmd and second is None:
            proc, second = _with_a_second_demo(cmd, cwd)
        elif (here := _rig_here(cmd, cwd)) is not None:
            proc = here
        else:
            proc = subprocess.run(
                ["bash", "-c", cmd], cwd=cwd, capture_output=True, text=True, timeout=600, check=False
            )
        hardware = "--rig lab.toml" in cmd and "--backend sim" not in cmd
        allowed = (0, 3) if hardware else (0,)  # 3: NI-DAQmx not on this machine, said in one line
        assert proc.returncode in allowed, f"{cmd}: exit {proc.returncode}\n{proc.stderr[-2000:]}"
        if proc.returncode == 3:
            assert "NI-DAQmx" in proc.stderr and "Traceback" not in proc.stderr
        ran.append(cmd)
    assert any(" demo --quick" in c for c in ran)
    out = cwd / "rig-demo"
    return out, json.loads((out / "findings.json").read_text()), second


def _rig_here(cmd: str, cwd: Path) -> subprocess.CompletedProcess | None:
    """A README line that is one ``rig`` command and nothing else for the shell to do, run in this
    process in ``cwd`` (the same arguments after the shell's quoting; a process per line cost ~2 s
    of CPU for the imports alone); None for any other line."""
    words = shlex.split(cmd)
    if Path(words[0]).name != "rig" or any(c in cmd for c in "|<>;&$`*?"):
        return None
    with contextlib.chdir(cwd):
        code, out, err = run_cli(words[1:])
    return subprocess.CompletedProcess(words, code, out, err)


def _with_a_second_demo(
    cmd: str, cwd: Path
) -> tuple[subprocess.CompletedProcess, subprocess.CompletedProcess]:
    """Run the README's demo and, once it has claimed its folder, a second ``rig demo --quick``
    into the same folder (what a lab does by pressing Enter twice): the README demo's result and
    the second's. One demo run serves both (a demo costs about a minute of the suite)."""
    first = subprocess.Popen(
        ["bash", "-c", cmd], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    marker = cwd / "rig-demo" / ".rig-demo"
    end = time.monotonic() + 120
    while not marker.exists() and first.poll() is None and time.monotonic() < end:
        time.sleep(0.05)
    second = subprocess.run(
        [sys.executable, "-m", "rigtools.cli", "demo", "--quick"],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        stdin=subprocess.DEVNULL,
    )
    out, err = first.communicate(timeout=600)
    return subprocess.CompletedProcess(first.args, first.returncode, out, err), second


def test_readme_python_examples_run(demo):
    out, _, _ = demo
    code = blocks("python")
    assert code
    for block in code:
        proc = subprocess.run(
            [sys.executable, "-c", block],
            cwd=out.parent,
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
        )
        assert proc.returncode == 0, proc.stderr[-2000:]
        # what each prints: the front door's dwell (force held within 1 %), or the demo's impacts
        held = re.search(r"finished ([\d.]+) N", proc.stdout)
        assert "impacts per period" in proc.stdout or (held and abs(float(held.group(1)) - 15.0) < 0.15)


def test_demo_writes_recordings_and_judges_every_finding(demo):
    out, doc, _ = demo
    assert [f["id"] for f in doc["findings"]] == [f"C{i}" for i in range(1, 8)]
    v = {f["id"]: f["verdicts"] for f in doc["findings"]}
    for fid in v:
        assert v[fid]["paper"]["why"]
    # the calibrated rig (docs/calibration.md): the gap trend is reversed at the paper's point and
    # appears at the equivalent point; FEM and AM agree; impacts grow with F0 at both points
    assert v["C4"]["paper"]["holds"] is False and v["C4"]["equivalent"]["holds"] is True
    assert v["C5"]["paper"]["holds"] is True and v["C5"]["equivalent"]["holds"] is True
    assert v["C1"]["paper"]["holds"] is True and v["C2"]["paper"]["holds"] is True
    assert v["C3"]["paper"]["holds"] is True and v["C3"]["equivalent"]["holds"] is True
    assert v["C6"]["paper"]["holds"] is False  # impacts grow with fe until the orbit folds
    assert len(doc["files"]) == 1 + 2 * 2 + 2 * 6 + 1  # and the rig's stepped sine up and down
    for f in doc["files"]:  # named relative to the demo's folder: two folders, one findings.json
        assert not Path(f).is_absolute()
        with open_recording(out / f) as rec:
            assert rec.points and all(p.complete for p in rec.points)
    assert (out / "report.html").exists() and doc["report"] == "report.html"
    assert (out / ".rig-demo").exists() and (out / "gap-trend.png").stat().st_size > 10_000


def test_demo_branches_explain_the_frequency_and_gap_findings(demo):
    """The FEM's branches at the paper's point (tests/sim/test_continuation.py holds them against
    settled runs): in fe the impacting orbit's fold and the grazing corner, each beside the jump
    of the simulated rig's stepped sine it explains; in gap the period doublings and the stable
    period-2 orbit; the report's text quotes the branch files' numbers."""
    from rigtools.branches_file import read_branches
    from rigtools.measured_sweeps import point_contact
    from rigtools.procedures import detect_jumps
    from rigtools.recording import open_recording

    out, doc, _ = demo
    fe, gap = doc["branches"]["frequency"], doc["branches"]["gap"]
    # the period-2 branch switched at the first doubling leaves the range, turns at a grazing
    # hairpin and merges at the second doubling (tests/sim/test_continuation.py)
    assert fe["status"] == ["complete"] and gap["status"] == ["complete", "merged"]
    (fold,) = [t for t in fe["turning_points"] if t["label"] == "fold"]
    (corner,) = [t for t in fe["turning_points"] if t["label"] == "grazing"]
    assert fold["upper"] and fold["value"] == pytest.approx(71.64, abs=0.01)
    assert not corner["upper"] and corner["value"] == pytest.approx(64.41, abs=0.01)
    # the period doublings at a converged time step (tests/sim/test_bifurcation_labels.py: the
    # first against brute force); 0.1 %: the refinement stops at a last change below 0.05 %
    assert len(gap["period_doublings"]) == 2
    pds = [r for r in gap["located"] if r["label"] == "period-doubling" and r["periods"] == 1]
    assert all(r["converged_ok"] for r in pds)
    np.testing.assert_allclose([r["converged"] for r in pds], [1.5591e-3, 2.4014e-3], rtol=1e-3)
    _, stored = read_branches(out / gap["file"])
    p2 = [b for b in stored if b.periods == 2 and b.stable.any()]
    assert p2 and max(b.value[b.stable].max() for b in p2) > 2.3e-3  # born at the 2nd doubling
    (hairpin,) = gap["turning_points"]
    assert hairpin["label"] == "grazing"
    # at a converged step the hairpin is at 0.1521 mm (0.1436 mm at the branch's 328 steps per
    # period; last change at 16x the steps 0.06 %, so within 0.1 %)
    (tip,) = [r for r in gap["located"] if r["label"] == "grazing" and r["value"] == hairpin["value"]]
    assert tip["converged"] == pytest.approx(0.1521e-3, rel=1e-3)
    lowest = min(b.value[b.stable].min() for b in p2)  # stable from just above the hairpin
    assert hairpin["value"] < lowest < 0.3e-3
    assert f"exists from {lowest * 1e3:.4g} mm to" in (out / "report.html").read_text()
    # each jump of the rig's stepped sine holds the FEM's turning point or lies at most 1.5 Hz
    # below it (its natural frequencies lie 1.4-2.3 % below the FEM's): up the fold, down the
    # grazing corner
    (sweep,) = [f for f in doc["files"] if f.startswith("sweep_")]
    with open_recording(out / sweep) as rec:
        runs: dict[str, tuple[list, list, list]] = {}
        for p in rec.complete_points:
            f, a, c = runs.setdefault(str(p.params["direction"]), ([], [], []))
            f.append(float(p.params["fe"]))
            a.append(float(p.params["active_shroud_accel_harmonic_amplitude"][0]))
            c.append(point_contact(p.params))
    (up,) = detect_jumps(*runs["up"][:2], 0.3, contact=runs["up"][2], other=runs["down"][:2])
    (down,) = detect_jumps(*runs["down"][:2], 0.3, contact=runs["down"][2], other=runs["up"][:2])
    assert up["evidence"] == "contact vanishes" and down["evidence"] == "contact appears"
    assert min(up["from_hz"], up["to_hz"]) <= fold["value"] <= max(up["from_hz"], up["to_hz"]) + 1.5
    assert min(down["from_hz"], down["to_hz"]) <= corner["value"] <= max(down["from_hz"], down["to_hz"]) + 1.5
    text = (out / "report.html").read_text()
    assert f"fold (LP) at {fold['value']:.4g} Hz" in text
    assert f"grazing corner at {corner['value']:.4g} Hz" in text
    # the up sweep's sentence says it leaves contact (its evidence above) and where it jumps
    assert (
        f"leaves contact in a jump between {min(up['from_hz'], up['to_hz']):g} Hz and "
        f"{max(up['from_hz'], up['to_hz']):g} Hz"
    ) in text
    assert "period-doubles (PD) at 1.532 mm, 2.405 mm" in text


def test_demo_report_in_chromium_every_figure_drawn_with_labels(demo, chromium):
    out, _doc, _ = demo
    shot = screenshot_page(out / "report.html")
    assert len(shot.figures) == N_FIGURES
    for box in shot.figures:
        assert box.loaded and (box.width, box.height) == (box.natural_width, box.natural_height)
        crop = shot.crop(box)
        assert crop.shape[:2] == (box.natural_height, box.natural_width)
        assert figure_is_drawn(crop)
        dark = np.all(crop < 0.45, axis=-1)
        # y label text in the left margin, x label text along the bottom
        assert dark[:, :40].sum() > 30, "no y-axis label drawn"
        assert dark[-40:, :].sum() > 30, "no x-axis label drawn"
    text = (out / "report.html").read_text()
    for fid in ("C1", "C4", "C7"):
        assert f">{fid}<" in text


def test_a_second_demo_into_the_folder_being_written_is_refused(demo):
    """Two ``rig demo --quick`` into one folder at once: the second is refused in one line (the
    folder is being written, exit 2), the first (the README's) finishes with its report."""
    out, doc, second = demo
    assert second is not None
    assert second.returncode == 2 and "Traceback" not in second.stderr, second.stderr
    assert len(second.stderr.strip().splitlines()) == 1, second.stderr
    assert "being written" in second.stderr, second.stderr
    assert (out / "report.html").is_file() and doc["report"] == "report.html"
