"""Harmonics of a dwell and the impacts behind them
==================================================

:func:`rigtools.analyze_recording` fits the harmonics k * fe of every channel over each point's
settled window (peak amplitudes, phases to the force) and detects the shroud impacts.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import rigtools

path = Path(tempfile.mkdtemp()) / "dwell.h5"  # or the path of your own recording (then skip the next line)
rigtools.dwell("60 Hz", "15 N", path, gap="0.5 mm", record_periods=20, seed=1, backend="sim")

analysis = rigtools.analyze_recording(path)
for point in analysis.points:
    if point.dwell is None:
        continue
    print(f"point {point.index}: fe {point.fe:g} Hz, force fundamental {point.dwell.force_amplitude:.2f} N")
    for channel in ("force", "active_shroud_accel", "passive_shroud_accel"):
        amplitudes = [point.harmonic(channel, k) for k in range(1, 6)]
        print(f"  {channel:22s} k=1..5:", " ".join(f"{a:9.3g}" for a in amplitudes if a is not None))
    impacts = point.dwell.impacts
    if impacts is not None:
        print(f"  impacts per period: {impacts.impacts_per_period:.2f}, periodic: {impacts.periodic}")

# %%
# The harmonics k * fe of the two shroud accelerations (peak, log scale): the impacts put a
# large part of the response into the higher harmonics.
point = next(p for p in analysis.points if p.dwell is not None)
k = np.arange(1, 11)
fig, ax = plt.subplots(figsize=(7, 4))
for offset, channel in ((-0.2, "active_shroud_accel"), (0.2, "passive_shroud_accel")):
    amplitudes = [point.harmonic(channel, int(i)) or np.nan for i in k]
    ax.bar(k + offset, amplitudes, width=0.4, label=channel.replace("_", " "))
ax.set_yscale("log")
ax.set_xticks(k)
ax.set_xlabel("harmonic k (frequency k·fe)")
ax.set_ylabel("acceleration amplitude, peak (m/s²)")
ax.set_title(f"harmonics of a dwell at {point.fe:g} Hz, gap 0.5 mm")
ax.legend()
