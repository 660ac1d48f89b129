"""CPU of the live monitor following a recording written at 4 channels x 51.2 kS/s, two viewers.

A writer process streams 4 float64 channels (force, both shroud accelerations with one impact
spike per period, drive; fe = 60 Hz) at 51.2 kS/s in real time, 0.1 s blocks, into one point
(``RecordingWriter``: SWMR, flush every 0.5 s). ``rig monitor`` follows it (its own process,
4 looks a second), with two viewers: two tabs of headless Chromium (or, without Chromium, two
Bokeh client sessions). Over the measuring window the monitor's CPU time (user + system, all its
threads) divided by wall time is its load in % of one core; the writer's is measured over the
same window in the same run as the baseline (the work of producing the stream).

Goal (issue 21): monitor <= 25 % of one core.

    .venv/bin/python benchmarks/bench_monitor.py                 # ~30 s
    .venv/bin/python benchmarks/bench_monitor.py --seconds 20 --json
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import psutil

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # headless_chromium
GOAL = 0.25  # of one core

WRITER = """
import sys, time
import numpy as np
from rigtools.recording import ChannelSpec, RecordingWriter
rate, fe, block = 51200.0, 60.0, 5120
names = [("force", "N", "force"), ("active_shroud_accel", "m/s^2", "acceleration"),
         ("passive_shroud_accel", "m/s^2", "acceleration"), ("drive", "V", "voltage")]
specs = [ChannelSpec(n, u, q, rate) for n, u, q in names]
seconds = float(sys.argv[2])
rng = np.random.default_rng(1)
with RecordingWriter(sys.argv[1], backend="simulated", rig="{}", experiment={}) as rec:
    point = rec.begin_point({"fe": fe, "force_amplitude": 15.0}, specs)
    print("started", flush=True)
    t0 = time.perf_counter()
    for i in range(int(seconds * rate / block)):
        t = (i * block + np.arange(block)) / rate
        phase = (t * fe) % 1.0
        spike = np.where(np.abs(phase - 0.3) < 0.5 / rate * fe, 400.0, 0.0)
        data = np.vstack([15 * np.sin(2 * np.pi * fe * t), 80 * np.sin(2 * np.pi * fe * t) - spike,
                          60 * np.sin(2 * np.pi * fe * t) + spike, np.sin(2 * np.pi * fe * t)])
        point.append(data + 0.01 * rng.standard_normal(data.shape))
        time.sleep(max(0.0, t0 + (i + 1) * block / rate - time.perf_counter()))
    point.end()
"""


def cpu_seconds(proc: psutil.Process) -> float:
    times = proc.cpu_times()
    return times.user + times.system


def viewers(url: str, n: int):
    """Open ``n`` viewers of ``url``; returns what to close."""
    from headless_chromium import BrowserUnavailable, find_chromium

    try:
        exe = find_chromium()
    except BrowserUnavailable:
        from bokeh.client import pull_session

        return "bokeh client", [pull_session(url=url.split("?")[0]) for _ in range(n)]
    from headless_chromium import Chromium

    browser = Chromium(exe).__enter__()
    pages = [browser.open(url) for _ in range(n)]
    for page in pages:
        page.wait_text("mon-status", 60, "recording")
    return "chromium tabs", [browser]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=15.0, help="measuring window, s")
    ap.add_argument("--viewers", type=int, default=2)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-monitor-") as tmp:
        path = Path(tmp) / "stream.h5"
        total = args.seconds + 20.0
        writer = subprocess.Popen(
            [sys.executable, "-c", WRITER, str(path), str(total)], stdout=subprocess.PIPE, text=True
        )
        assert writer.stdout is not None and writer.stdout.readline().strip() == "started"
        cmd = [sys.executable, "-m", "rigtools.cli", "monitor", str(path), "--port", "0"]
        monitor = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        try:
            assert monitor.stdout is not None
            url = monitor.stdout.readline().strip()
            kind, opened = viewers(url, args.viewers)
            time.sleep(3.0)  # the viewers' first full draw is not the steady state
            mon, wri = psutil.Process(monitor.pid), psutil.Process(writer.pid)
            c0, w0, t0 = cpu_seconds(mon), cpu_seconds(wri), time.monotonic()
            time.sleep(args.seconds)
            c1, w1, t1 = cpu_seconds(mon), cpu_seconds(wri), time.monotonic()
            for thing in opened:
                thing.close()
        finally:
            monitor.kill()
            writer.kill()
            monitor.wait()
            writer.wait()
    wall = t1 - t0
    load, base = (c1 - c0) / wall, (w1 - w0) / wall
    result = {
        "channels": 4,
        "sample_rate": 51200.0,
        "viewers": f"{args.viewers} {kind}",
        "seconds": round(wall, 2),
        "monitor_cpu_of_one_core": round(load, 4),
        "writer_cpu_of_one_core": round(base, 4),
        "monitor_over_writer": round(load / base, 3) if base else None,
        "monitor_over_goal": round(load / GOAL, 3),
        "goal_met": load <= GOAL,
    }
    if args.json:
        print(json.dumps(result))
        return
    print(f"monitor following 4 ch x 51.2 kS/s with {result['viewers']}, {wall:.1f} s window")
    print(
        f"  monitor CPU  {load * 100:6.1f} % of one core   (goal <= {GOAL * 100:.0f} %: ratio {load / GOAL:.2f})"
    )
    print(
        f"  writer CPU   {base * 100:6.1f} % of one core   (baseline, same run; monitor/writer {load / base:.2f})"
    )


if __name__ == "__main__":
    main()
