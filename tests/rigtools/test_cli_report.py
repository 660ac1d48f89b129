"""rig report: one self-contained page of real recordings (simulated rig and model runs), opened
in headless Chromium: every figure laid out at its size and drawn, the tables present."""

from __future__ import annotations

import re
import sys

import pytest
from cli_helpers import acquire_dwell, acquire_frf, run_cli


@pytest.fixture(scope="module")
def recordings(tmp_path_factory, sim_recording):
    d = tmp_path_factory.mktemp("rep")
    runs = {
        "frf": acquire_frf("burst", band="20 Hz:1500 Hz", averages=4, seed=2),
        "study": [
            "study",
            "gap",
            "--values",
            "0.4 mm,1 mm",
            "--fe",
            "60",
            "--force",
            "15 N",
            "--duration",
            "0.1 s",
            "--no-plot",
        ],
    }
    # the dwell test_cli_acquire.py records (15 N at 60 Hz, gap 0.5 mm, 12 periods), made once
    paths = {"dwell": sim_recording([*acquire_dwell(periods=12), "--json"], "dwell.h5")}
    for name, argv in runs.items():
        paths[name] = d / f"{name}.h5"
        code, _out, err = run_cli([*argv, "--out", str(paths[name])])
        assert code == 0, err
    return paths


def test_report_opens_in_chromium_with_every_figure_drawn(recordings, tmp_path, monkeypatch, chromium):
    from headless_chromium import figure_is_drawn, screenshot_page

    monkeypatch.setitem(sys.modules, "rigtools.recording_comparison", None)  # comparison not installed
    files = [str(recordings[k]) for k in ("dwell", "frf", "study")]
    code, out, err = run_cli(["report", *files, "--out", str(tmp_path / "rep"), "--simulate"])
    assert code == 0, err
    assert "comparison is not available" in err and len(err.strip().splitlines()) == 1
    n_figures = int(re.search(r"(\d+) figures", out).group(1))
    page = tmp_path / "rep" / "report.html"
    html = page.read_text()
    # self-contained: no external resource
    assert not re.search(r'(src|href)="(?!data:)', html)
    # dwell: 1 waveform figure; frf: FRF of both responses + stabilisation chart of the active;
    # study: 2 waveform figures + trends
    assert n_figures == 1 + 3 + 3
    for caption in ("Periodic points", "Identified modes", "Flexural natural frequencies"):
        assert caption in html
    assert html.count("<table>") >= 4
    assert "No modes from these points" in html
    shot = screenshot_page(page)
    assert len(shot.figures) == n_figures
    for box in shot.figures:
        assert box.loaded
        assert (round(box.width), round(box.height)) == (box.natural_width, box.natural_height)
        assert box.natural_width >= 1000 and box.natural_height >= 400
        crop = shot.crop(box)
        assert crop.shape[:2] == (box.natural_height, box.natural_width)
        assert figure_is_drawn(crop)
    # the page is as wide as its widest figure plus margins, nothing cut
    assert max(b.left + b.width for b in shot.figures) <= 1300


def test_report_refuses_bad_input_and_keeps_foreign_files(recordings, tmp_path):
    code, _out, err = run_cli(["report", str(tmp_path / "none.h5"), "--out", str(tmp_path / "r")])
    assert code == 2 and err.startswith("rig report: error:") and len(err.strip().splitlines()) == 1
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "report.html").write_text("<html>my notes</html>")
    code, _out, err = run_cli(["report", str(recordings["dwell"]), "--out", str(foreign)])
    assert code == 2 and "not overwritten" in err
    assert (foreign / "report.html").read_text() == "<html>my notes</html>"
    code, _out, err = run_cli(["report", str(recordings["dwell"]), "--out", str(recordings["dwell"])])
    assert code == 2
