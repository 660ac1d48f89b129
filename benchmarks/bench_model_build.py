"""Building the FE model: time and peak memory against the element count, and what it gives.

For 100 / 400 / 1600 / 6400 elements per blade (each size in a fresh process, so the peak resident
memory is that size's), the default rig is built and reduced as every study and ``rig simulate``
does (:func:`rigtools.sim.rig_model.build_rig_model` + :func:`rigtools.sim.reduction.reduce_rig_model`:
sparse matrices, only the modes below the cutoff of the loaded DOF groups, by shift-invert
Lanczos polished through the element deformations, :mod:`rigtools.sim.deformation`). Printed per
size: wall time, peak RSS, the first three flexural frequencies of each blade, the kept modes
(normal + pseudo) and the FE static tip deflection against the closed form ``L^3 / 3EI`` (exact
for these elements: what is left is round-off), solved as the reduction does and, for
comparison, by a sparse LU of the assembled stiffness.

Goals (issue 20): 1600 elements within 10x the 100-element time; 6400 within 60 s; memory under
2 GB; the kept-mode count independent of the mesh; the frequencies converging monotonically. The
user limit (:data:`rigtools.sim.params.MAX_ELEMENTS`) is built too, to show what it costs.

Monotonic: consistent-mass Hermite elements are a Rayleigh-Ritz method, so on *nested* meshes each
frequency bounds the next from above (the benchmark says whether ``mesh_nodes`` nests the sizes:
the passive blade, uniform, does; the active blade, with the force sensor at 0.085 m, does not,
and there convergence need not be monotonic). A change smaller than the round-off cannot say which
way the mesh moved the frequency; the bound used, :data:`ROUND_OFF` relative, has a margin over
what was measured (tests/sim/test_deformation.py: at most 2.3e-15 from the closed form at
1600-25600 elements; at most 1.4e-14 between 6400 and 25600 elements on blades with the rig's
masses and rotary inertia).

For comparison the old build (all modes by dense LAPACK and the dense all-modes damping matrix,
still available as :attr:`rigtools.sim.rig_model.RigModel.damping` for the full-order reference) is
timed at 100 and 400 elements in the same run.

Run: .venv/bin/python benchmarks/bench_model_build.py
"""

from __future__ import annotations

import itertools
import json
import os
import resource
import subprocess
import sys
import time

SIZES = (100, 400, 1600, 6400)
ROUND_OFF = 1e-13  # relative, on a frequency (see the docstring)


def load_average() -> str:
    return f"load {os.getloadavg()[0]:.2f}"


def one(n: int, dense: bool) -> dict:
    """Build (and reduce, or the old dense path) at ``n`` elements; runs in its own process."""
    from dataclasses import replace

    from rigtools.config import load_rig
    from rigtools.runtime import configure_process
    from rigtools.sim.modal import _all_modes, flexural_frequencies
    from rigtools.sim.reduction import reduce_rig_model
    from rigtools.sim.rig_model import build_rig_model

    configure_process()
    p0 = load_rig(None).to_params()
    p = replace(p0, active=replace(p0.active, elements=n), passive=replace(p0.passive, elements=n))
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    model = build_rig_model(p)
    if dense:
        _all_modes(model.active)
        _all_modes(model.passive)
        model.damping  # noqa: B018 - the dense all-modes damping matrix is what is timed
        kept, pseudo = 0, 0
    else:
        reduced = reduce_rig_model(model)
        kept, pseudo = reduced.n_modes, int(reduced.pseudo.sum())
    seconds = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    import numpy as np
    import scipy.sparse.linalg as spla

    from rigtools.sim.blade import mesh_nodes
    from rigtools.sim.deformation import blade_stiffness
    from rigtools.sim.rig_model import blade_masses

    blade = model.passive
    tip = blade.dof(blade.tip_node, 1)
    e = np.zeros(blade.n_dofs)
    e[tip] = 1.0
    bp = p.passive
    exact = bp.length**3 / (3.0 * bp.youngs_modulus * bp.width * bp.thickness**3 / 12.0)
    static = float(blade_stiffness(blade).solve(e)[tip]) / exact - 1.0
    static_lu = float(spla.splu(blade.stiffness.tocsc()).solve(e)[tip]) / exact - 1.0
    nodes = {
        name: mesh_nodes(b.length, n, [m.position for m in blade_masses(p, name)]).tolist()
        for name, b in (("active", p.active), ("passive", p.passive))
    }
    return {
        "n": n,
        "seconds": seconds,
        "peak_mb": peak / 1024.0,
        "model_mb": (peak - base) / 1024.0,
        "f": [float(v) for v in flexural_frequencies(model.active, 3)],
        "f_passive": [float(v) for v in flexural_frequencies(model.passive, 3)],
        "kept": kept,
        "pseudo": pseudo,
        "static_error": static,
        "static_error_lu": static_lu,
        "nodes": nodes if not dense else {},
        "load": os.getloadavg()[0],
    }


def nested(coarse: list[float], fine: list[float]) -> bool:
    """Whether every node of ``coarse`` is a node of ``fine`` (to 1e-12 of the blade length)."""
    import numpy as np

    c, f = np.asarray(coarse), np.asarray(fine)
    return bool(np.all(np.min(np.abs(c[:, None] - f[None, :]), axis=1) <= 1e-12 * f[-1]))


def convergence(label: str, rows: list[dict], key: str, mesh_nested: bool) -> None:
    """Print each frequency per size, its changes, and what they say about monotonicity."""
    for k in range(3):
        seq = [r[key][k] for r in rows]
        steps = [b - a for a, b in itertools.pairwise(seq)]
        bound = [ROUND_OFF * abs(a) for a in seq[1:]]
        words = []
        for s, e in zip(steps, bound, strict=True):
            words.append("down" if s < -e else ("UP" if s > e else "within round-off"))
        verdict = "met" if all(s <= 0 for s in steps) else "NOT met"
        decided = sum(w == "down" for w in words)
        print(
            f"  {label} f{k + 1}: {', '.join(f'{v:.10f}' for v in seq)} Hz; changes "
            f"{', '.join(f'{s:+.1e} ({w})' for s, w in zip(steps, words, strict=True))}; "
            f"non-increasing: {verdict} (decreasing beyond round-off {ROUND_OFF:.0e} x f in {decided} of "
            f"{len(steps)} steps{'' if mesh_nested else '; meshes not nested: no guarantee'})"
        )


def run_child(n: int, dense: bool) -> dict:
    out = subprocess.run(
        [sys.executable, __file__, "--one", str(n), *(["--dense"] if dense else [])],
        capture_output=True,
        text=True,
        check=True,
        timeout=1800,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> int:
    if "--one" in sys.argv:
        print(json.dumps(one(int(sys.argv[sys.argv.index("--one") + 1]), "--dense" in sys.argv)))
        return 0
    print(f"FE model build + reduction of the default rig, elements per blade ({load_average()} at start)")
    rows = []
    for n in SIZES:
        r = run_child(n, dense=False)
        rows.append(r)
        f = ", ".join(f"{v:.6f}" for v in r["f"])
        print(
            f"  {n:5d} elements: {r['seconds']:6.2f} s, peak RSS {r['peak_mb']:6.0f} MB "
            f"(+{r['model_mb']:.0f} MB for the model), active f1-3 = {f} Hz, kept {r['kept']} modes "
            f"({r['pseudo']} pseudo), static tip deflection vs L^3/3EI {r['static_error']:+.1e} "
            f"(sparse LU of the assembled K: {r['static_error_lu']:+.1e}) (load {r['load']:.2f})"
        )
    by = {r["n"]: r for r in rows}
    ratio = by[1600]["seconds"] / by[100]["seconds"]
    print(f"1600 vs 100 elements: {ratio:.1f}x the time (goal <= 10x: {'met' if ratio <= 10 else 'NOT met'})")
    t64 = by[6400]["seconds"]
    print(f"6400 elements: {t64:.2f} s (goal <= 60 s: {'met' if t64 <= 60 else 'NOT met'})")
    peak = max(r["peak_mb"] for r in rows)
    print(f"peak memory: {peak:.0f} MB (goal < 2048 MB: {'met' if peak < 2048 else 'NOT met'})")
    kept = sorted({r["kept"] for r in rows})
    print(
        f"kept modes per size: {[r['kept'] for r in rows]} "
        f"(goal independent of the mesh: {'met' if len(kept) == 1 else 'NOT met'})"
    )
    worst = max(abs(r["static_error"]) for r in rows)
    print(f"static tip deflection: worst {worst:.1e} of L^3/3EI over the sizes (round-off only)")
    print("frequencies per size (goal: converging monotonically):")
    for name, key in (("active", "f"), ("passive", "f_passive")):
        ok = all(nested(a["nodes"][name], b["nodes"][name]) for a, b in itertools.pairwise(rows))
        print(
            f"  {name} blade: mesh_nodes nests {' -> '.join(str(n) for n in SIZES)}: {'yes' if ok else 'no'}"
        )
        convergence(name, rows, key, ok)
    from rigtools.sim.params import MAX_ELEMENTS

    r = run_child(MAX_ELEMENTS, dense=False)
    print(
        f"at the element limit, {MAX_ELEMENTS} per blade: {r['seconds']:.2f} s, peak RSS {r['peak_mb']:.0f} MB, "
        f"active f1-3 = {', '.join(f'{v:.10f}' for v in r['f'])} Hz, static tip deflection vs L^3/3EI "
        f"{r['static_error']:+.1e} (load {r['load']:.2f})"
    )
    print(f"old build for comparison (dense all-modes eigen-solve + dense damping matrix, {load_average()}):")
    for n in (100, 400):
        r = run_child(n, dense=True)
        new = by[n]["seconds"]
        print(
            f"  {n:5d} elements: {r['seconds']:6.2f} s, peak RSS {r['peak_mb']:6.0f} MB; "
            f"the new build {r['seconds'] / new:.1f}x faster"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
