"""The HTML report in a real headless Chromium: every figure laid out at the size it was made,
drawn (not blank) and equal to the PNG embedded in the page; tables present. ``rig report
--branches``: the FEM's branches over the simulated rig's up/down stepped sine, the numbers the
page shows against the branch file and the recording."""

from __future__ import annotations

import html
import io
import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pytest
from headless_chromium import figure_is_drawn, screenshot_page
from matplotlib import image as mpimg

from rigtools.report import Report, write_report
from rigtools.report.html import figure_png


def _fig(seed):
    t = np.linspace(0, 0.05, 500)
    fig, ax = plt.subplots(figsize=(6, 3))
    ax.plot(t * 1e3, np.sin(2 * np.pi * 60 * t + seed), label="EM")
    ax.plot(t * 1e3, 0.8 * np.sin(2 * np.pi * 60 * t + seed), "--", label="FEM")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("acceleration, peak (m/s²)")
    ax.legend()
    return fig


def test_blank_detector_tells_blank_from_drawn():
    assert not figure_is_drawn(np.ones((50, 50, 3)))
    data, _, _ = figure_png(_fig(0))
    assert figure_is_drawn(mpimg.imread(io.BytesIO(data))[..., :3])


def test_report_figures_drawn_in_chromium(tmp_path, chromium):
    rep = Report("test report", "two figures and a table")
    s = rep.section("Waveforms")
    s.table([{"k": 1, "EM (m/s²)": 10.0, "FEM (m/s²)": 10.5, "difference (%)": 5.0}], caption="harmonics")
    s.figure(_fig(0), "first figure")
    rep.section("More").figure(_fig(1), "second figure")
    page = write_report(rep, tmp_path / "report.html")
    shot = screenshot_page(page)
    assert len(shot.figures) == 2
    for box in shot.figures:
        # shown at its own pixel size; the PNG is the 600 x 300 figure cropped to what is drawn
        assert box.loaded and (box.width, box.height) == (box.natural_width, box.natural_height)
        assert 0.85 * 600 <= box.natural_width <= 600 and 0.85 * 300 <= box.natural_height <= 300
        crop = shot.crop(box)
        assert crop.shape[:2] == (box.natural_height, box.natural_width)
        assert figure_is_drawn(crop)
    # the first figure on screen is the PNG embedded in the page
    data, _, _ = figure_png(_fig(0))
    embedded = mpimg.imread(io.BytesIO(data))[..., :3]
    assert np.mean(np.abs(shot.crop(shot.figures[0]) - embedded)) < 0.02
    assert "harmonics" in page.read_text()


# ------------------------------------------------------------------ branches over a stepped sine


def dom_tables(dom: str) -> dict[str, list[dict[str, str]]]:
    """The tables of a page's DOM by caption: a list of rows, each ``{header: cell text}``."""
    out = {}
    for caption, body in re.findall(r"<table>\s*<caption>(.*?)</caption>(.*?)</table>", dom, re.DOTALL):
        rows = [
            [html.unescape(c) for c in re.findall(r"<t[hd][^>]*>(.*?)</t[hd]>", r, re.DOTALL)]
            for r in re.findall(r"<tr>(.*?)</tr>", body, re.DOTALL)
        ]
        out[html.unescape(caption)] = [dict(zip(rows[0], r, strict=True)) for r in rows[1:]]
    return out


@pytest.fixture(scope="module")
def branches_report(tmp_path_factory, fem_model, fem_frequency_branch):
    """A report of the simulated rig's stepped sine up and down (62-72 Hz in 2 Hz steps, 15 N,
    gap 0.7 mm) with the FEM's branch at the same point (tests/conftest.py, written as ``rig
    continuation`` writes it) drawn over it, as ``rig report --branches`` draws it (its
    analysis figures left out: test_cli_report.py checks those)."""
    from cli_helpers import run_cli

    from rigtools.branches_file import write_branches
    from rigtools.recording_analysis.dispatch import analyze_recording
    from rigtools.report.branches import add_recording_branches, load_branch_files

    d = tmp_path_factory.mktemp("branches")
    sweep = d / "sweep.h5"
    code, _, err = run_cli(
        ["acquire", "sweep", "--backend", "sim", "--seed", "3", "--frequencies", "62 Hz:72 Hz:2 Hz"]
        + ["--force", "15 N", "--gap", "0.7 mm", "--direction", "both", "--periods", "5", "--out", sweep]
    )
    assert code == 0, err
    experiment = {"procedure": "continuation", "param": "fe", "from": 55.0, "to": 80.0}
    experiment |= {"fe": 60.0, "force": 15.0, "gap": 0.7e-3, "model": "fem", "measured": []}
    branch_file = write_branches(
        d / "branches-fe.h5", [fem_frequency_branch], fem_model[0].to_json(), experiment
    )
    rep = Report("branches over a stepped sine", "sweep.h5")
    files = load_branch_files([branch_file])
    add_recording_branches(rep.section("sweep.h5: stepped sine"), analyze_recording(sweep), files)
    assert files[0].used
    return sweep, branch_file, write_report(rep, d / "report.html")


def test_branches_over_the_rigs_stepped_sine_in_chromium(branches_report, chromium):
    """The figure of the FEM's branches with the simulated rig's up/down stepped sine is laid out
    at its size, drawn, its alt text its caption; the tables the browser shows hold the branch
    file's bifurcations (6 digits) and the recording's jumps, and the fold the text names lies
    inside the up sweep's jump as the tables say."""
    from rigtools.analysis.branches import SHORT
    from rigtools.branches_file import read_branches
    from rigtools.measured_sweeps import point_contact
    from rigtools.procedures import detect_jumps
    from rigtools.recording import open_recording

    sweep, branch_file, page = branches_report
    shot = screenshot_page(page)
    (box,) = [b for b in shot.figures if b.alt.startswith("branches-fe.h5")]
    assert box.loaded and (box.width, box.height) == (box.natural_width, box.natural_height)
    assert (
        850 <= box.natural_width <= 950 and 400 <= box.natural_height <= 500
    )  # 9.5 x 5 in at 100 dpi (the legend beside the axes), cropped
    assert figure_is_drawn(shot.crop(box))
    assert box.caption == box.alt
    assert "sweep (up), sweep (down) (up ^, down v), their jumps shaded" in box.alt
    assert "(FEM, F0 15 N, gap 0.7 mm)" in box.alt

    tables = dom_tables(shot.dom)
    bif = tables["branches-fe.h5 (FEM, F0 15 N, gap 0.7 mm): bifurcations of the branches"]
    _, (stored,) = read_branches(branch_file)
    want = [
        (f"{lab} ({SHORT[lab]})", v, s)
        for v, s, labs in zip(stored.value, stored.stable, stored.labels, strict=True)
        for lab in labs
        if lab in SHORT
    ]
    assert [r["bifurcation"] for r in bif] == [w[0] for w in want]
    # shown to 4 significant digits (rigtools.readable): within half a unit of the 4th digit
    np.testing.assert_allclose([float(r["fe (Hz)"]) for r in bif], [w[1] for w in want], rtol=5e-4)
    assert [r["stable"] for r in bif] == ["yes" if w[2] else "no" for w in want]
    (fold,) = [r for r in bif if r["bifurcation"] == "fold (LP)" and r["turning point"] == "upper"]
    assert fold["turning point"] == "upper" and 71.5 < float(fold["fe (Hz)"]) < 71.8  # 71.64 Hz

    # the jumps the table shows are the recording's: its own fundamentals, in run order
    with open_recording(sweep) as rec:
        runs: dict[str, tuple[list, list, list]] = {}
        for p in rec.complete_points:
            f, a, c = runs.setdefault(str(p.params["direction"]), ([], [], []))
            f.append(float(p.params["fe"]))
            a.append(float(p.params["active_shroud_accel_harmonic_amplitude"][0]))
            c.append(point_contact(p.params))
    recorded = sorted(
        (d, min(j["from_hz"], j["to_hz"]), max(j["from_hz"], j["to_hz"]))
        for d, (f, a, c) in runs.items()
        for j in detect_jumps(f, a, 0.3, contact=c, other=runs["down" if d == "up" else "up"][:2])
    )
    jumps = tables["Measured jumps and the model's turning points (offset 0: inside the jump)"]
    shown = sorted((r["direction"], float(r["jump from (Hz)"]), float(r["jump to (Hz)"])) for r in jumps)
    assert shown == recorded == [("down", 64.0, 66.0), ("up", 70.0, 72.0)]
    text = html.unescape(shot.dom)
    for r in jumps:
        lo, hi, at = float(r["jump from (Hz)"]), float(r["jump to (Hz)"]), float(r["at (Hz)"])
        kind = r["turning point"].split(" (")[0]
        (turn,) = [b for b in bif if b["bifurcation"].startswith(kind) and b["turning point"]]
        assert float(turn["fe (Hz)"]) == at
        inside = lo <= at <= hi
        assert r["inside the jump"] == ("yes" if inside else "no")
        offset = 0.0 if inside else (at - hi if at > hi else at - lo)
        assert float(r["offset (Hz)"]) == pytest.approx(offset, abs=1e-4)
        assert f"in a jump between {lo:g} Hz and {hi:g} Hz" in text  # the sweep leaves or makes contact
    # the up sweep's jump is the fold, the down sweep's the grazing corner, as the text says
    up = next(r for r in jumps if r["direction"] == "up")
    assert up["turning point"] == "fold (upper)" and up["inside the jump"] == "yes"
    assert f"the model's fold (LP) at {float(fold['fe (Hz)']):.4g} Hz lies inside it" in text
    down = next(r for r in jumps if r["direction"] == "down")
    assert down["turning point"] == "grazing (lower)" and down["inside the jump"] == "yes"
    assert 64.3 < float(down["at (Hz)"]) < 64.5  # 64.41 Hz
