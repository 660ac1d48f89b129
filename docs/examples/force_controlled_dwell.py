"""Hold 15 N at 60 Hz with the shrouds impacting (0.5 mm gap), record 60 periods
=============================================================================

    python docs/examples/force_controlled_dwell.py [dwell.h5] [--backend nidaq|sim]

On the NI rig the gap is whatever the operator set (give the rig file with --rig in a real
lab); on the simulated rig it is set to 0.5 mm. The drive ramps to zero on every exit path.
"""

import argparse
import tempfile
from pathlib import Path

from rigtools.config import load_rig
from rigtools.procedures import SineDwell


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("out", nargs="?", help="recording to write (default: in a new temporary folder)")
    p.add_argument("--backend", default="sim")
    p.add_argument("--rig", default=None)
    args = p.parse_args()
    out = args.out or str(Path(tempfile.mkdtemp()) / "force_controlled_dwell.h5")
    cfg = load_rig(args.rig)
    dwell = SineDwell(
        cfg,
        {"fe": 60.0, "force": 15.0, "gap": 0.5e-3, "record_periods": 60},
        out,
        backend=args.backend,
        overwrite=True,
        progress=lambda e: (
            e.kind == "control" and print(f"update {e.update}: force error {e.control_error * 100:+.2f} %")
        ),
    )
    result = dwell.run()  # a RunResult, as rigtools.dwell returns
    point = result.points[0]
    print(
        f"{result.status}: F1 = {point.force_amplitude_measured:.3f} N at "
        f"{point.drive_amplitude:.3f} V after {point.control_updates} updates, "
        f"settled {point.settled}"
    )


if __name__ == "__main__":
    main()
