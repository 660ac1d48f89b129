"""Study runner on Dask: speed-up on this machine's cores, per-point overhead, a 10x10x10 map.

Prints, each against a baseline measured in the same run:

* speed-up: an independent-chain study (from rest, 6000 steps per period: each point settles
  for a few tenths of a second, its record is short) in-process (the baseline) vs a 2-worker
  LocalCluster; goal >= 1.7x;
* runner overhead per point: 400 points whose work is nothing, on the 2-worker cluster, minus
  nothing; goal < 50 ms;
* wall time of a 10 x 10 x 10 gap x F0 x fe map at 2 workers (0.2 s recorded per point).

Run: .venv/bin/python benchmarks/bench_dask_study.py [--quick]
"""

from __future__ import annotations

import os
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np

from rigtools.config import load_rig
from rigtools.sim.reduction import reduced_system
from rigtools.sim.studies import StudyPlan
from rigtools.study_runner import RunOptions, StudyRunner, map_chains


def nothing(system, point, options, previous):
    return point.index


def timed(runner, system, chains, options, point_fn=None):
    t = time.perf_counter()
    kw = {} if point_fn is None else {"point_fn": point_fn}
    n = sum(1 for _ in runner.run(system, chains, options, **kw))
    return time.perf_counter() - t, n


def main() -> int:
    quick = "--quick" in sys.argv
    system = reduced_system(load_rig(None).to_params(), "fem")
    # from rest with a fine step: settling dominates (~0.3 s of work per point), records are short
    options = RunOptions(record_duration=0.02, max_settle_time=10.0, steps_per_period=6000)
    values = tuple(np.linspace(0.3e-3, 0.9e-3, 12 if quick else 24))
    chains = StudyPlan("gap", values, carry_state=False).chains()  # independent points
    base = StudyRunner()
    timed(base, system, chains[:2], options)  # compile/load kernels
    t_in, n = timed(base, system, chains, options)
    with StudyRunner(workers=2) as runner:
        timed(runner, system, chains[:4], options)  # warm the workers
        t_2, _ = timed(runner, system, chains, options)
        empty_chains = StudyPlan("gap", tuple(np.arange(400) * 1e-6), carry_state=False).chains()
        t_nothing, n_nothing = timed(runner, system, empty_chains, options, point_fn=nothing)
        speedup = t_in / t_2
        overhead = t_nothing / n_nothing
        print(
            f"independent {n}-point gap study: in-process {t_in:.2f} s, 2 workers {t_2:.2f} s: "
            f"speed-up {speedup:.2f}x (goal >= 1.7x: {'met' if speedup >= 1.7 else 'NOT met'})"
        )
        print(
            f"runner overhead: {overhead * 1e3:.1f} ms per point over {n_nothing} empty points, "
            f"ratio to one in-process point of the study {overhead / (t_in / n):.3f} "
            f"(goal < 50 ms: {'met' if overhead < 0.05 else 'NOT met'})"
        )
        side = 4 if quick else 10
        grid = map_chains(
            np.linspace(0.3e-3, 0.9e-3, side), np.linspace(5, 25, side), np.linspace(55, 75, side)
        )
        t_map, n_map = timed(runner, system, grid, RunOptions(record_duration=0.2, max_settle_time=10.0))
        print(
            f"{side} x {side} x {side} map ({n_map} points, fe swept per (gap, F0) chain) at 2 "
            f"workers: {t_map:.1f} s wall ({t_map / n_map * 1e3:.0f} ms per point)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
