"""Periodic-chirp FRF test (no impacts: gap opened to 5 mm), H1 peaks as a check
=============================================================================

python docs/examples/frf_test.py [frf.h5]
"""

import argparse
import tempfile
from pathlib import Path

from rigtools.config import load_rig
from rigtools.procedures.frf import FrfTest, quick_check


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("out", nargs="?", help="recording to write (default: in a new temporary folder)")
    p.add_argument("--backend", default="sim")
    args = p.parse_args()
    out = args.out or str(Path(tempfile.mkdtemp()) / "frf_test.h5")
    FrfTest(
        load_rig(),
        {"signal": "chirp", "band": (20.0, 500.0), "level": 0.3, "frame": 0.5, "averages": 4, "gap": 5e-3},
        out,
        backend=args.backend,
        overwrite=True,
    ).run()
    for pk in quick_check(out)["peaks"]:
        print(
            f"peak {pk['frequency_hz']:6.1f} Hz  |H1| {pk['h1']:8.2f} (m/s^2)/N  coherence {pk['coherence']:.4f}"
        )


if __name__ == "__main__":
    main()
