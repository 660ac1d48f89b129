"""Force-controlled gap study at 15 N and 60 Hz
===============================================

Three gaps on the simulated rig, the force held at 15 N at each: the impacts make the shroud
accelerations rich in harmonics of the excitation frequency, more so as the gap changes. Each
point is written as it completes (``resume=True`` continues an interrupted study). On the NI rig
(``backend="nidaq"``) the operator sets each gap when asked.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import rigtools

gaps = ["0.3 mm", "0.6 mm", "0.9 mm"]
run = rigtools.acquire_study(
    "gap",
    gaps,
    Path(tempfile.mkdtemp()) / "gap.h5",
    fe="60 Hz",
    force="15 N",
    record_periods=10,
    seed=1,
    backend="sim",
)
print(f"{run.status}: {len(run.points)} points")

gap_mm = [p.gap * 1e3 for p in run.points]
fig, ax = plt.subplots(figsize=(7, 4))
for k in (1, 2, 3, 6):
    ax.plot(gap_mm, [p.harmonics["active_shroud_accel"][k - 1] for p in run.points], "o-", label=f"k = {k}")
ax.set_xlabel("gap (mm)")
ax.set_ylabel("active shroud acceleration, k·fe (m/s²)")
ax.set_title("gap study at 15 N, 60 Hz: harmonics of the active shroud")
ax.legend(title="harmonic")
for p in run.points:
    print(f"gap {p.gap * 1e3:.1f} mm: F1 {p.force_amplitude_measured:.2f} N")
