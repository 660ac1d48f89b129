"""The HTML report in a real headless Chromium: every figure laid out at the size it was made,
drawn (not blank) and equal to the PNG embedded in the page; tables present."""

from __future__ import annotations

import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib import image as mpimg

from rigtools.report import Report, write_report
from rigtools.report.browser import figure_is_drawn, screenshot_page
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
