"""The real-time CBC's measured multipliers next to the fold, on four short paths (issue 33: within
10 % of the model's where |mu| <= 2). Each path is its own run of the CBC from the approach, so
the points differ from path to path; the largest measured multiplier of each point is printed
beside the model's at the measured A (tests/rigtools/data/cbc_model_64hz.json, as
benchmarks/bench_cbc_realtime.py reads it).

Run: ``PYTHONPATH=. python benchmarks/cbc_realtime_fold_paths.py`` (about a minute of CPU).
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_cbc_realtime import model_at

import rigtools

PATHS = (
    "0.3298 mm,0.3389 mm,0.3458 mm",
    "0.330 mm:0.360 mm:0.0075 mm",
    "0.3221 mm,0.3298 mm,0.3389 mm,0.3458 mm,0.3538 mm,0.3618 mm",
    "0.3320 mm,0.3360 mm,0.3400 mm,0.3440 mm,0.3480 mm",
)


def main() -> None:
    worst, count, fitted = 0.0, 0, 0
    for path in PATHS:
        print(f"targets {path}")
        out = Path(tempfile.mkdtemp()) / "fold.h5"
        run = rigtools.control_based_continuation("64 Hz", path, out, gap="0.5 mm", backend="sim")
        for p in run.points:
            x = p.extra
            _f1, mu_model = model_at(x["amplitude_m"])
            mu = x.get("max_multiplier", math.nan)
            err = mu / mu_model - 1
            count += 1
            if math.isfinite(err):  # a point without a trusted fit carries no multiplier: counted apart
                fitted += 1
                worst = max(worst, abs(err))
            print(
                f"  A {x['amplitude_m'] * 1e3:.4f} mm  |mu| {mu:.3f}  model {mu_model:.3f} ({err * 100:+.1f} %)"
                f"  releases {x.get('multipliers_releases', math.nan):.0f}"
                f"  drive probe {x.get('multipliers_drive_probe', math.nan):g}"
                f"  residual {x.get('multipliers_residual', math.nan):.3f}"
                + (
                    f"  [not measured: {x['multipliers_not_measured']}]"
                    if "multipliers_not_measured" in x
                    else ""
                )
            )
    print(
        f"{count} points, {fitted} fitted: worst {worst * 100:.1f} % -> {'met' if worst <= 0.10 else 'NOT met'} (10 %)"
    )


if __name__ == "__main__":
    main()
