"""Stepped sine up and down at 15 N across the impact range, with jumps
====================================================================

python docs/examples/stepped_sine.py [sweep.h5]
"""

import argparse
import tempfile
from pathlib import Path

import numpy as np

from rigtools.config import load_rig
from rigtools.procedures import SteppedSine


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("out", nargs="?", help="recording to write (default: in a new temporary folder)")
    p.add_argument("--backend", default="sim")
    args = p.parse_args()
    out = args.out or str(Path(tempfile.mkdtemp()) / "stepped_sine.h5")
    sweep = SteppedSine(
        load_rig(),
        {
            "frequencies": list(np.arange(62.0, 72.01, 2.0)),
            "force": 15.0,
            "gap": 0.7e-3,
            "direction": "both",
            "record_periods": 10,
        },
        out,
        backend=args.backend,
        overwrite=True,
    )
    result = sweep.run()  # a RunResult, as rigtools.stepped_sine returns
    for pt in result.points:
        print(
            f"{pt.fe:5.1f} Hz {pt.extra['direction']:>4}: active shroud "
            f"{pt.harmonics['active_shroud_accel'][0]:7.1f} m/s^2 at F1 "
            f"{pt.force_amplitude_measured:.2f} N"
        )
    for direction, jumps in result.summary["jumps"].items():
        for j in jumps:
            print(f"jump ({direction}): {j['from_hz']:g} -> {j['to_hz']:g} Hz")


if __name__ == "__main__":
    main()
