"""The monitor of a controlled test (rigtools.monitor.controlled): a PLL's phase and lock, a CBC's
control effort and iterations, and the points growing (A against fe; F1 against A), each number
the one its procedure wrote (read back here with h5py), the live phase against a closed form,
and the page in headless Chromium. Simulated rig, gap 0.5 mm: one PLL point (5 N, -90 deg), two
CBC points at 64 Hz."""

from __future__ import annotations

import math
import re
import subprocess
import sys
import threading

import h5py
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import rigtools
from rigtools.analysis.harmonics import harmonic_amplitudes
from rigtools.monitor import controlled
from rigtools.monitor.follow import Follower
from rigtools.readable import number

RATE = 51200.0


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    d = tmp_path_factory.mktemp("controlled")
    pll = rigtools.phase_locked_loop("5 N", d / "pll.h5", gap="0.5 mm", backend="sim")
    cbc = rigtools.control_based_continuation(
        "64 Hz", "0.330 mm,0.335 mm", d / "cbc.h5", gap="0.5 mm", backend="sim"
    )
    return pll.file, cbc.file


def _attrs(path) -> list[dict]:
    with h5py.File(path, "r") as f:
        return [dict(f["points"][k].attrs) for k in sorted(f["points"])]


@settings(max_examples=20, deadline=None)
@given(phase=st.floats(-359.0, -1.0), fe=st.floats(40.0, 80.0))
def test_live_phase_is_the_displacements_lag_to_the_force(phase, fe):
    """x = A cos(wt + phi) under F cos(wt): the acceleration -w^2 x gives back phi (closed form),
    over whole periods with harmonics added to both (they must not move the fundamental's phase;
    tolerance 1e-6 deg: round-off of a least-squares fit on whole periods)."""
    n = round(20 * RATE / fe)
    t = np.arange(n) / RATE
    fe_exact = 20 * RATE / n  # whole periods in the window
    w = 2 * math.pi * fe_exact
    force = 5 * np.cos(w * t) + 1.5 * np.cos(2 * w * t + 0.3)
    accel = -(w**2) * 3e-4 * np.cos(w * t + math.radians(phase)) + 40 * np.cos(3 * w * t)
    got = controlled.live_phase_deg(force, accel, RATE, fe_exact, harmonic_amplitudes)
    assert -360.0 < got <= 0.0
    assert got == pytest.approx(phase, abs=1e-6)


def test_ended_points_show_what_the_procedure_wrote(recordings):
    """Each row holds the point's fields as written; the phase shown is the last point's; the
    state is locked / converged; the trend holds (fe, A mm) for the PLL and (A mm, F1) for the CBC."""
    pll, cbc = recordings
    for path, kind, state in ((pll, "pll", "locked"), (cbc, "cbc", "converged")):
        s = Follower(path).poll()
        attrs = _attrs(path)
        assert s.kind == kind and s.status == "finished" and len(s.points) == len(attrs)
        for row, a in zip(s.points, attrs, strict=True):
            for name in ("fe_hz", "amplitude_m", "force_fundamental_n", "phase_deg", "iterations"):
                assert row[name] == a[name], name
        assert s.phase_deg == attrs[-1]["phase_deg"]
        assert s.controlled_state == (state if attrs[-1]["converged"] else f"NOT {state}")
        series = controlled.trend(kind, s.points)
        ok = [a for a in attrs if a["converged"]]
        x, y = (
            ([a["fe_hz"] for a in ok], [a["amplitude_m"] * 1e3 for a in ok])
            if kind == "pll"
            else ([a["amplitude_m"] * 1e3 for a in ok], [a["force_fundamental_n"] for a in ok])
        )
        assert series["converged"] == {"x": x, "y": y}
    assert "control_effort" in s.points[-1] and s.points[-1]["control_effort"] == attrs[-1]["control_effort"]


def test_a_damaged_field_is_left_out_not_fatal(recordings, tmp_path):
    """A controlled point whose fields a script overwrote (fe_hz "sixty", converged "no",
    amplitude_m a string) still shows: the unreadable values are left out of its row, the
    others kept. Before the fix the follower raised ValueError on every look: a blank page, and
    rig monitor never ended."""
    path = tmp_path / "edited.h5"
    path.write_bytes(recordings[0].read_bytes())
    with h5py.File(path, "r+") as f:
        point = f["points/0000"]
        force = float(point.attrs["force_fundamental_n"])
        point.attrs["fe_hz"] = "sixty"
        point.attrs["converged"] = "no"
        point.attrs["amplitude_m"] = "a lot"
    s = Follower(path).poll()
    row = s.points[0]
    assert s.status == "finished" and len(s.points) == 1
    assert "fe_hz" not in row and "converged" not in row and "amplitude_m" not in row
    assert row["force_fundamental_n"] == force


@pytest.mark.parametrize("damage", ["truncated", "flipped"])
def test_monitor_of_an_unreadable_ended_recording_says_so(recordings, tmp_path, damage):
    """``rig monitor`` on an ended recording that cannot be read (cut to half its size, or its
    one byte in ~500 flipped past its first quarter) says so in one line naming the file and exits 2; before the fix it
    served a page saying nothing ("waiting for the recording") and never ended, --linger or not.
    The 120 s timeout guards against that hang (not a timing assertion)."""
    data = bytearray(recordings[0].read_bytes())
    if damage == "truncated":
        data = data[: len(data) // 2]
    else:
        for i in range(len(data) // 4, len(data), len(data) // 4000):  # every chunk hit
            data[i] ^= 0xFF
    path = tmp_path / f"{damage}.h5"
    path.write_bytes(bytes(data))
    done = subprocess.run(
        [sys.executable, "-m", "rigtools.cli", "monitor", str(path), "--linger", "1"],
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
    )
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1, done.stderr
    assert lines[0].startswith("rig monitor: error: ") and str(path) in lines[0]
    assert done.stdout == ""  # no address printed: nothing is served


def test_monitor_help_teaches_what_it_shows_of_pll_and_cbc(capsys):
    """``rig monitor --help`` says what a PLL and a CBC recording add to the page."""
    from rigtools.cli import main

    with pytest.raises(SystemExit):
        main(["monitor", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "phase-locked loop (rig acquire pll) adds its phase and lock" in text
    assert "control-based continuation (rig acquire cbc) its control effort and iterations" in text


def test_pll_states_in_words():
    """While a point runs, the PLL's events say where the loop is; once written, its convergence."""
    assert controlled.state_text("pll", {}, {"kind": "control"}, [], 0) == "locking"
    assert controlled.state_text("pll", {}, {"kind": "recording"}, [], 0) == "locked, recording"
    row = {"point": 0, "converged": False}
    assert controlled.state_text("pll", {}, {"kind": "control"}, [row], 0) == "NOT locked"
    for title, xlabel, ylabel in controlled.TRENDS.values():  # units on every axis
        assert all(label.endswith(("(Hz)", "(mm)", "(N)")) for label in (xlabel, ylabel)), title


def test_page_shows_phase_lock_effort_and_iterations_in_chromium(recordings, chromium, tmp_path):
    """``rig monitor`` on the CBC recording, then the PLL's, in headless Chromium: the panel shows the
    last point's phase, state, control effort / periods to lock and iterations as written, and the
    trend is drawn."""
    from headless_chromium import Chromium, figure_is_drawn
    from matplotlib import image as mpimg

    for path, want in zip(recordings, ("pll", "cbc"), strict=True):
        last = _attrs(path)[-1]
        cmd = [sys.executable, "-m", "rigtools.cli", "monitor", str(path), "--port", "0"]
        server = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        timer = threading.Timer(90, server.kill)
        timer.start()
        try:
            url = server.stdout.readline().strip()
            with Chromium(chromium) as browser:
                page = browser.open(url)
                page.wait_text("mon-status", 60, "finished")
                phase = number(last["phase_deg"], ".2f", "deg")
                page.wait_text("mon-phase-deg", 30, re.escape(phase))  # the panel follows the header
                shown = page.texts("mon-phase-deg", "mon-lock", "mon-iterations")
                assert shown["mon-phase-deg"] == phase
                assert shown["mon-iterations"] == number(int(last["iterations"]))
                word = "locked" if want == "pll" else "converged"
                assert shown["mon-lock"] == (word if last["converged"] else f"NOT {word}")
                if want == "cbc":
                    effort = page.texts("mon-effort")["mon-effort"]
                    assert effort == number(float(last["control_effort"]), ".3g", "V")
                shot = mpimg.imread(str(page.screenshot(tmp_path / f"monitor-{want}.png")))[..., :3]
        finally:
            timer.cancel()
            server.kill()
            server.wait()
        assert figure_is_drawn(shot[60:560, 0:800])  # the traces


def test_check_names_a_controlled_points_damaged_fields_and_the_report_leaves_it_out(recordings, tmp_path):
    """``rig check`` of a PLL recording whose first point a script edited (fe_hz "sixty",
    converged "yes", iterations 2.5, drive_harmonics_ratio deleted): one note per field naming it
    (before: nothing; notes, not errors: the samples are intact, so every reader still takes the
    file); the report's points are the untouched ones (before: float("sixty") raised)."""
    from rigtools.recording import check_recording, open_recording
    from rigtools.report.controlled_branch import controlled_points

    path = tmp_path / "edited.h5"
    path.write_bytes(recordings[0].read_bytes())
    whole = controlled_points(recordings[0])
    with h5py.File(path, "r+") as f:
        point = f["points/0000"]
        point.attrs["fe_hz"] = "sixty"
        point.attrs["converged"] = "yes"
        point.attrs["iterations"] = 2.5
        del point.attrs["drive_harmonics_ratio"]
    result = check_recording(path)
    lines = [p.line() for p in result.problems if p.severity == "note"]
    assert result.valid
    end = ": rig report leaves the point out"
    assert "/points/0000: controlled-point field 'fe_hz' = 'sixty' is not a number" + end in lines
    assert "/points/0000: controlled-point field 'converged' = 'yes' is not a bool" + end in lines
    assert "/points/0000: controlled-point field 'iterations' = 2.5 is not a whole number >= 0" + end in lines
    assert "/points/0000: a controlled point without drive_harmonics_ratio: rig report leaves it out" in lines
    assert not any("/points/0001" in line for line in lines)
    assert not [p for p in check_recording(recordings[0]).problems if "controlled" in p.message]
    with open_recording(path) as rec:
        assert rec.points[0]["force"].size > 0  # the samples are kept and readable
    assert controlled_points(path) == whole[1:]
