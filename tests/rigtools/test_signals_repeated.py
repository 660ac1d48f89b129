"""Two and three stop signals (issue 19, item 2): the drive reaches zero on every path.

A first SIGINT/SIGTERM/SIGHUP starts the abort ramp; a second one while it runs is held until the
output is at zero and the device closed, then honoured; a third cuts the ramp short but only
after zeros are written. Checked twice:

* on the simulated rig, ``rig acquire dwell --backend sim --pace`` in subprocesses (all cases run
  side by side to keep the test short), signals 20-200 ms apart during force control and during
  the recording: the recording ends ``aborted`` with its last drive samples exactly 0 V;
* against the NI-DAQmx driver contract (the autospecced fake of ``tests/drivers/test_nidaq.py``,
  signals sent to this process from inside the fake's read): the last samples written to the
  AO task are 0 V and the AO task is stopped before the interrupt leaves the procedure.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import acquire_dwell

from rigtools.errors import Interrupted
from rigtools.recording import check_recording, open_recording

DWELL = acquire_dwell(fe="60 Hz", gap=None, pace=True, periods=3000)
ORDER = [signal.SIGINT, signal.SIGTERM, signal.SIGINT]

# (phase, gaps between signals in s): two and three signals 20-200 ms apart
CASES = [
    ("control", (0.02,)),
    ("control", (0.2,)),
    ("control", (0.05, 0.05)),
    ("recording", (0.02,)),
    ("recording", (0.1,)),
    ("recording", (0.2,)),
    ("recording", (0.02, 0.02)),
    ("recording", (0.1, 0.2)),
]


def _samples(path: Path) -> int:
    try:
        with open_recording(path) as rec:
            return rec.points[0].n_samples if rec.points else 0
    except Exception:  # noqa: BLE001 - the writer is between flushes: "not yet"
        return 0


def _one_run(phase: str, gaps: tuple[float, ...], out: Path, results: dict) -> None:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    proc = subprocess.Popen(
        [sys.executable, "-m", "rigtools.cli", *DWELL, "--out", str(out)],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    # control: the first samples are on disk (the force is still being set); recording: past
    # the control (about 2 s of samples at 51.2 kS/s). A limit only stops a hung child.
    need = 1 if phase == "control" else 120_000
    end = time.monotonic() + 240
    while _samples(out) < need and proc.poll() is None and time.monotonic() < end:
        time.sleep(0.02)
    if proc.poll() is None:
        proc.send_signal(ORDER[0])
        for sig, gap in zip(ORDER[1:], gaps, strict=False):
            time.sleep(gap)
            if proc.poll() is None:
                proc.send_signal(sig)
    _, err = proc.communicate(timeout=240)
    results[(phase, gaps)] = (proc.returncode, err)


def test_two_and_three_signals_on_the_simulated_rig_end_at_zero_drive(tmp_path):
    results: dict = {}
    threads = []
    for i, (phase, gaps) in enumerate(CASES):
        t = threading.Thread(target=_one_run, args=(phase, gaps, tmp_path / f"run{i}.h5", results))
        t.start()
        threads.append(t)
    for t in threads:
        t.join()
    for i, (phase, gaps) in enumerate(CASES):
        code, err = results[(phase, gaps)]
        what = f"{phase} {gaps}: {err}"
        assert code == 130, what  # the first signal's status (SIGINT), honoured after zero
        assert "Traceback" not in err and len(err.strip().splitlines()) <= 2, what
        out = tmp_path / f"run{i}.h5"
        assert check_recording(out).valid, what
        with open_recording(out) as rec:
            assert rec.status == "aborted" and "SIGINT" in str(rec.attrs.get("abort_reason")), what
            drive = rec.points[-1].channels["drive"].read()
        peak = np.max(np.abs(drive))
        assert peak > 0.05, what  # the shaker was driven when the signals came
        # the record ends at zero drive: the last 10 ms exactly 0 V
        assert np.all(drive[-512:] == 0.0), (what, np.abs(drive[-512:]).max(), peak)


# ------------------------------------------------------------------- NI-DAQmx driver contract
def _ni_world(monkeypatch):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "drivers"))
    try:
        import test_nidaq  # the autospecced nidaqmx fake
    finally:
        sys.path.pop(0)
    from rigtools.config import load_rig
    from rigtools.drivers.nidaq import NiDaqDevice

    cfg = load_rig()
    rig = test_nidaq.Rig(monkeypatch)
    dev = NiDaqDevice(abort_ramp_time=cfg.safety.abort_ramp_time)
    dev.configure(cfg.daq.input_specs(), cfg.daq.output_spec(), 51200.0)
    return cfg, rig, dev


@pytest.mark.parametrize(
    "at",
    [(3, 4), (3, 5), (3, 4, 5), (3, 5, 6), (3, 3, 3)],
    ids=lambda at: "signals-at-reads-" + "-".join(map(str, at)),
)
def test_repeated_signals_against_the_ni_driver_contract(monkeypatch, at):
    """Signals sent at the given block reads (the first starts the ramp; the others land in it):
    every write to the AO task is within range, the last one ends at exactly 0 V, the AO task is
    stopped, and only then does the first signal's interrupt leave the procedure."""
    from rigtools.acquisition import BlockStream
    from rigtools.drivers.drive_signals import SineDrive
    from rigtools.procedures.base import Procedure, StopRequested

    cfg, rig, dev = _ni_world(monkeypatch)
    reads = {"n": 0}
    sigs = iter(ORDER)

    def fill(data, number_of_samples_per_channel=-1, timeout=10.0):
        reads["n"] += 1
        data[:] = 0.0
        for _ in range(at.count(reads["n"])):
            os.kill(os.getpid(), next(sigs))
        return number_of_samples_per_channel

    rig.reader.read_many_sample.side_effect = fill
    stopped_when_raised: list[bool] = []

    class Stream(Procedure):
        def execute(self) -> None:
            drive = SineDrive(51200.0, 60.0, max_drive=cfg.safety.max_drive, ramp_time=0.01)
            drive.set_target(1.0)
            self.stream = BlockStream(
                dev, drive, abort_ramp_time=cfg.safety.abort_ramp_time, hurry=lambda: self.hurry_requested
            )
            for _ in range(200):
                self.stream.read()
                if self.stop_requested:
                    self.stream.finish(ramp_time=cfg.safety.abort_ramp_time)
                    raise StopRequested(self.stop_reason)

        def shutdown(self, status, reason) -> None:
            dev.close()
            stopped_when_raised.append(not dev.running)

    proc = Stream()
    with pytest.raises(Interrupted) as stop:
        proc.run()
    assert stop.value.signum == signal.SIGINT and proc.signals_seen == len(at)
    assert stopped_when_raised == [True] and "ao_stop" in rig.order()
    written = np.concatenate(rig.written)
    assert np.max(np.abs(written)) > 0.5  # driven before the stop
    assert written[-1] == 0.0 and np.all(rig.written[-1][-100:] == 0.0)
    assert reads["n"] < 200  # the stop ended the stream


def test_ctrl_c_then_a_kill_30_ms_later_ends_130_with_the_branches_kept(tmp_path):
    """A Ctrl-C, then SIGTERM 30 ms later (as a scheduler sends) while the continuation writes
    what it has: the branches are kept and the status is the first signal's 130; the process
    died by the SIGTERM (-15) once the handlers were restored for the exit (issue 30)."""
    out = tmp_path / "b.h5"
    cmd = [
        sys.executable,
        "-m",
        "rigtools.cli",
        "continuation",
        "--param",
        "fe",
        "--from",
        "55",
        "--to",
        "80",
    ]
    proc = subprocess.Popen(
        [*cmd, "--gap", "0.5 mm", "--force", "15", "--out", str(out)],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    time.sleep(8.0)  # into the tracing (the branch takes about a minute); any moment gives 130
    proc.send_signal(signal.SIGINT)
    time.sleep(0.03)
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=240)
    assert proc.returncode == 130, (proc.returncode, err)
    assert "Traceback" not in err and "SIGINT: interrupted" in err
    check = subprocess.run(
        [sys.executable, "-m", "rigtools.cli", "check", str(out)], capture_output=True, text=True, check=False
    )
    assert check.returncode == 0 and "branch" in check.stdout, check.stdout + check.stderr
    assert not list(tmp_path.glob("*.partial"))
