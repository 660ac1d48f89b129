"""The model's F1(A) curve at fe = 64 Hz, gap 0.5 mm (the simulated rig with its shaker, the force
fundamental held): the reference the CBC tests hold the measured points against.

Run ``PYTHONPATH=. python benchmarks/cbc_model_reference.py`` (about 1 min of CPU): it continues the
period-1 branch in fe at F1 = 5 N from 56 Hz (an impacting orbit) through the fold at 64.58 Hz,
takes its two impacting orbits at 64 Hz, continues each in the force over the S-curve and writes
``tests/rigtools/data/cbc_model_64hz.json``: per point F1 (N), the fundamental amplitude of the active
shroud's displacement A (m, from its acceleration's fundamental / w^2), half its peak-to-peak, the
largest Floquet multiplier's modulus and stability; and the scaled state of the unstable 5 N orbit
(so that a test re-solves that one orbit with Newton in a second and checks the table is today's model).

``--sheet`` (about 1 min more) adds ``sheet_to_grazing``: the unstable 5 N orbit continued in the
force up to 11.5 N (grazing near 11.25 N), the S-curve's unstable part up to A ~ 0.49 mm and beyond
with its multipliers, the reference of the real-time CBC (``benchmarks/bench_cbc_realtime.py``);
the rest of the file is kept as it is.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from rigtools.branches import simulated_rig_model
from rigtools.sim.continuation import ContinuationSettings, PeriodMap, continue_orbits, orbit_at

FE, GAP, F_START = 64.0, 0.5e-3, 5.0
OUT = Path(__file__).resolve().parents[1] / "tests" / "rigtools" / "data" / "cbc_model_64hz.json"


def rows(branch) -> list[dict]:
    return [row(p) for p in branch.points]


def row(p) -> dict:
    w = 2 * math.pi * FE
    return {
        "force_n": float(p.value),
        "amplitude_m": float(p.measures.accel_harmonics_active[0] / w**2),
        "tip_amplitude_m": float(p.measures.tip_amplitude_active),
        "max_multiplier": float(p.max_multiplier),
        "stable": bool(p.stable),
        "impacts_per_period": float(p.measures.impacts_per_period),
        "drive_v": float(p.measures.drive_amplitude),
    }


def sheet() -> None:
    """Add ``sheet_to_grazing`` to the table: the unstable 5 N orbit continued up to 11.5 N."""
    doc = json.loads(OUT.read_text())
    _cfg, system, shaker = simulated_rig_model(None)
    spp = doc["steps_per_period"]
    ref = doc["unstable_5n"]
    b = continue_orbits(
        system,
        "force",
        F_START,
        11.5,
        fe=FE,
        force=F_START,
        gap=GAP,
        shaker=shaker,
        y0=np.array(ref["state_scaled"]),
        settings=ContinuationSettings(locate=False, refine=False, steps_per_period=spp, max_points=2000),
    )
    print(f"unstable orbit towards 11.5 N: {len(b.points)} points, {b.status} {b.message}")
    doc["sheet_to_grazing"] = sorted(rows(b), key=lambda r: r["amplitude_m"])
    OUT.write_text(json.dumps(doc, indent=1))
    a = [r["amplitude_m"] for r in doc["sheet_to_grazing"]]
    print(f"A {min(a) * 1e3:.4f} .. {max(a) * 1e3:.4f} mm; wrote {OUT}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sheet", action="store_true", help="add sheet_to_grazing only")
    if parser.parse_args().sheet:
        sheet()
        return
    _cfg, system, shaker = simulated_rig_model(None)
    quick = ContinuationSettings(locate=False, refine=False)
    fe_branch = continue_orbits(
        system, "fe", 56.0, 66.0, fe=FE, force=F_START, gap=GAP, shaker=shaker, settings=quick
    )
    at = [p for p in orbit_at(system, fe_branch, FE, shaker=shaker) if p.measures.impacts_per_period > 0]
    stable = min(at, key=lambda p: p.max_multiplier)
    unstable = max(at, key=lambda p: p.max_multiplier)
    pmap = PeriodMap(system, fe_branch.steps_per_period, 1, shaker)
    points: list[dict] = []
    # from each orbit at 5 N towards the F1 minimum (a fold in F1, where the tracer may stall:
    # from both sides), the unstable one up to 6 N, the stable one up to 7 N (A below 0.30 mm)
    for p, stop in ((stable, 4.5), (unstable, 4.5), (unstable, 6.0), (stable, 12.0)):
        b = continue_orbits(
            system,
            "force",
            F_START,
            stop,
            fe=FE,
            force=F_START,
            gap=GAP,
            shaker=shaker,
            y0=p.state * pmap.scale,
            settings=ContinuationSettings(
                locate=False, refine=False, steps_per_period=fe_branch.steps_per_period
            ),
        )
        print(f"from {p.max_multiplier:.3f} towards {stop} N: {len(b.points)} points, {b.status} {b.message}")
        points.extend(rows(b))
    # the orbit without contact at the same A (F1 linear in A): the CBC finds it where the
    # impacting branch does not reach (A below about 0.305 mm) or when it loses the impacts
    linear = continue_orbits(
        system, "force", 6.0, 8.5, fe=FE, force=6.0, gap=GAP, shaker=shaker, settings=quick
    )
    print(f"no contact: {len(linear.points)} points, {linear.status}")
    points.extend(rows(linear))
    points.sort(key=lambda r: r["amplitude_m"])
    doc = {
        "what": "F1(A) of the simulated rig's model at fe = 64 Hz, gap 0.5 mm (benchmarks/cbc_model_reference.py)",
        "fe_hz": FE,
        "gap_m": GAP,
        "steps_per_period": fe_branch.steps_per_period,
        "points": points,
        "unstable_5n": {
            "state_scaled": [float(v) for v in unstable.state * pmap.scale],
            "amplitude_m": row(unstable)["amplitude_m"],
            "max_multiplier": float(unstable.max_multiplier),
        },
    }
    OUT.write_text(json.dumps(doc, indent=1))
    f = np.array([r["force_n"] for r in points])
    a = np.array([r["amplitude_m"] for r in points])
    i = int(np.argmin(np.where(a > 0.3e-3, f, np.inf)))
    print(f"{len(points)} points; F1 minimum {f[i]:.4f} N at A {a[i] * 1e3:.4f} mm; wrote {OUT}")


if __name__ == "__main__":
    main()
