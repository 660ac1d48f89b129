"""Speed of continuation: a 200-point branch with stability versus 200 settled time integrations.

Case: default rig (FEM), F0 = 15 N, gap 0.7 mm, continued in fe from 55 Hz upwards until the
branch holds 200 points (:func:`rigtools.sim.continuation.continue_orbits`: shooting on the
stepper's kernel, forward-difference monodromy at every point, bifurcations located). Baseline,
timed in the same process: :func:`rigtools.sim.vibro_impact.run_harmonic` from rest at the same
200 frequencies (each to its detected steady state, the default one-second record).

Goal: the branch in < 60 s on this machine; printed with its ratio to the baseline, "NOT met" if
missed.

    .venv/bin/python benchmarks/bench_continuation.py           # ~15 s
    .venv/bin/python benchmarks/bench_continuation.py --json
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from rigtools.config import load_rig
from rigtools.sim.continuation import ContinuationSettings, continue_orbits
from rigtools.sim.reduction import reduced_system
from rigtools.sim.vibro_impact import run_harmonic

GOAL_S = 60.0
POINTS = 200


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    system = reduced_system(load_rig(None).to_params(), "fem")
    # warm-up: numba compilation and caches out of the timing
    continue_orbits(
        system, "fe", 55.0, 56.0, force=15.0, gap=0.7e-3, settings=ContinuationSettings(max_points=3)
    )
    run_harmonic(system.with_contact(gap=0.7e-3), 55.0, 15.0, record_periods=1)

    t0 = time.perf_counter()
    branch = continue_orbits(
        system, "fe", 55.0, 80.0, force=15.0, gap=0.7e-3, settings=ContinuationSettings(max_points=POINTS)
    )
    t_branch = time.perf_counter() - t0
    fe = branch.values()
    t0 = time.perf_counter()
    for f in fe:
        run_harmonic(system.with_contact(gap=0.7e-3), float(f), 15.0, record_periods=max(1, round(f)))
    t_runs = time.perf_counter() - t0
    result = {
        "points": len(branch.points),
        "fe_reached_hz": float(fe[-1]),
        "bifurcations": [f"{lab} {p.value:.4g} Hz" for p in branch.labelled() for lab in p.labels],
        "branch_s": t_branch,
        "settled_runs_s": t_runs,
        "ratio_branch_to_runs": t_branch / t_runs,
        "goal_s": GOAL_S,
        "goal_met": t_branch < GOAL_S,
    }
    if args.json:
        print(json.dumps(result, indent=2))
        return
    print(f"branch: {result['points']} points, 55 -> {result['fe_reached_hz']:.4g} Hz, with stability")
    print(f"  bifurcations: {', '.join(result['bifurcations']) or 'none'}")
    print(f"  time {t_branch:.2f} s (goal < {GOAL_S:g} s: {'met' if result['goal_met'] else 'NOT met'})")
    print(f"200 settled time integrations at the same points: {t_runs:.2f} s")
    print(f"ratio branch / settled runs: {result['ratio_branch_to_runs']:.3g}")


if __name__ == "__main__":
    main()
