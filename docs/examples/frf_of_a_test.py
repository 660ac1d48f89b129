"""FRF and modes of an FRF test
==============================

    python docs/examples/frf_of_a_test.py [FRF.h5]

H1 accelerance (response / force) over the averaged frames of an FRF test, its coherence, and
the modes identified (LSCF); by default it first runs a short chirp test on the simulated rig.
"""

import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import rigtools

if len(sys.argv) > 1:
    path = Path(sys.argv[1])
else:
    path = Path(tempfile.mkdtemp()) / "frf.h5"
    rigtools.frf_test("20 Hz:500 Hz", "1 V", path, averages=4, gap="5 mm", backend="sim", seed=1)

point = rigtools.analyze_recording(path).broadband[0]
est = point.frf.estimate
fig, ax = plt.subplots(figsize=(8, 4))
for row, response in enumerate(point.frf.responses):
    ax.semilogy(est.frequency_hz, np.abs(est.h1[row]), label=response)
    for mode in point.frf.modes[response].modes:
        print(f"{response}: {mode.frequency_hz:7.1f} Hz, damping {mode.damping_ratio * 100:.2f} %")
ax.set_xlim(point.params.get("band_low", 0), point.params.get("band_high", est.frequency_hz[-1]))
ax.set_xlabel("frequency (Hz)")
ax.set_ylabel("|H1| ((m/s²)/N)")
ax.legend()
fig.savefig(path.with_suffix(".frf.png"))
print("figure:", path.with_suffix(".frf.png"))
