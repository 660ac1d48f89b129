"""Compare a dwell with the finite-element model
================================================

The FE model runs at every point of a recording (driven by the measured force harmonics, at the
recorded gap) and the harmonics are set side by side. Here the recording is a short dwell with
impacts on the simulated rig; give your own recording's path instead. The figure overlays the
measured (EM) and simulated (FEM) waveforms and spectra.
"""

import tempfile
from pathlib import Path

import rigtools

path = Path(tempfile.mkdtemp()) / "dwell.h5"
rigtools.dwell("60 Hz", "15 N", path, gap="0.5 mm", record_periods=20, seed=1, backend="sim")

comparison = rigtools.compare_with_model(path)
for point in comparison.points:
    table = point.table  # one row per channel and harmonic k: EM, FEM (peak, SI) and difference
    shown = table[(table.k <= 3) & (table.channel != "contact_force")]
    print(f"point {point.em_index}: agreement score {point.score:.2f}")
    print(shown[["channel", "k", "frequency_hz", "em", "fem", "diff_pct"]].to_string(index=False))
for line in comparison.notes:
    print("note:", line)

overlay = next(fig for name, fig, _ in comparison.figures() if "overlay" in name)
