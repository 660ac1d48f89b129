"""Wall time and model evaluations of the linear model update (issue 11).

Case: the default rig (nominal: clamped root, 1 % damping) fitted to the simulated rig's test
article (its exact first three flexural frequencies and damping ratios of both blades), the
parameters ``root.rotational_stiffness, root.translational_stiffness, shroud.mass,
force_sensor.mass, damping.ratio`` free (the widest fit the rig file's deviations call for).

Same-run baselines:

* one model evaluation of the fit (:func:`sim.updating.predict`: both blades built, the lowest
  flexural modes solved); the fit's time over it says how much the fit costs beyond its
  evaluations;
* one evaluation the plain way (:func:`sim.rig_model.build_rig_model` and
  :func:`sim.modal.flexural_frequencies`: every mode of every DOF group), what a fit built on the
  existing modal code would pay per evaluation.

Goal: the fit in < 60 s on this machine.

    .venv/bin/python benchmarks/bench_update.py          # ~10-30 s
    .venv/bin/python benchmarks/bench_update.py --json
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from rigtools.config import load_rig  # noqa: E402
from sim.modal import flexural_frequencies  # noqa: E402
from sim.rig_model import build_rig_model  # noqa: E402
from sim.updating import mode_targets, predict, update_model  # noqa: E402

NAMES = ["root.rotational_stiffness", "root.translational_stiffness", "shroud.mass", "force_sensor.mass",
         "damping.ratio"]
GOAL_S = 60.0


def best_of(repeats, fn):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", action="store_true", help="print the figures as JSON")
    ap.add_argument("--repeats", type=int, default=3, help="best of N for the baselines (default 3)")
    args = ap.parse_args()

    cfg = load_rig(None)
    nominal = cfg.to_params()
    spec = cfg.test_article.to_params()
    article = spec.apply(nominal)
    targets = mode_targets(article, 3, damping=True)

    t_eval = best_of(args.repeats, lambda: predict(nominal, targets))

    def plain():
        model = build_rig_model(nominal)
        flexural_frequencies(model.active, 3), flexural_frequencies(model.passive, 3)

    t_plain = best_of(args.repeats, plain)
    res = update_model(nominal, targets, NAMES)
    met = res.wall_time < GOAL_S
    out = {
        "parameters": NAMES,
        "fit_wall_s": res.wall_time,
        "model_evaluations": res.n_evaluations,
        "one_evaluation_s": t_eval,
        "one_plain_evaluation_s": t_plain,
        "fit_over_one_evaluation": res.wall_time / t_eval,
        "plain_over_fast_evaluation": t_plain / t_eval,
        "max_frequency_error_before": res.max_frequency_error_before,
        "max_frequency_error_after": res.max_frequency_error_after,
        "root_rotational_stiffness": res.fitted["root.rotational_stiffness"],
        "root_rotational_stiffness_true": spec.root_rotational_stiffness,
        "damping_ratio": res.fitted["damping.ratio"],
        "goal_s": GOAL_S,
        "met": met,
    }
    if args.json:
        print(json.dumps(out, indent=1))
        return
    print(res.report())
    print()
    print(f"one model evaluation (fit's solver) {1e3 * t_eval:8.1f} ms   "
          f"plain build_rig_model + flexural_frequencies {1e3 * t_plain:8.1f} ms   "
          f"ratio {t_plain / t_eval:.1f}x")
    print(f"linear fit ({len(NAMES)} parameters, 12 targets): {res.wall_time:.2f} s, "
          f"{res.n_evaluations} model evaluations = {res.wall_time / t_eval:.0f}x one evaluation   "
          f"goal < {GOAL_S:.0f} s: {'met' if met else 'NOT met'}")


if __name__ == "__main__":
    main()
