"""Compare a recording with the FE model
=======================================

    python docs/examples/compare_with_fem.py [EM.h5]

Runs the FE model at every point of an EM recording (driven by the measured force harmonics,
at the recorded gap) and prints the harmonics side by side with their differences; by default
it first makes a short dwell with impacts on the simulated rig.
"""

import sys
import tempfile
from pathlib import Path

import rigtools

if len(sys.argv) > 1:
    path = Path(sys.argv[1])
else:
    path = Path(tempfile.mkdtemp()) / "dwell.h5"
    rigtools.dwell("60 Hz", "15 N", path, gap="0.5 mm", record_periods=20, backend="sim", seed=1)

comparison = rigtools.compare_with_model(path)
for point in comparison.points:
    table = point.table  # one row per channel and harmonic k: EM, FEM (peak, SI) and difference
    shown = table[(table.k <= 3) & (table.channel != "contact_force")]
    print(f"point {point.em_index}: agreement score {point.score:.2f}")
    print(shown[["channel", "k", "frequency_hz", "em", "fem", "diff_pct"]].to_string(index=False))
for line in comparison.notes:
    print("note:", line)
