"""The breaker's findings left open after session 11, each with the command that showed it:
now one clear line, the record kept whole, or the right answer. Files are built here from
known arrays (``test_bad_input._write_recording``: two points of 60/61 Hz sines)."""

from __future__ import annotations

import json
import re

import h5py
import pytest
from cli_helpers import run_cli
from test_bad_input import _write_recording


def _one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


# ------------------------------------------------------------ 1: export of a point a stop cut
def _stopped_inside_point_1(path):
    """Point 1 ended by its writer (end_time set, as ``RecordingWriter.abort`` does) but with
    ``point_complete`` false: the procedure was stopped inside it, its samples a truncated record."""
    _write_recording(path)
    with h5py.File(path, "r+") as f:
        f["points/0000"].attrs["point_complete"] = True
        f["points/0001"].attrs["point_complete"] = False
        f.attrs["status"] = "aborted"
        f.attrs["abort_reason"] = "aborted: SIGINT"
    return path


@pytest.mark.parametrize("json_flag", [False, True])
def test_export_uff_skips_a_point_a_stop_cut_and_names_it(tmp_path, json_flag):
    import pyuff

    src = _stopped_inside_point_1(tmp_path / "cut.h5")
    out = tmp_path / "c.uff"
    code, stdout, err = run_cli(["export", "uff", src, out] + (["--json"] if json_flag else []))
    assert code == 0, err
    line = _one_line(err)
    assert line == (
        "point 1 not exported: the run was stopped inside it (point_complete false), its record is cut short"
    )
    if json_flag:
        doc = json.loads(stdout)
        assert doc["skipped_incomplete_points"] == [1]
        assert doc["datasets"] == {"time": 4, "spectra": 4}  # four channels of point 0 only
    names = [s["id1"] for s in pyuff.UFF(str(out)).read_sets() if s["type"] == 58]
    assert len(names) == 8 and all(n.startswith("point 0000") for n in names)


def test_export_uff_of_only_stopped_points_is_one_line(tmp_path):
    src = _stopped_inside_point_1(tmp_path / "cut.h5")
    with h5py.File(src, "r+") as f:
        f["points/0000"].attrs["point_complete"] = False
    code, _, err = run_cli(["export", "uff", src, tmp_path / "c.uff"])
    assert code == 2
    assert _one_line(err) == f"rig export: error: {src}: the recording has no complete points to export"
    assert not (tmp_path / "c.uff").exists()


# --------------------------------------------------------------- 2: an empty item in a value list
@pytest.mark.parametrize(
    ("text", "line"),
    [
        ("0.32 mm,,0.33 mm", "--amplitude = '0.32 mm,,0.33 mm': item 2 is empty (two commas in a row)"),
        ("0.32 mm,0.33 mm,", "--amplitude = '0.32 mm,0.33 mm,': item 3 is empty (a comma at an end)"),
        (",0.32 mm", "--amplitude = ',0.32 mm': item 1 is empty (a comma at an end)"),
    ],
)
def test_value_list_names_an_empty_item(text, line):
    from rigtools.errors import UserError
    from rigtools.options import value_list

    with pytest.raises(UserError) as e:
        value_list(text, "amplitude", "--amplitude")
    assert str(e.value) == line
    assert value_list("0.32 mm, 0.33 mm", "amplitude", "--amplitude") == pytest.approx([0.32e-3, 0.33e-3])


def test_an_empty_item_on_the_command_line_is_one_line(tmp_path):
    code, _, err = run_cli(["study", "force", "--values", "5 N,,10 N", "--out", tmp_path / "s.h5"])
    assert code == 2
    assert _one_line(err).endswith("--values = '5 N,,10 N': item 2 is empty (two commas in a row)")
    assert not (tmp_path / "s.h5").exists()


# ------------------------------------------------- 3: the monitor's options without --monitor
@pytest.mark.parametrize(
    ("extra", "line"),
    [
        (["--allow-stop"], "--allow-stop needs --monitor"),
        (["--monitor-linger", "5 s"], "--monitor-linger needs --monitor"),
        (["--monitor-port", "5006"], "--monitor-port needs --monitor"),
        (["--allow-stop", "--monitor-linger", "0"], "--allow-stop and --monitor-linger need --monitor"),
    ],
)
@pytest.mark.parametrize(
    "procedure",
    [
        ["dwell", "--fe", "60 Hz", "--force", "5 N"],
        ["cbc", "--fe", "60 Hz", "--amplitude", "0.3 mm"],
        ["pll", "--force", "5 N"],
    ],
)
def test_monitor_options_without_monitor_are_one_line(tmp_path, procedure, extra, line):
    code, _, err = run_cli(["acquire", *procedure, "--backend", "sim", "--out", tmp_path / "r.h5", *extra])
    assert code == 2
    assert f"error: {line} (no monitor is started without it" in _one_line(err)
    assert not (tmp_path / "r.h5").exists()


# ------------------------------------- 4: a CBC point that did not converge says why no multipliers
class _MeasuringLoop:
    """A real-time loop's multiplier measurement, counting its calls."""

    def __init__(self) -> None:
        self.calls = 0

    def multipliers(self, measurement):
        self.calls += 1
        raise AssertionError("a point that did not converge is never measured")


@pytest.mark.parametrize("wanted", [True, False])
def test_a_cbc_point_that_did_not_converge_says_why_it_has_no_multipliers(wanted):
    """ControlBasedContinuation._stability decides per point: a converged point is measured, one
    that did not converge records ``multipliers_not_measured`` (so every point of a real-time run
    carries one or the other); with multipliers=False nothing is tried and nothing is said."""
    from types import SimpleNamespace

    from rigtools.procedures.cbc import CBCPoint, ControlBasedContinuation

    run = SimpleNamespace(params=SimpleNamespace(multipliers=wanted), emit=lambda *a, **k: None)
    pt = SimpleNamespace(point=SimpleNamespace(converged=False), multipliers=None, stability={})
    loop = _MeasuringLoop()
    ControlBasedContinuation._stability(run, loop, pt)
    assert loop.calls == 0
    fields = CBCPoint.multiplier_fields(pt)
    assert fields == ({"multipliers_not_measured": "the point did not converge"} if wanted else {})


# ------------------------------------------------------ 5: rig monitor on a file that never appears
def test_monitor_of_a_file_that_never_appears_ends_after_its_linger(tmp_path):
    """``rig monitor`` waits for a FILE that does not exist yet (a run about to start); with
    --linger it waits at most that long, then says so in one line and exits 2 (before the fix it
    waited for ever, --linger or not). The 120 s timeout guards against that hang (not a timing
    assertion)."""
    import subprocess
    import sys

    path = tmp_path / "typo.h5"
    done = subprocess.run(
        [sys.executable, "-m", "rigtools.cli", "monitor", str(path), "--port", "0", "--linger", "0.5"],
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
    )
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2, done.stderr
    assert lines == [
        f"rig monitor: waiting for {path} (at most 0.5 s: --linger); Ctrl-C ends the monitor (never the run)",
        f"rig monitor: error: {path} does not exist, and did not appear within --linger 0.5 s",
    ]
    assert not path.exists()


# ------------------------------------------- 6: --json of a run that stopped or failed
def test_json_of_a_failed_dwell_is_printed_before_its_line(tmp_path):
    """Exit 5 (the force target beyond the rig's limits): stdout still holds the run's JSON
    document (status failed, the reason, the file, the point recorded), as read from the file."""
    from rigtools.recording import open_recording

    out = tmp_path / "f.h5"
    argv = [
        "acquire",
        "dwell",
        "--backend",
        "sim",
        "--fe",
        "60 Hz",
        "--force",
        "1 kN",
        "--out",
        out,
        "--json",
    ]
    code, stdout, err = run_cli(argv)
    assert code == 5
    assert "cannot be reached at 60 Hz" in _one_line(err)
    doc = json.loads(stdout)
    with open_recording(out) as rec:
        assert rec.attrs["end_status"] == "failed"  # the file: status aborted, how it ended: failed
        params = rec.points[0].params
    assert doc["status"] == "failed" and doc["file"] == str(out) and doc["procedure"] == "dwell"
    assert doc["reason"].startswith("--force 1000 N cannot be reached at 60 Hz")
    assert doc["reason"] in _one_line(err)
    assert doc["force_amplitude_measured"] == params["force_amplitude_measured"]
    assert doc["settled"] is False


def test_json_of_a_dwell_stopped_by_sigterm(tmp_path):
    """SIGTERM mid-dwell: exit 143, and --json still prints the document (status aborted, the
    recording's reason, the file) before the one line on stderr. The signal is sent once the
    dwell has 1 s on disk (a wait with a 600 s safety net, not a timing)."""
    import signal
    import subprocess
    import sys
    import time

    from cli_helpers import acquire_dwell

    from rigtools.recording import open_recording

    out = tmp_path / "d.h5"
    child = subprocess.Popen(
        [sys.executable, "-m", "rigtools.cli", *acquire_dwell(periods=6000), "--out", str(out), "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )

    def samples() -> int:
        try:
            with open_recording(out) as rec:
                return rec.points[0].n_samples if rec.points else 0
        except Exception:  # noqa: BLE001 - the writer is between phases: look again
            return 0

    end = time.monotonic() + 600
    while child.poll() is None and samples() < 51200 and time.monotonic() < end:
        time.sleep(0.05)
    assert child.poll() is None, child.communicate()
    child.send_signal(signal.SIGTERM)
    stdout, stderr = child.communicate(timeout=600)
    assert child.returncode == 143, stderr
    assert "interrupted" in _one_line(stderr)
    doc = json.loads(stdout)
    with open_recording(out) as rec:
        assert rec.status == "aborted"
        reason = rec.abort_reason
    assert doc["status"] == "aborted" and doc["file"] == str(out) and doc["procedure"] == "dwell"
    assert reason == f"aborted: {doc['reason']}" and doc["reason"].startswith("signal SIGTERM")


# ---------------------------------------- 7: rig info's other parameters with their units


def _info_text(path, monkeypatch) -> str:
    """``rig info path``'s output in a wide table (each point's cell on one line), whitespace
    runs joined to one space; the command must succeed."""
    monkeypatch.setenv("COLUMNS", "400")
    code, out, err = run_cli(["info", path])
    assert code == 0, err
    return " ".join(out.split())


def test_info_shows_the_units_of_the_other_parameters(tmp_path, monkeypatch):
    """A CBC point's parameters that have no column of their own are shown with the SI units
    the vocabulary gives them (amplitude_target in m, feedforward_amplitude in V, ...); ratios and
    flags without any."""
    path = _write_recording(tmp_path / "c.h5")
    with h5py.File(path, "r+") as f:
        attrs = f["points/0000"].attrs
        attrs["amplitude_target"] = 0.00032
        attrs["feedforward_amplitude"] = 1.25
        attrs["control_effort"] = 0.0125
        attrs["phase_target"] = -90.0
        attrs["release_growth_rate"] = 3.5
        attrs["drive_harmonics_ratio"] = 0.004
        attrs["converged"] = True
    text = _info_text(path, monkeypatch)
    for shown in (
        "amplitude_target=0.00032 m",
        "feedforward_amplitude=1.25 V",
        "control_effort=0.0125 V",
        "phase_target=-90 deg",
        "release_growth_rate=3.5 1/s",
        "drive_harmonics_ratio=0.004,",
        "converged=yes",
    ):
        assert shown in text, (shown, text)


def test_json_of_a_run_stopped_in_its_analysis_is_the_finished_document(tmp_path, monkeypatch):
    """SIGTERM after the run finished, while its document is computed (a tap test's modal
    analysis, an FRF check: seconds on lab data): exit 143 and one line as for any signal, and
    stdout still one JSON document, status finished as the recording says, without the analysis
    the signal cut (it is not run a second time); was nothing on stdout. The signal is raised
    where the analysis runs (result_document), as the stop handler raises it."""
    import signal

    from cli_helpers import acquire_dwell

    from rigtools.errors import Interrupted
    from rigtools.procedures import from_options
    from rigtools.recording import open_recording

    calls = []

    def stopped_in_analysis(*args, **kwargs):
        calls.append(args[0])
        raise Interrupted(signal.SIGTERM)

    monkeypatch.setattr(from_options, "result_document", stopped_in_analysis)
    out = tmp_path / "d.h5"
    code, stdout, err = run_cli([*acquire_dwell(periods=20), "--out", out, "--json"])
    assert code == 143 and "SIGTERM" in _one_line(err)
    assert json.loads(stdout) == {
        "file": str(out),
        "status": "finished",
        "reason": "",
        "backend": "sim",
        "procedure": "dwell",
    }
    assert calls == ["dwell"]
    with open_recording(out) as rec:
        assert rec.status == "complete"


def test_a_failed_json_run_whose_reader_went_away_keeps_its_status_and_line(tmp_path):
    """``rig acquire dwell ... --json | head`` with the reader gone: the run failed (exit 5), its
    document cannot be written; the exit status is still 5 and the failure's one line is on
    stderr (was 141 and no line: the closed pipe while printing the document hid the failure)."""
    import contextlib
    import io

    from cli_helpers import acquire_dwell

    from rigtools.cli import main

    class ClosedPipe(io.StringIO):
        def write(self, text: str) -> int:
            raise BrokenPipeError(32, "Broken pipe")

    err = io.StringIO()
    argv = [*acquire_dwell(force="1 kN"), "--out", str(tmp_path / "f.h5"), "--json"]
    with contextlib.redirect_stdout(ClosedPipe()), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    assert code == 5
    assert "cannot be reached at 60 Hz" in _one_line(err.getvalue())


def test_info_shows_the_units_of_tap_and_frf_parameters(tmp_path, monkeypatch):
    """The tap test's and FRF test's parameters without a column of their own also carry their
    SI units (vocabulary.POINT_PARAMETER_UNITS; units from the procedures' fields: position m,
    trigger N, level V, band Hz); were bare numbers (position=0.085, band_low=20) after the
    CBC/PLL ones got theirs. Counts and flags stay bare."""
    path = _write_recording(tmp_path / "t.h5")
    with h5py.File(path, "r+") as f:
        tap, frf = f["points/0000"].attrs, f["points/0001"].attrs
        tap["position"] = 0.085
        tap["trigger_level"] = 5.0
        tap["trigger_time"] = 0.3
        tap["hit_peak_force"] = 20.5
        tap["pretrigger_samples"] = 512
        frf["band_low"] = 20.0
        frf["band_high"] = 500.0
        frf["drive_level"] = 0.3
        frf["averages"] = 10
    text = _info_text(path, monkeypatch)
    for shown in (
        "position=0.085 m",
        "trigger_level=5 N",
        "trigger_time=0.3 s",
        "hit_peak_force=20.5 N",
        "band_low=20 Hz",
        "band_high=500 Hz",
        "drive_level=0.3 V",
    ):
        assert shown in text, (shown, text)
    for bare in ("pretrigger_samples=512", "averages=10"):  # a count: no unit after it
        assert re.search(re.escape(bare) + r"(,| │)", text), (bare, text)
