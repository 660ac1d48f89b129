"""Scripting the rig: dwell, spectrum, FRF and modes, comparison, branches over a sweep
=======================================================================================

The lab script of :doc:`../scripting`, on the simulated rig: a force-controlled dwell with the
shrouds impacting, the force spectrum of its settled window, an FRF test with the gap opened and
the modes it identifies, the dwell compared with the finite-element model, and a stepped sine up
and down drawn over the model's branches of periodic orbits (stable solid, unstable dashed, the
folds and grazing named). On the NI rig, give ``backend="nidaq"`` and ``rig="lab.toml"``.
"""

# %%
# A force-controlled dwell: 15 N at 60 Hz, gap 0.5 mm.
import tempfile
from pathlib import Path

import rigtools

folder = Path(tempfile.mkdtemp())
dwell = rigtools.dwell(
    "60 Hz", "15 N", folder / "dwell.h5", gap="0.5 mm", record_periods=20, seed=1, backend="sim"
)
print(dwell.status, f"F1 = {dwell.points[0].force_amplitude_measured:.2f} N")

# %%
# The force spectrum of its settled window (peak amplitudes, N).
with rigtools.open_recording(dwell.file) as recording:
    force = rigtools.spectrum(recording.points[0], "force")
print(f"F1 = {force.at(60.0):.2f} N, F2 = {force.at(120.0):.3f} N")

# %%
# An FRF test with the gap opened (no impacts) and the modes identified from it.
frf = rigtools.frf_test(
    ("20 Hz", "500 Hz"), "1 V", folder / "frf.h5", averages=4, gap="5 mm", seed=1, backend="sim"
)
modes = rigtools.analyze_recording(frf.file).points[0].frf.modes["active_shroud_accel"].modes
print("active blade modes (Hz):", [round(m.frequency_hz, 1) for m in modes])

# %%
# The dwell against the finite-element model at the same point (the FRF test's modes tune it).
comparison = rigtools.compare_with_model(dwell.file, frf=frf.file)
print(f"EM versus FEM agreement score: {comparison.mean_score:.2f} (1 = identical harmonics)")

# %%
# A stepped sine up and down over the impact range, and the model's branches over the same range
# (the simulated rig's own model under force control, so the two can meet).
import numpy as np

from rigtools.analysis.branches import BranchCurve, MeasuredSweep, branch_figure

sweep = rigtools.stepped_sine(
    list(np.arange(62.0, 72.5, 1.0)),
    "15 N",
    folder / "sweep.h5",
    gap="0.7 mm",
    direction="both",
    seed=1,
    backend="sim",
)
branches = rigtools.continuation("fe", "62 Hz", "72 Hz", gap="0.7 mm", force="15 N", model="rig")
curves = [
    BranchCurve(
        b.values(),
        b.measure("accel_harmonics_active")[:, 0],
        b.stable(),
        [p.labels for p in b.points],
        f"period {b.periods}",
    )
    for b in branches
]
measured = []
for direction in ("up", "down"):
    points = [p for p in sweep.points if p.extra.get("direction") == direction]
    fe = np.array([p.fe for p in points])
    response = np.array([p.harmonics["active_shroud_accel"][0] for p in points])
    measured.append(MeasuredSweep(fe, response, direction, f"stepped sine ({direction})"))
figure = branch_figure(
    curves,
    "excitation frequency (Hz)",
    "active shroud acceleration, k = 1 (m/s²)",
    measured=measured,
    title="stepped sine at 15 N, gap 0.7 mm, over the model's branches",
)
for b in branches:
    for p in b.labelled():
        print(f"period {b.periods}: {', '.join(p.labels)} at {p.value:.2f} Hz")
