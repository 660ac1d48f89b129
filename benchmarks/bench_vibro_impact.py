"""Speed and accuracy of the fast vibro-impact integrator versus the full-order reference.

Default case of issue 3: default rig, fe = 60 Hz, F0 = 15 N, gap 0.5 mm.

* fast: the reduced model (modes below 6 kHz + static correction) stepped by the compiled kernel
  (:class:`rigtools.sim.vibro_impact.VibroImpactStepper`) at its default step (30 steps per contact
  period); wall seconds per simulated second (best of ``--repeats`` runs of ``--seconds``
  simulated seconds) and the real-time factor;
* reference: the full-order HHT/Newmark integrator on the full FE matrices
  (:mod:`rigtools.sim.full_order`, 1760 steps per period: converged to ~0.2 %), timed in the same process
  in its exact modal form and (a few hundred steps, scaled) with the dense full-matrix solver;
  the ratios;
* accuracy: harmonics k = 1, 6, 8 of both shroud accelerations and the peak contact force,
  fast (settled run) versus reference (4 s from rest), and the fast run with the step halved;
* study: a 5-point gap study (0.3-0.9 mm) to steady state, after warm-up (each point from rest,
  and carrying the state).

Goals: >= 300x faster than real time on one core with 1 % accuracy; the study in < 2 s.

    .venv/bin/python benchmarks/bench_vibro_impact.py          # ~15 s
    .venv/bin/python benchmarks/bench_vibro_impact.py --json
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from rigtools.analysis.harmonics import derivative_harmonics, harmonic_amplitudes
from rigtools.config import load_rig
from rigtools.sim.full_order import FullOrderIntegrator, run_full_order
from rigtools.sim.reduction import reduced_system
from rigtools.sim.rig_model import build_rig_model
from rigtools.sim.studies import run_study
from rigtools.sim.vibro_impact import N_OUT, VibroImpactStepper, run_harmonic, steps_per_period_for

FE, F0 = 60.0, 15.0
REF_STEPS = 1760
GAPS = [0.3e-3, 0.45e-3, 0.6e-3, 0.75e-3, 0.9e-3]


def accel_harmonics(outputs, fs):
    return {
        tip: derivative_harmonics(harmonic_amplitudes(outputs[f"{tip}_velocity"], fs, FE, 30)).amplitude
        for tip in ("active_tip", "passive_tip")
    }


def best_of(repeats, fn):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=5.0, help="simulated seconds per fast timing run")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()

    params = load_rig().to_params()
    model = build_rig_model(params)
    system = reduced_system(params, rig_model=model)
    n = steps_per_period_for(system, FE)
    dt = 1.0 / (FE * n)

    # warm-up: compile (or load the cache of) every kernel
    run_harmonic(system, FE, F0, record_periods=1, max_settle_time=0.05)
    FullOrderIntegrator(model, 1.0 / (FE * REF_STEPS)).step(np.zeros(10))
    run_study(system, "gap", GAPS[:1], record_periods=1, max_settle_time=0.05)

    # fast integrator, wall per simulated second
    steps = round(args.seconds / dt)
    u = F0 * np.sin(2 * np.pi * FE * dt * np.arange(1, steps + 1))
    out = np.empty((steps, N_OUT))

    def fast():
        VibroImpactStepper(system, dt).step(u, out)

    t_fast = best_of(args.repeats, fast) / (steps * dt)

    # full-order reference, same process
    ref_seconds = 0.5
    ref_steps = round(ref_seconds * FE * REF_STEPS)
    uf = F0 * np.sin(2 * np.pi * FE / (FE * REF_STEPS) * np.arange(1, ref_steps + 1))

    def full():
        FullOrderIntegrator(model, 1.0 / (FE * REF_STEPS)).step(uf)

    t_full = best_of(1, full) / ref_seconds
    phys_steps = 300  # the dense-matrix solver is slow: time a few steps and scale
    t_phys = best_of(
        1, lambda: FullOrderIntegrator(model, 1.0 / (FE * REF_STEPS), solver="physical").step(uf[:phys_steps])
    ) / (phys_steps / (FE * REF_STEPS))

    # accuracy against the reference
    run = run_harmonic(system, FE, F0)
    run2 = run_harmonic(system, FE, F0, steps_per_period=2 * n)
    ref = run_full_order(model, FE, F0, 4.0, 1.0 / (FE * REF_STEPS), record_periods=5)
    h, h2, hr = (
        accel_harmonics(run.outputs, run.sample_rate),
        accel_harmonics(run2.outputs, run2.sample_rate),
        accel_harmonics(ref, FE * REF_STEPS),
    )
    acc = {}
    for tip in h:
        for k in (1, 6, 8):
            acc[f"{tip} k={k}"] = {
                "fast": float(h[tip][k - 1]),
                "reference": float(hr[tip][k - 1]),
                "vs_reference_pct": float(100 * (h[tip][k - 1] / hr[tip][k - 1] - 1)),
                "half_step_change_pct": float(100 * (h2[tip][k - 1] / h[tip][k - 1] - 1)),
            }
    peak = {"fast": run.peak_contact_force, "reference": float(ref["contact_force"].max())}
    energy = run.energy_balance()["imbalance"]

    # 5-point gap study after warm-up
    t_study_rest = best_of(args.repeats, lambda: run_study(system, "gap", GAPS, carry_state=False))
    t_study_carry = best_of(args.repeats, lambda: run_study(system, "gap", GAPS, carry_state=True))
    runs = [p.run for p in run_study(system, "gap", GAPS, carry_state=False).points]

    result = {
        "modes": int(system.n_modes),
        "steps_per_period": n,
        "time_step_us": dt * 1e6,
        "contact_period_ms": run.contact_period * 1e3,
        "fast_wall_s_per_sim_s": t_fast,
        "fast_real_time_factor": 1.0 / t_fast,
        "ns_per_step": t_fast * dt * 1e9,
        "reference_wall_s_per_sim_s": t_full,
        "reference_real_time_factor": 1.0 / t_full,
        "speedup_vs_reference": t_full / t_fast,
        "reference_physical_wall_s_per_sim_s": t_phys,
        "speedup_vs_physical_reference": t_phys / t_fast,
        "accuracy": acc,
        "peak_contact_force_n": peak,
        "energy_imbalance_pct": 100 * energy,
        "fast_settle_time_s": run.settle_time,
        "steady_state": run.steady_state,
        "gap_study_5_points_s_from_rest": t_study_rest,
        "gap_study_5_points_s_carried": t_study_carry,
        "gap_study_simulated_s": float(sum(r.settle_time + r.record_periods / r.fe for r in runs)),
    }
    if args.json:
        print(json.dumps(result, indent=1))
        return
    print(
        f"default case: fe = {FE:g} Hz, F0 = {F0:g} N, gap {params.contact.gap * 1e3:g} mm; "
        f"{system.n_modes} modes, {n} steps/period (dt = {dt * 1e6:.1f} us, contact period "
        f"{run.contact_period * 1e3:.2f} ms)"
    )
    print(
        f"fast:      {t_fast * 1e3:8.3f} ms wall per simulated s   real-time factor {1 / t_fast:7.0f}x   "
        f"({t_fast * dt * 1e9:.0f} ns/step)   goal >= 300x"
    )
    print(
        f"reference: {t_full * 1e3:8.1f} ms wall per simulated s   real-time factor {1 / t_full:7.1f}x   "
        f"({REF_STEPS} steps/period)"
    )
    print(
        f"reference, dense full-matrix solver: {t_phys:8.1f} s wall per simulated s (from {phys_steps} steps)"
    )
    print(
        f"fast / reference speed-up: {t_full / t_fast:.0f}x (modal form), {t_phys / t_fast:.0f}x (dense solver)"
    )
    print("harmonic amplitudes of the shroud accelerations (m/s^2):")
    for key, a in acc.items():
        print(
            f"  {key:16s} fast {a['fast']:9.3f}  reference {a['reference']:9.3f}  "
            f"diff {a['vs_reference_pct']:+6.2f} %  (goal 1 %)   half step {a['half_step_change_pct']:+6.3f} % (goal 0.5 %)"
        )
    print(
        f"peak contact force: fast {peak['fast']:.2f} N, reference {peak['reference']:.2f} N "
        f"({100 * (peak['fast'] / peak['reference'] - 1):+.2f} %); energy imbalance {100 * energy:+.3f} % "
        f"(goal 1 %); steady after {run.settle_time:.2f} s"
    )
    print(
        f"gap study, 5 points to steady state: {t_study_rest:.3f} s from rest, {t_study_carry:.3f} s "
        f"carrying the state (goal < 2 s)"
    )


if __name__ == "__main__":
    main()
