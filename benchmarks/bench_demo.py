"""Wall time of ``rig demo --quick`` and of the full demo (in-process, :func:`rigtools.demo.run.run_demo`).

Goals: --quick under 60 s, the full demo under 600 s, on this 2-core machine. Baseline, same
process: one settled FEM run of the paper's dwell (60 Hz, 15 N, 0.5 mm), the unit of model work
the demo repeats; the ratios say how many such runs each demo costs. CPU seconds are printed
too: on a machine shared with other work they, not the wall time, say what the demo costs.

    .venv/bin/python benchmarks/bench_demo.py [--quick-only] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time

from rigtools.runtime import configure_process

configure_process()  # as `rig` does: one BLAS thread (else idle BLAS threads spin and the figures mislead)

from rigtools.config import load_rig
from rigtools.demo import settings
from rigtools.demo.run import run_demo
from rigtools.demo.steps import load_system_cached
from rigtools.simulation import RunSettings, simulate_point

GOALS = {"quick": 60.0, "full": 600.0}


def baseline(cfg) -> float:
    _, system = load_system_cached(cfg, "fem")
    t0 = time.perf_counter()
    simulate_point(system.with_contact(gap=0.5e-3), 60.0, 15.0, RunSettings(duration=0.5))
    return time.perf_counter() - t0


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--quick-only", action="store_true")
    p.add_argument("--json", action="store_true")
    args = p.parse_args()
    cfg = load_rig(None)
    base = baseline(cfg)
    results = {"baseline_fem_run_s": base, "load_average": os.getloadavg()[0]}
    for name in ("quick",) if args.quick_only else ("quick", "full"):
        with tempfile.TemporaryDirectory() as tmp:
            t0, c0 = time.perf_counter(), time.process_time()
            run_demo(tmp, getattr(settings, name)())
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        results[name] = {
            "wall_s": wall,
            "cpu_s": cpu,
            "ratio_to_baseline": wall / base,
            "goal_s": GOALS[name],
            "met": wall < GOALS[name],
        }
    if args.json:
        print(json.dumps(results, indent=1))
        return
    print(f"baseline: one FEM dwell run {base:.2f} s (load average {results['load_average']:.1f})")
    for name in ("quick", "full"):
        if name in results:
            r = results[name]
            print(
                f"demo {name}: {r['wall_s']:.1f} s wall ({r['cpu_s']:.1f} s CPU) = {r['ratio_to_baseline']:.0f} x "
                f"baseline; goal < "
                f"{r['goal_s']:.0f} s wall {'met' if r['met'] else 'NOT met'}"
            )


if __name__ == "__main__":
    main()
