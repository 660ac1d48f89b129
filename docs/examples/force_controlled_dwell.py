"""Hold 15 N at 60 Hz with the shrouds impacting, and how force control got there
=================================================================================

A dwell on the simulated rig (gap 0.5 mm): the drive starts low, each control update measures the
force fundamental and corrects the drive, and once the force holds within tolerance the rig
records 20 settled periods. The figure is the convergence: the drive and the measured force at
each update, the target dashed. On the NI rig give ``backend="nidaq"`` and ``rig="lab.toml"``
(the gap is then whatever the operator set); the drive ramps to zero on every exit path.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import rigtools

run = rigtools.dwell(
    "60 Hz",
    "15 N",
    Path(tempfile.mkdtemp()) / "dwell.h5",
    gap="0.5 mm",
    record_periods=20,
    seed=1,
    backend="sim",
)
point = run.points[0]
print(f"{run.status}: F1 = {point.force_amplitude_measured:.2f} N with {point.drive_amplitude:.3f} V drive")
print(f"{point.control_updates} control updates, settled: {point.settled}")

history = point.extra["control_history"]  # (drive V, measured force N) at each update
updates = range(1, len(history) + 1)
fig, (ax_force, ax_drive) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
ax_force.plot(updates, [force for _, force in history], "o-", label="measured F1")
ax_force.axhline(15.0, color="k", ls="--", lw=1, label="target 15 N")
ax_force.set_ylabel("force amplitude (N)")
ax_force.legend()
ax_drive.plot(updates, [drive for drive, _ in history], "s-", color="C1")
ax_drive.set_ylabel("drive amplitude (V)")
ax_drive.set_xlabel("control update")
fig.suptitle("force control at 60 Hz, gap 0.5 mm")
