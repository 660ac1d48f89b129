"""The PLL's must-show figures (issue 33) on the simulated rig, gap 0.5 mm, each with "met" or
"NOT met", against the model (benchmarks/pll_model_reference.py's numbers, as the tests hold them).

    PYTHONPATH=. python benchmarks/bench_pll.py

Prints: the 0.2 N lock (frequency error against the linear phase resonance, periods to lock,
phase error RMS); the backbone at 1, 2, 5, 10 N (fe and A errors against the model's -90 deg
orbits); the 5 N stepped phase at -152, -156, -165 deg from the default start (fe and A errors);
the CPU each took.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import h5py

import rigtools
from rigtools.branches import simulated_rig_model
from rigtools.sim.phase_points import linear_phase_resonance

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "rigtools"))
# the one copy of the model's numbers
from test_pll import BACKBONE, STEPPED_5N


def verdict(ok: bool) -> str:
    return "met" if ok else "NOT met"


def main() -> None:
    folder = Path(tempfile.mkdtemp())
    _, system, _ = simulated_rig_model(None)
    f_lin = linear_phase_resonance(system)

    t = time.process_time()
    run = rigtools.phase_locked_loop("0.2 N", folder / "lin.h5", gap="0.5 mm", backend="sim")
    x = run.points[0].extra
    with h5py.File(run.file, "r") as f:
        rms = float(f["points/0000"].attrs["phase_error_rms"])
    err = x["fe_hz"] / f_lin - 1
    ok = x["converged"] and abs(err) <= 1e-3 and x["iterations"] <= 150 and rms <= 1.0
    print(
        f"0.2 N, -90 deg: fe {x['fe_hz']:.4f} Hz vs {f_lin:.4f} Hz ({err * 100:+.4f} %), "
        f"{x['iterations']} periods, phase RMS {rms:.3f} deg: {verdict(ok)} "
        f"(CPU {time.process_time() - t:.1f} s)"
    )

    t = time.process_time()
    run = rigtools.phase_locked_loop("1 N,2 N,5 N,10 N", folder / "bb.h5", gap="0.5 mm", backend="sim")
    for point, (force, (fe, amp)) in zip(run.points, BACKBONE.items(), strict=True):
        x = point.extra
        e_f, e_a = x["fe_hz"] / fe - 1, x["amplitude_m"] / amp - 1
        ok = x["converged"] and abs(e_f) <= 2e-3 and abs(e_a) <= 0.03
        print(
            f"backbone {force:g} N: fe {x['fe_hz']:.4f} Hz ({e_f * 100:+.4f} %), A {x['amplitude_m'] * 1e3:.4f} mm "
            f"({e_a * 100:+.2f} %), {x['iterations']} periods: {verdict(ok)}"
        )
    print(f"  (backbone CPU {time.process_time() - t:.1f} s)")

    t = time.process_time()
    phases = ",".join(f"{p:g} deg" for p in STEPPED_5N)
    run = rigtools.phase_locked_loop("5 N", folder / "fr.h5", phases=phases, gap="0.5 mm", backend="sim")
    for point, (phase, (fe, amp)) in zip(run.points, STEPPED_5N.items(), strict=True):
        x = point.extra
        e_f, e_a = x["fe_hz"] / fe - 1, x["amplitude_m"] / amp - 1
        ok = x["converged"] and abs(e_f) <= 1e-3 and abs(e_a) <= 0.02
        print(
            f"5 N, {phase:g} deg: fe {x['fe_hz']:.4f} Hz vs {fe:.4f} ({e_f * 100:+.3f} %), A "
            f"{x['amplitude_m'] * 1e3:.4f} vs {amp * 1e3:.4f} mm ({e_a * 100:+.2f} %), phase "
            f"{x['phase_deg']:.2f} deg, converged {x['converged']}: {verdict(ok)}"
        )
    print(f"  (stepped phase CPU {time.process_time() - t:.1f} s)")


if __name__ == "__main__":
    main()
