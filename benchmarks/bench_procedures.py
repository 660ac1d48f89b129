"""End-to-end speed of a force-controlled rig study on the simulated rig, and Ctrl-C latency.

1. A 5-point force-controlled gap study (0.3, 0.45, 0.6, 0.75, 0.9 mm; 15 N; 60 Hz; 30
   periods recorded per point), unpaced, recorded to HDF5 (rigtools.procedures.RigStudy):
   wall seconds, simulated seconds and their ratio. Goal: wall < 10 s.
   Baseline, same process: the same simulated seconds streamed by a plain
   ``rigtools.acquisition.acquire`` at a fixed drive without recording (the rig's own cost);
   the ratio study / baseline is the cost of force control, settling tests and recording.
2. SIGINT during a simulated dwell (``rig acquire dwell`` in a child process, paced in real
   time): wall seconds from the signal to the end status in the file (drive ramped to zero,
   recording closed) and to the process exit. Goal: exit < 1 s. Baseline, same run: the exit
   time of a child that only imports rigtools.drivers.simulated (the interpreter's own teardown).

    .venv/bin/python benchmarks/bench_procedures.py [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rigtools.acquisition import acquire
from rigtools.config import load_rig
from rigtools.drivers.drive_signals import SineDrive
from rigtools.drivers.simulated import SimulatedRig
from rigtools.procedures import RigStudy

GAPS = [0.3e-3, 0.45e-3, 0.6e-3, 0.75e-3, 0.9e-3]


def study(cfg, out: Path) -> tuple[float, float]:
    t0 = time.perf_counter()
    proc = RigStudy(
        cfg,
        {"kind": "gap", "values": GAPS, "force": 15.0, "fe": 60.0, "record_periods": 30},
        out,
        backend="sim",
        seed=1,
        overwrite=True,
    )
    proc.run()
    wall = time.perf_counter() - t0
    simulated = proc.device.drive_samples / proc.device.sample_rate
    return wall, simulated


def baseline(cfg, seconds: float) -> float:
    rig = SimulatedRig.from_config(cfg, seed=1)
    rig.configure(cfg.daq.input_specs(), cfg.daq.output_spec(), cfg.daq.sample_rate, cfg.daq.block_size())
    drive = SineDrive(rig.sample_rate, 60.0, max_drive=5.0, ramp_time=0.5)
    drive.set_target(1.0)
    t0 = time.perf_counter()
    acquire(rig, drive, seconds)
    return time.perf_counter() - t0


def teardown_baseline() -> float:
    """Wall time a child needs to exit after importing the simulated rig and doing nothing."""
    child = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys, rigtools.drivers.simulated; print(1, flush=True); sys.stdin.readline()",
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    child.stdout.readline()
    t0 = time.perf_counter()
    child.stdin.write("\n")
    child.stdin.flush()
    child.wait()
    return time.perf_counter() - t0


def sigint_latency(tmp: Path) -> tuple[float, float]:
    out = tmp / "dwell.h5"
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    child = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "rigtools.cli",
            "acquire",
            "dwell",
            "--backend",
            "sim",
            "--pace",
            "--fe",
            "60",
            "--force",
            "15 N",
            "--gap",
            "0.5 mm",
            "--periods",
            "6000",
            "--out",
            str(out),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=env,
    )
    from rigtools.recording import open_recording

    while child.poll() is None:  # wait until it is streaming into the file
        try:
            with open_recording(out) as rec:
                if rec.points and rec.points[0].n_samples > 51200:
                    break
        except Exception:  # noqa: BLE001, S110 - the child is mid-write: any read error means "not yet"
            pass
        time.sleep(0.05)
    import h5py

    t0 = time.perf_counter()
    child.send_signal(signal.SIGINT)
    status_at = None
    while child.poll() is None:
        if status_at is None:
            try:
                with h5py.File(out, "r", swmr=True, locking=False) as f:
                    if "end_status" in f.attrs:
                        status_at = time.perf_counter() - t0
            except Exception:  # noqa: BLE001, S110 - the child is mid-write: any read error means "not yet"
                pass
        time.sleep(0.005)
    exit_at = time.perf_counter() - t0
    return (status_at if status_at is not None else exit_at), exit_at


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    cfg = load_rig()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        study(cfg, tmp / "warm.h5")  # numba caches, imports
        wall, simulated = study(cfg, tmp / "study.h5")
        base = baseline(cfg, simulated)
        status_at, latency = sigint_latency(tmp)
        teardown = teardown_baseline()
    doc = {
        "study_wall_s": wall,
        "simulated_s": simulated,
        "wall_per_simulated_s": wall / simulated,
        "baseline_wall_s": base,
        "ratio_to_baseline": wall / base,
        "sigint_status_s": status_at,
        "sigint_exit_s": latency,
        "interpreter_teardown_s": teardown,
        "goal_study_s": 10.0,
        "goal_sigint_s": 1.0,
    }
    if args.json:
        print(json.dumps(doc))
        return
    print(
        f"5-point force-controlled gap study: {wall:.2f} s wall for {simulated:.2f} s simulated "
        f"({wall / simulated:.3f} s wall per simulated s); goal < 10 s: {'met' if wall < 10 else 'NOT met'}"
    )
    print(
        f"baseline (same simulated time, fixed drive, no recording): {base:.2f} s; "
        f"study / baseline = {wall / base:.2f}"
    )
    print(
        f"SIGINT during a paced dwell -> status aborted in the file (drive at 0 V): {status_at:.3f} s; "
        f"-> process exit: {latency:.3f} s; goal exit < 1 s: {'met' if latency < 1 else 'NOT met'}"
    )
    print(
        f"baseline: a child importing rigtools.drivers.simulated exits in {teardown:.3f} s "
        f"(interpreter teardown); SIGINT exit / teardown = {latency / teardown:.2f}"
    )


if __name__ == "__main__":
    main()
