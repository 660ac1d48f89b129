"""Dwell, spectrum, FRF and comparison with the FEM in one lab script
=====================================================================

15 N at 60 Hz with impacts (gap 0.5 mm), then an FRF test and the FEM, on the simulated rig."""

import tempfile
from pathlib import Path

import rigtools

folder = Path(tempfile.mkdtemp())
dwell = rigtools.dwell("60 Hz", "15 N", folder / "dwell.h5", gap="0.5 mm", periods=20, backend="sim", seed=1)
with rigtools.open_recording(dwell.file) as rec:
    force = rigtools.spectrum(rec.points[0], "force")
print(f"{dwell.status}: F1 = {force.at(60.0):.2f} N, F2 = {force.at(120.0):.3f} N (peak)")
frf = rigtools.frf_test("20 Hz:500 Hz", "1 V", folder / "frf.h5", averages=4, gap="5 mm", backend="sim")
modes = rigtools.analyze_recording(frf.file).points[0].frf.modes["active_shroud_accel"].modes
print("active blade modes (Hz):", [round(m.frequency_hz, 1) for m in modes])
comparison = rigtools.compare_with_model(dwell.file, frf=frf.file)
print(f"EM versus FEM agreement score: {comparison.mean_score:.2f} (1 = identical harmonics)")
