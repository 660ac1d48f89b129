"""Impact-hammer (tap) test of the passive blade
==============================================

The passive blade has no shaker; it is hit at 85 mm from the root so that its first three
flexural modes all move. The script prints the modes identified from H1 (shroud acceleration /
hammer force) over the accepted hits.

    python docs/examples/tap_test.py [tap.h5]
    python docs/examples/tap_test.py [tap.h5] --backend nidaq --rig lab.toml

On the NI rig the rig file needs the hammer's force channel, e.g.

    [daq.channels.hammer]
    physical_channel = "Dev1/ai3"
    kind = "force"
    sensitivity = "2.25 mV/N"      # IEPE modal hammer (calibration sheet)
    excitation_current = "4 mA"
    range = "2200 N"
    location = "impact hammer"

and the operator taps when the script says so (the gap opened by hand first).
"""

import argparse
import tempfile
from pathlib import Path

from rigtools.config import load_rig
from rigtools.procedures import TapTest
from rigtools.procedures.tap import tap_analysis


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("out", nargs="?", help="recording to write (default: in a new temporary folder)")
    p.add_argument("--backend", default="sim")
    p.add_argument("--rig", default=None)
    args = p.parse_args()
    out = args.out or str(Path(tempfile.mkdtemp()) / "tap_test.h5")
    test = TapTest(
        load_rig(args.rig),
        {"blade": "passive", "position": 0.085, "hits": 5, "gap": 5e-3 if args.backend == "sim" else None},
        out,
        backend=args.backend,
        overwrite=True,
        progress=lambda e: print(e.text) if e.kind in ("message", "point_done") else None,
    )
    result = test.run()  # a RunResult, as rigtools.tap_test returns
    print(f"{result.summary['accepted']} of {result.summary['hits']} hits accepted; {result.status}")
    res = tap_analysis(out, f_min=20, f_max=1600, n_modes=3)
    for m in res.modes[result.summary["response"]].modes:
        print(f"mode {m.frequency_hz:8.2f} Hz  damping {m.damping_ratio * 100:.2f} %")


if __name__ == "__main__":
    main()
