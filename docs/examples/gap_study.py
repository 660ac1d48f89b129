"""Force-controlled gap study (15 N, 60 Hz), the paper's Figure 10 on the rig
==========================================================================

    python docs/examples/gap_study.py [study.h5] [--resume]

Each point is written as it completes; rerun with --resume after an interruption. On the NI
rig the script asks the operator to set each gap and waits for Enter.
"""

import argparse
import tempfile
from pathlib import Path

from rigtools.config import load_rig
from rigtools.procedures import RigStudy


def ask_operator(gap: float, index: int) -> None:
    input(f"point {index + 1}: set the gap to {gap * 1e3:.2f} mm and press Enter ")


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("out", nargs="?", help="recording to write (default: in a new temporary folder)")
    p.add_argument("--backend", default="sim")
    p.add_argument("--resume", action="store_true")
    args = p.parse_args()
    out = args.out or str(Path(tempfile.mkdtemp()) / "gap_study.h5")
    study = RigStudy(
        load_rig(),
        {"kind": "gap", "values": [0.3e-3, 0.6e-3, 0.9e-3], "force": 15.0, "fe": 60.0, "record_periods": 30},
        out,
        backend=args.backend,
        overwrite=not args.resume,
        resume=args.resume,
        confirm_gap=ask_operator,
        progress=lambda e: e.kind == "point_done" and print(f"point {e.point}/{e.n_points} done"),
    )
    result = study.run()  # a RunResult, as rigtools.acquire_study returns
    for pt in result.points:
        h = pt.harmonics["passive_shroud_accel"]  # peak amplitudes of k = 1, 2, ...
        print(
            f"gap {pt.gap * 1e3:.2f} mm: F1 {pt.force_amplitude_measured:.2f} N, "
            f"passive shroud k=1..3: {', '.join(f'{a:.1f}' for a in h[:3])} m/s^2"
        )
    print(result.status)


if __name__ == "__main__":
    main()
