"""Start-up latency of the ``rig`` command line.

Wall time of whole processes, as a user feels it: ``rig --help``, ``rig info FILE`` and
``rig check FILE`` on a small recording (one point, four channels, 0.5 s at 51.2 kS/s, written
here with :class:`rigtools.recording.RecordingWriter`), and the baseline: a bare
``python -c pass`` with the same interpreter, measured in the same run. Each figure is the
median of ``--repeats`` runs, the commands interleaved so a busy machine slows all alike.
``rig`` is run as ``python -c "from rigtools.cli import main; ..."`` (what the console script
does) so the interpreter and the environment are the same as the baseline's.

Goals (issue 8): ``rig --help`` <= 0.3 s, ``rig info`` / ``rig check`` on a small file <= 0.6 s.
The ratio to the bare interpreter tells how much is ours when the machine is loaded.

    .venv/bin/python benchmarks/bench_cli_latency.py              # ~20 s
    .venv/bin/python benchmarks/bench_cli_latency.py --repeats 11 --json
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rigtools.recording import ChannelSpec, RecordingWriter

GOALS = {"rig --help": 0.3, "rig info FILE": 0.6, "rig check FILE": 0.6}
RIG = "import sys; from rigtools.cli import main; sys.exit(main())"


def make_recording(path: Path, seconds: float = 0.5, rate: float = 51200.0) -> Path:
    """A small complete recording like ``rig acquire`` writes (force, two accelerations, drive)."""
    t = np.arange(int(seconds * rate)) / rate
    rng = np.random.default_rng(0)
    specs = [
        ChannelSpec("force", "N", "force", rate),
        ChannelSpec("active_shroud_accel", "m/s^2", "acceleration", rate),
        ChannelSpec("passive_shroud_accel", "m/s^2", "acceleration", rate),
        ChannelSpec("drive", "V", "voltage", rate),
    ]
    data = np.vstack(
        [
            a * np.sin(2 * np.pi * 60 * t + k) + rng.normal(0, 0.01 * a, t.size)
            for k, a in enumerate((15.0, 400.0, 250.0, 0.5))
        ]
    )
    with RecordingWriter(
        path, backend="simulated", rig="{}", experiment={"procedure": "sine dwell", "cli": "bench"}
    ) as rec:
        point = rec.begin_point({"fe": 60.0, "drive_amplitude": 0.5}, specs)
        point.append(data)
        point.end()
    return path


def wall(argv: list[str]) -> tuple[float, int]:
    """Wall time of one process (s) and its exit status; output discarded."""
    t0 = time.perf_counter()
    code = subprocess.call(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0, code


def interleaved_medians(cases: dict[str, list[str]], repeats: int) -> dict[str, float]:
    """Median wall time of each command over ``repeats`` rounds, the commands interleaved so a
    busy machine slows all alike, after one warm-up run each (file cache, .pyc and numba caches).

    Raises
    ------
    RuntimeError
        A command that exits non-zero, naming it.
    """
    for argv in cases.values():
        wall(argv)
    times: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(repeats):
        for name, argv in cases.items():
            seconds, code = wall(argv)
            if code != 0:
                raise RuntimeError(f"{name}: exit status {code}")
            times[name].append(seconds)
    return {name: statistics.median(v) for name, v in times.items()}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="runs per command (median)")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        path = make_recording(Path(tmp) / "small.h5")
        cases = {
            "python -c pass": [sys.executable, "-c", "pass"],
            "rig --help": [sys.executable, "-c", RIG, "--help"],
            "rig info FILE": [sys.executable, "-c", RIG, "info", str(path)],
            "rig check FILE": [sys.executable, "-c", RIG, "check", str(path)],
        }
        try:
            median = interleaved_medians(cases, args.repeats)
        except RuntimeError as exc:
            print(exc, file=sys.stderr)
            return 1
        size = os.path.getsize(path)

    base = median["python -c pass"]
    rows = []
    for name, seconds in median.items():
        goal = GOALS.get(name)
        rows.append(
            {
                "command": name,
                "median_s": seconds,
                "ratio_to_python": seconds / base,
                "goal_s": goal,
                "met": None if goal is None else seconds <= goal,
            }
        )
    if args.json:
        print(json.dumps({"repeats": args.repeats, "file_bytes": size, "results": rows}, indent=1))
        return 0
    print(f"rig start-up latency: median of {args.repeats} runs, small recording {size / 1e6:.2f} MB")
    for row in rows:
        verdict = (
            ""
            if row["goal_s"] is None
            else (f"goal <= {row['goal_s']:.1f} s: {'met' if row['met'] else 'NOT met'}")
        )
        print(
            f"  {row['command']:<16} {row['median_s']:6.3f} s  {row['ratio_to_python']:5.1f}x "
            f"python -c pass  {verdict}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
