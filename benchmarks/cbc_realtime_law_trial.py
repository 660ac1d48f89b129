"""A candidate real-time CBC law tried on the simulated rig (issue 33): the command's sweep with
the law ``(Kp, Kd, low-pass)`` in place of the default schedule from a switch amplitude up (below
it the schedule of ``rigtools.procedures.cbc_realtime.scheduled_gains``), each point printed with
its iterations (amplitude error and drive harmonics per iteration) against the model
(benchmarks/bench_cbc_realtime.py's), and the lost lines.

Run: ``PYTHONPATH=. python benchmarks/cbc_realtime_law_trial.py KP KD CORNER|none GRID SWITCH_MM
[--multipliers]``, e.g. ``2000 4.25 350 "0.30 mm:0.49 mm:0.0076 mm" 0.43 --multipliers`` (the
bench's sweep with Kd 4.25 from 0.43 mm; about a minute of CPU). ``KP`` 0: the default schedule.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from bench_cbc_realtime import model_at

import rigtools.procedures.cbc_realtime as rt
from rigtools.acquisition import AcquisitionAborted
from rigtools.procedures.cbc_door import control_based_continuation
from rigtools.recording import open_recording


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("kp", type=float)
    parser.add_argument("kd", type=float)
    parser.add_argument("corner")
    parser.add_argument("grid")
    parser.add_argument("switch_mm", type=float)
    parser.add_argument("--multipliers", action="store_true")
    args = parser.parse_args()
    corner = None if args.corner == "none" else float(args.corner)
    schedule = rt.scheduled_gains

    def law(amplitude: float) -> tuple[float, float, float | None]:
        return (args.kp, args.kd, corner) if amplitude >= args.switch_mm * 1e-3 else schedule(amplitude)

    if args.kp > 0:
        rt.scheduled_gains = law  # the loop looks the schedule up in its module at each hold
    out = Path(tempfile.mkdtemp()) / "trial.h5"
    t0, aborted, summary = time.process_time(), None, {}
    try:
        run = control_based_continuation(
            "64 Hz", args.grid, out, gap="0.5 mm", backend="sim", multipliers=args.multipliers
        )
        summary = run.summary
    except AcquisitionAborted as exc:
        aborted = str(exc)
    with open_recording(out) as rec:
        points = [dict(p.params) for p in rec.points if "converged" in p.params]
    good = 0
    for x in points:
        f_model = model_at(x["amplitude_m"])[0]
        err = x["force_fundamental_n"] / f_model - 1
        ok = (
            x["converged"]
            and abs(err) <= 0.02
            and x["drive_harmonics_ratio"] <= 0.01
            and x["iterations"] <= 8
        )
        good += ok
        errors = [round(v * 100, 2) for v in x["iteration_amplitude_error"]]
        ratios = [round(v * 100, 2) for v in x["iteration_drive_ratio"]]
        print(
            f"target {x['amplitude_target'] * 1e3:.4f} mm: A {x['amplitude_m'] * 1e3:.4f} mm F1 "
            f"{x['force_fundamental_n']:.3f} N ({err * 100:+.2f} %) {'ok' if ok else 'NOT ok'} in "
            f"{x['iterations']}; A error % {errors}, drive harmonics % {ratios} {x.get('branch', '')}"
        )
    for line in summary.get("lost", []):
        print(" ", line)
    print(
        f"law Kp {args.kp:g} Kd {args.kd:g} low-pass {args.corner} from {args.switch_mm} mm: {good} of "
        f"{len(points)} points ok, aborted: {aborted}; CPU {time.process_time() - t0:.0f} s"
    )


if __name__ == "__main__":
    main()
