"""The figure a lab shows of a nonlinear test (rigtools.report.controlled_overview), as ``rig
report`` puts it into the page: short PLL, CBC and stepped-sine runs on the simulated rig (gap
0.5 mm, 5 N), branch files standing in for ``rig continuation --model rig`` (their shapes are not
under test: the model's numbers are checked in test_cbc.py and test_pll.py), the page looked at in
a real headless Chromium."""

from __future__ import annotations

import math
from pathlib import Path

import h5py
import numpy as np
import pytest
from headless_chromium import figure_is_drawn, screenshot_page

import rigtools
from rigtools.branches_file import StoredBranch
from rigtools.recording_analysis.dispatch import analyze_recording
from rigtools.report import Report, write_report
from rigtools.report.branches import BranchFile
from rigtools.report.controlled_overview import (
    add_controlled_overview,
    collect_overview,
    overview_figure,
    sweep_curves,
)

FE = 64.0  # Hz, the CBC's


def _branch(param: str, value: np.ndarray, amplitude_m: np.ndarray, fe: np.ndarray, stable) -> StoredBranch:
    """A stored branch whose orbits have the active shroud's displacement fundamental ``amplitude_m``
    (its acceleration fundamental stored, as the continuation stores it)."""
    accel = amplitude_m * (2 * math.pi * fe) ** 2
    n = value.size
    return StoredBranch(
        param=param,
        periods=1,
        status="complete",
        message="",
        value=value,
        stable=np.asarray(stable, bool),
        multipliers=np.zeros((n, 2), complex),
        labels=[()] * n,
        measures={"accel_harmonics_active": np.column_stack([accel, 0.1 * accel])},
    )


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """One PLL point (5 N, -90 deg), two CBC points at 64 Hz (stable and unstable side of the F1
    minimum), a stepped sine up and down 63-65 Hz at 5 N; and two branch files: one in frequency
    at 5 N, one in force at 64 Hz (a parabola, stable below 0.3425 mm as the model's)."""
    d = tmp_path_factory.mktemp("overview")
    pll = rigtools.phase_locked_loop("5 N", d / "pll.h5", gap="0.5 mm", backend="sim")
    cbc = rigtools.control_based_continuation(
        "64 Hz", "0.330 mm,0.345 mm", d / "cbc.h5", gap="0.5 mm", backend="sim"
    )
    sweep = rigtools.stepped_sine(
        "63 Hz:65 Hz:1 Hz", "5 N", d / "sweep.h5", gap="0.5 mm", direction="both", backend="sim"
    )
    fe = np.linspace(50.0, 67.0, 60)
    a_fe = 0.3e-3 + 2.4e-3 * np.exp(-(((fe - 52.7) / 1.5) ** 2))
    a_force = np.linspace(0.31e-3, 0.37e-3, 40)
    f_force = 4.656 + 2.0e7 * (a_force - 0.328e-3) ** 2
    files = [
        BranchFile(
            Path(d / "in-fe.h5"),
            {"param": "fe", "force": 5.0, "gap": 0.5e-3, "model": "rig"},
            [_branch("fe", fe, a_fe, fe, fe < 60)],
            "",
        ),
        BranchFile(
            Path(d / "in-force.h5"),
            {"param": "force", "fe": FE, "gap": 0.5e-3, "model": "rig"},
            [_branch("force", f_force, a_force, np.full(40, FE), a_force < 0.3425e-3)],
            "",
        ),
    ]
    return pll, cbc, sweep, files, d


def _attrs(path: Path) -> list[dict]:
    """The points' attributes as h5py reads them (not through rigtools' reader)."""
    with h5py.File(path, "r") as f:
        return [dict(f["points"][k].attrs) for k in sorted(f["points"])]


def test_figure_holds_each_measurement_where_it_belongs(runs):
    """The left panel holds the PLL point, the CBC points at their fe and the sweep's up and down
    curves (A from its acceleration fundamental over (2 pi fe)^2); the right the CBC points at (A,
    F1) and the model's force branch, stable solid then unstable dashed; every axis has its unit."""
    pll, cbc, sweep, files, _ = runs
    paths = [
        ("phase-locked loop", pll.file),
        ("control-based continuation", cbc.file),
        ("stepped sine", sweep.file),
    ]
    ov = collect_overview(paths, files)
    assert [bf.path.name for bf in ov.force_files] == ["in-force.h5"] and ov.cbc_fe == pytest.approx(FE)
    fig = overview_figure(ov)
    left, right = fig.axes
    for ax in (left, right):
        assert all(u in ax.get_xlabel() + ax.get_ylabel() for u in ("(", ")")), ax.get_xlabel()
    assert "(Hz)" in left.get_xlabel() and "(mm)" in left.get_ylabel()
    assert "(mm)" in right.get_xlabel() and "(N)" in right.get_ylabel()

    def lines(ax, label):
        return [ln for ln in ax.get_lines() if ln.get_label() == label]

    cbc_attrs = _attrs(cbc.file)
    (cbc_right,) = lines(right, "CBC") or lines(right, "CBC, not converged")
    converged = [a for a in cbc_attrs if bool(a["converged"])]
    np.testing.assert_allclose(cbc_right.get_xdata(), [a["amplitude_m"] * 1e3 for a in converged], rtol=1e-12)
    np.testing.assert_allclose(
        cbc_right.get_ydata(), [a["force_fundamental_n"] for a in converged], rtol=1e-12
    )
    (cbc_left,) = lines(left, "CBC")
    np.testing.assert_allclose(cbc_left.get_xdata(), FE, rtol=1e-9)
    (pll_left,) = lines(left, "PLL")
    (p,) = _attrs(pll.file)
    assert (pll_left.get_xdata()[0], pll_left.get_ydata()[0]) == pytest.approx(
        (p["fe_hz"], p["amplitude_m"] * 1e3)
    )
    # the sweep as a lab reads it: each point's acceleration fundamental over (2 pi fe)^2
    want = {}
    for a in _attrs(sweep.file):
        fe = float(a["fe"])
        want.setdefault(str(a["direction"]), []).append(
            (fe, a["active_shroud_accel_harmonic_amplitude"][0] / (2 * math.pi * fe) ** 2 * 1e3)
        )
    for direction in ("up", "down"):
        (ln,) = lines(left, f"stepped sine, {direction}")
        np.testing.assert_allclose(
            np.column_stack([ln.get_xdata(), ln.get_ydata()]), want[direction], rtol=1e-12
        )
    assert {c.direction for c in sweep_curves(sweep.file)} == {"up", "down"}
    styles = [
        (ln.get_linestyle(), ln.get_label()) for ln in right.get_lines() if ln.get_label().startswith("model")
    ]
    assert styles == [("-", "model, stable"), ("--", "model, unstable")]


def test_report_page_in_chromium(runs, chromium):
    """The section rig report adds: its figure laid out at its own size, drawn (not blank), its
    caption saying what is where; both branch files marked used (not drawn again alone)."""
    pll, cbc, sweep, files, d = runs
    rep = Report("nonlinear test", "pll.h5, cbc.h5, sweep.h5")
    add_controlled_overview(rep, [analyze_recording(f) for f in (pll.file, cbc.file, sweep.file)], files)
    assert all(bf.used for bf in files)
    page = write_report(rep, d / "report.html")
    shot = screenshot_page(page)
    (box,) = shot.figures
    assert box.loaded and (box.width, box.height) == (box.natural_width, box.natural_height)
    assert (
        1000 <= box.natural_width <= 1200 and 420 <= box.natural_height <= 500
    )  # 11 x 4.6 in at 100 dpi, cropped to what is drawn
    assert figure_is_drawn(shot.crop(box))
    assert box.caption == box.alt
    for words in (
        "Left: A (the active shroud's displacement fundamental) against fe",
        "in-fe.h5, F0 5 N, gap 0.5 mm), stable solid, unstable dashed",
        "the stepped sine up (triangles up) and down (triangles down)",
        "the PLL's points (circles, labelled by their phase of A to F1)",
        "the CBC's points (diamonds) on the dotted line at its fe 64 Hz",
        "Right: F1 against A at fe 64 Hz, the CBC's S-curve over the model's orbits continued in force (in-force.h5",
    ):
        assert words in box.alt, (words, box.alt)
