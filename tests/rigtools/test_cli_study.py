"""``rig study`` streams each point to its recording as it settles: the streamed file equals the
in-memory study, and Ctrl-C / SIGTERM / SIGKILL keep every finished point."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from rigtools.analysis.harmonics import harmonic_amplitudes
from rigtools.cli import main
from rigtools.recording import RecordingWriter, open_recording
from rigtools.sim.studies import StudyPlan, run_study
from rigtools.simulation import MODEL_OUTPUTS, RunSettings, load_system, write_study

FAST = ["--duration", "0.1 s", "--max-settle", "4 s"]
GAPS = [0.3e-3, 0.5e-3, 0.7e-3]


@pytest.fixture(scope="module")
def system():
    return load_system(None, "fem")


def test_streamed_study_equals_the_in_memory_study(system, tmp_path):
    """Every sample of every channel and every point parameter as run_study computes it (1e-12)."""
    cfg, sys_ = system
    settings = RunSettings(duration=0.1, max_settle_time=4.0)
    plan = StudyPlan("gap", tuple(GAPS), "both")
    out = tmp_path / "s.h5"
    with RecordingWriter(out, backend="fem", rig=cfg.to_json()) as rec:
        summaries = write_study(rec, sys_, plan, settings, "fem")
    ref = run_study(sys_, "gap", GAPS, direction="both", record_duration=0.1, max_settle_time=4.0)
    with open_recording(out) as rec:
        assert rec.status == "complete" and len(rec.points) == len(ref.points) == 5
        for p, r, s in zip(rec.points, ref.points, summaries, strict=True):
            assert p.ended
            assert (p.params["direction"], p.params["study_value"]) == (r.direction, r.value)
            assert (
                p.params["gap"] == r.run.gap
                and p.params["fe"] == 60.0
                and p.params["force_amplitude"] == 15.0
            )
            for name, src in MODEL_OUTPUTS.items():
                np.testing.assert_allclose(p[name][:], r.run.outputs[src], rtol=1e-12, atol=0)
            assert p.params["peak_contact_force"] == pytest.approx(r.run.peak_contact_force, rel=1e-12)
            assert s["peak_contact_force_n"] == pytest.approx(r.run.peak_contact_force, rel=1e-12)
            # force_amplitude_measured is the fundamental of the recorded force channel (a pure sine: F0)
            fund = harmonic_amplitudes(p["force"][:], p.sample_rate, 60.0, 1).at(1)
            assert p.params["force_amplitude_measured"] == pytest.approx(fund, rel=1e-12)
            assert fund == pytest.approx(15.0, rel=1e-12)


def _start(tmp_path, out, values="5 N:40 N:0.05 N"):
    """A long force study (701 points) in a subprocess; returns the process."""
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    cmd = [
        sys.executable,
        "-m",
        "rigtools.cli",
        "study",
        "force",
        "--values",
        values,
        "--out",
        str(out),
        "--json",
        "--no-plot",
        "--from-rest",
        *FAST,
    ]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=tmp_path)


def _ended_points(out):
    """(index, end time as epoch s) of every ended point, or [] while the file is not there yet."""
    from datetime import datetime

    if not out.exists():
        return []
    try:
        with open_recording(out) as rec:
            return [(p.index, datetime.fromisoformat(p.end_time).timestamp()) for p in rec.points if p.ended]
    except Exception:  # noqa: BLE001 - the writer is between structure and streaming: try again
        return []


def _wait_for_points(proc, out, n, timeout=120.0):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if len(_ended_points(out)) >= n:
            return
        if proc.poll() is not None:
            pytest.fail(f"rig study ended early: {proc.returncode} {proc.stderr.read().decode()}")
        time.sleep(0.05)
    proc.kill()
    pytest.fail("rig study wrote no points in time")


def _check_points(out, indices):
    """Each listed point is readable, ended, with its full, finite data and consistent parameters."""
    with open_recording(out) as rec:
        points = {p.index: p for p in rec.points}
        for i in indices:
            p = points[i]
            assert p.ended
            n = p.params["steps_per_period"] * round(0.1 * p.params["fe"])
            assert p.n_samples == n
            force = p["force"][:]
            assert force.size == n and np.all(np.isfinite(force))
            assert harmonic_amplitudes(force, p.sample_rate, p.params["fe"], 1).at(1) == pytest.approx(
                p.params["force_amplitude"], rel=1e-9
            )
            assert p.params["force_amplitude_measured"] == pytest.approx(
                p.params["force_amplitude"], rel=1e-9
            )
            assert p.params["study_value"] == p.params["force_amplitude"] == pytest.approx(5.0 + 0.05 * i)
        return rec.status, rec.abort_reason, len(rec.points)


def test_sigkill_keeps_every_point_finished_a_second_before(tmp_path):
    out = tmp_path / "killed.h5"
    proc = _start(tmp_path, out)
    _wait_for_points(proc, out, 2)
    time.sleep(1.5)
    killed_at = time.time()
    proc.send_signal(signal.SIGKILL)
    proc.wait(30)
    old = [i for i, t in _ended_points(out) if t < killed_at - 1.0]
    assert len(old) >= 2
    assert old == list(range(len(old)))
    status, _, n = _check_points(out, old)
    assert status == "recording" and n >= len(old)  # the writer never finished the file


@pytest.mark.parametrize(
    "sig, code, reason",
    [
        (signal.SIGINT, 130, "SIGINT: interrupted (Ctrl-C)"),
        (signal.SIGTERM, 143, "SIGTERM: terminated (kill, timeout or a job scheduler)"),
    ],
)
def test_stop_request_ends_the_file_aborted_with_every_point(tmp_path, sig, code, reason):
    out = tmp_path / "stopped.h5"
    proc = _start(tmp_path, out)
    _wait_for_points(proc, out, 2)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=60)
    err = stderr.decode().strip().splitlines()
    assert proc.returncode == code
    assert (
        len(err) == 1
        and err[0].startswith(f"rig study: {reason} after ")
        and "Traceback" not in stderr.decode()
    )
    assert stdout == b""
    with open_recording(out) as rec:
        n = len(rec.points)
        assert rec.status == "aborted" and rec.abort_reason == f"{reason} after {n} of 701 points"
        assert all(p.ended for p in rec.points)  # a stop waits for the point being written
    _check_points(out, range(n))


def test_study_json_reports_the_measured_force_fundamental(tmp_path, capsys):
    out = tmp_path / "f.h5"
    assert (
        main(["study", "force", "--values", "10 N,20 N", "--out", str(out), "--json", "--no-plot", *FAST])
        == 0
    )
    doc = json.loads(capsys.readouterr().out)
    assert [p["force_amplitude_measured"] for p in doc["points"]] == pytest.approx([10.0, 20.0], rel=1e-12)
    with open_recording(out) as rec:
        assert [p.params["force_amplitude_measured"] for p in rec.points] == pytest.approx(
            [10.0, 20.0], rel=1e-12
        )


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["gap", "--values", "0.3 mm,0.5"], "wider than any blade could close"),
        (["gap", "--values", "0.3 mm:1e400 mm:0.1 mm"], "not a finite number"),
        (["force", "--values", "1 N:1e9 N:1 N"], "too many"),
        (["force", "--values", "5 N", "--gap", "0.5"], "--gap = '0.5' is 500 mm"),
        (["force", "--values", "5 N", "--fe", "1e400"], "--fe = '1e400': '1e400' is not a finite number"),
        (["frequency", "--values", "60 Hz", "--duration", "1e400 s"], "--duration"),
        (["frequency", "--values", "60 Hz", "--max-settle", "-1 s"], "--max-settle"),
        (["frequency", "--values", "60 Hz", "--steps-per-period", "100000000"], "--steps-per-period"),
        (
            ["force", "--values", "5 N", "--duration", "1000 s", "--steps-per-period", "1000000"],
            "GB of memory",
        ),
    ],
)
def test_study_refuses_bad_input_with_one_line(tmp_path, capsys, argv, needle):
    out = tmp_path / "x.h5"
    assert main(["study", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rig study: error:") and needle in err and err.count("\n") == 1, err
    assert not out.exists()


def test_memory_does_not_grow_with_the_number_of_points(system, tmp_path):
    """Peak traced memory of a streamed 8-point study is that of a 2-point one (within 15 %),
    while the in-memory study holds every run (each ~ steps x 14 outputs x 8 bytes)."""
    import tracemalloc

    cfg, sys_ = system
    settings = RunSettings(duration=0.5, max_settle_time=4.0)

    def peak(n):
        plan = StudyPlan("force", tuple(np.linspace(5.0, 20.0, n)), carry_state=False)
        tracemalloc.start()
        with RecordingWriter(tmp_path / f"m{n}.h5", backend="fem", rig=cfg.to_json()) as rec:
            write_study(rec, sys_, plan, settings, "fem")
        value = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        return value

    peak(1)  # compile and warm caches outside the measurement
    p2, p8 = peak(2), peak(8)
    assert p8 < 1.15 * p2, (p2, p8)
    tracemalloc.start()
    study = run_study(
        sys_,
        "force",
        list(np.linspace(5.0, 20.0, 8)),
        carry_state=False,
        record_duration=0.5,
        max_settle_time=4.0,
    )
    in_memory = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    run_bytes = sum(a.nbytes for a in study.points[0].run.outputs.values())
    assert in_memory > p8 + 4 * run_bytes, (in_memory, p8, run_bytes)  # 8 runs held vs 1 at a time


def test_stop_requests_hold_a_signal_until_the_protected_write_is_done():
    from rigtools.errors import Interrupted as Stopped
    from rigtools.runtime import StopRequests

    steps = []
    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(Stopped) as info, StopRequests() as stops:
        with stops.protected():
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.05)  # the handler runs here and only holds the request
            steps.append("written")
        steps.append("not reached")
    assert steps == ["written"]
    assert info.value.exit_code == 143 and info.value.reason.startswith("SIGTERM")
    assert signal.getsignal(signal.SIGTERM) is before  # the previous handler is back


def test_a_record_appended_in_blocks_is_the_run(system, tmp_path, monkeypatch):
    from rigtools import simulation

    cfg, sys_ = system
    run = simulation.simulate_point(sys_, 60.0, 15.0, RunSettings(0.1, 4.0))
    monkeypatch.setattr(simulation, "APPEND_SAMPLES", 577)  # several blocks and a partial one
    assert run.time.size > 3 * 577 and run.time.size % 577
    with RecordingWriter(tmp_path / "b.h5", backend="fem", rig=cfg.to_json()) as rec:
        simulation.write_point(rec, run, "fem")
    with open_recording(tmp_path / "b.h5") as rec:
        for name, src in MODEL_OUTPUTS.items():
            np.testing.assert_array_equal(rec.points[0][name][:], run.outputs[src])


def test_a_map_prints_gap_and_force_columns_under_a_map_title():
    """A map sweeps fe for each (gap, F0): its table shows all three, titled as a map."""
    from rich.console import Console

    from rigtools.model_study import summary_table

    h = {
        c: [{"amplitude": 0.5 * k} for k in range(1, 31)]
        for c in ("active_shroud_accel", "passive_shroud_accel")
    }
    points = [
        {"value": fe, "fe": fe, "gap": gap, "force_amplitude": f0, "direction": "up", "steady_state": True,
         "peak_contact_force_n": 1.0, "impacts_per_period": 2.0, "harmonics": h}
        for gap in (3e-4, 5e-4) for f0 in (10.0,) for fe in (58.0, 60.0)
    ]  # fmt: skip
    table = summary_table("map", points)
    assert table.title == "map study: gap x F0 x fe, 4 points"
    headers = [c.header for c in table.columns]
    assert headers[:3] == ["gap (mm)", "F0 (N)", "fe (Hz)"]
    console = Console(record=True, width=200)
    console.print(table)
    text = console.export_text()
    assert "0.3" in text and "0.5" in text and "10" in text
