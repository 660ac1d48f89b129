"""CPU cost of the periodic-orbit continuation: the batched finite-difference Jacobian versus the
per-column reference, in the same process.

Case: the simulated rig's model (the default rig's blades through its shaker, force control at
15 N, gap 0.7 mm, as ``rig continuation --param fe --force 15 --gap '0.7 mm'`` traces it), the
period-1 branch in fe from 55 to 80 Hz (628 points; ``--points`` caps it)
(:func:`rigtools.sim.continuation.continue_orbits`). New path: every Jacobian's state columns in
one compiled call (:meth:`rigtools.sim.orbit_map.PeriodMap.flows`). Baseline, same process:
the same branch with ``PeriodMap.jacobian(..., batched=False)``, one ``flow`` per column (the
reference the batched path equals bit for bit; the branches are compared here too). Also one
Jacobian at a converged orbit, each way (CPU per call).

Both runs share the cheaper stepper rebuild at each new fe (the map keeps its systems at the
gap, ``PeriodMap._systems_at``), so the ratio understates the gain over the code before both
changes; that is measured by running ``rig continuation`` from both versions (the helper's
report). Most of what is left is the compiled kernel's own arithmetic, which the batching does
not change. CPU seconds (``time.process_time``): the machine is shared, wall time says little.

    .venv/bin/python benchmarks/bench_continuation_speed.py              # ~12 s CPU
    .venv/bin/python benchmarks/bench_continuation_speed.py --points 100 --json
"""

from __future__ import annotations

import argparse
import contextlib
import json
import time
from collections.abc import Iterator
from contextlib import contextmanager
from functools import partialmethod

from rigtools.runtime import configure_process

configure_process()  # as `rig` does: one BLAS thread

import numpy as np

from rigtools.branches import simulated_rig_model
from rigtools.sim.continuation import ContinuationSettings, continue_orbits
from rigtools.sim.orbit_map import PeriodMap, map_for_range
from rigtools.sim.orbit_solver import solve_orbit

FE = (55.0, 80.0)
FORCE = 15.0
GAP = 0.7e-3


@contextmanager
def reference_jacobian() -> Iterator[None]:
    """Every :meth:`PeriodMap.jacobian` in the block takes the per-column reference path."""
    fast = PeriodMap.jacobian
    PeriodMap.jacobian = partialmethod(fast, batched=False)  # type: ignore[assignment, method-assign]  # the benchmark's switch
    try:
        yield
    finally:
        PeriodMap.jacobian = fast  # type: ignore[method-assign]  # restored


def branch_cpu(system, drive, points: int):
    """``(CPU s, branch)`` of the period-1 branch up to ``points`` points."""
    t0 = time.process_time()
    branch = continue_orbits(
        system,
        "fe",
        *FE,
        force=FORCE,
        gap=GAP,
        shaker=drive,
        settings=ContinuationSettings(max_points=points),
    )
    return time.process_time() - t0, branch


def jacobian_cpu(system, drive, repeats: int = 20) -> tuple[float, float]:
    """CPU seconds of one Jacobian (with the fe column) at a converged orbit: ``(batched,
    reference)``, each the mean of ``repeats`` calls."""
    pmap, p = map_for_range(system, "fe", 60.0, 61.0, 60.0, FORCE, GAP, 1, drive, None)
    y = solve_orbit(pmap, p).state * pmap.scale
    out = []
    for batched in (True, False):
        t0 = time.process_time()
        for _ in range(repeats):
            pmap.jacobian(y, p, "fe", batched=batched)
        out.append((time.process_time() - t0) / repeats)
    return out[0], out[1]


def same_branch(a, b) -> bool:
    """The two branches' points hold the same values, states and multipliers, bit for bit."""
    if len(a.points) != len(b.points):
        return False
    return all(
        pa.value == pb.value
        and np.array_equal(pa.state, pb.state)
        and np.array_equal(pa.multipliers, pb.multipliers)
        and pa.labels == pb.labels
        for pa, pb in zip(a.points, b.points, strict=True)
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=1000, help="most points of the branch (default 1000)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    _, system, drive = simulated_rig_model(None)
    # warm-up: numba compilation and caches out of the timing, both paths
    for path in (contextlib.nullcontext, reference_jacobian):
        with path():
            continue_orbits(
                system,
                "fe",
                55.0,
                56.0,
                force=FORCE,
                gap=GAP,
                shaker=drive,
                settings=ContinuationSettings(max_points=3),
            )

    jac_fast, jac_ref = jacobian_cpu(system, drive)
    t_fast, fast = branch_cpu(system, drive, args.points)
    with reference_jacobian():
        t_ref, ref = branch_cpu(system, drive, args.points)
    result = {
        "points": len(fast.points),
        "fe_reached_hz": float(fast.values()[-1]),
        "branch_cpu_s": t_fast,
        "branch_cpu_s_reference": t_ref,
        "branch_ratio": t_fast / t_ref,
        "jacobian_cpu_ms": 1e3 * jac_fast,
        "jacobian_cpu_ms_reference": 1e3 * jac_ref,
        "jacobian_ratio": jac_fast / jac_ref,
        "identical": same_branch(fast, ref),
    }
    if args.json:
        print(json.dumps(result, indent=2))
        return
    print(
        f"branch: {result['points']} points, 55 -> {result['fe_reached_hz']:.4g} Hz, rig model, force control"
    )
    print(f"  batched Jacobian:   {t_fast:7.2f} s CPU")
    print(f"  per-column (ref.):  {t_ref:7.2f} s CPU   ratio {result['branch_ratio']:.3f}")
    print(
        f"one Jacobian (31 columns incl. fe): {1e3 * jac_fast:.2f} ms CPU batched, {1e3 * jac_ref:.2f} ms per column,"
    )
    print(f"  ratio {result['jacobian_ratio']:.3f}")
    print(f"branches identical bit for bit: {result['identical']}")


if __name__ == "__main__":
    main()
