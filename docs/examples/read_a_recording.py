"""Read a recording: its points, parameters and settled record window
=====================================================================

Opens a recording (by default it first makes a short dwell on the simulated rig), lists its
points with their parameters, and reads the settled record window of the first point as arrays
and as a pandas table. Any HDF5 tool reads the same file (``docs/recording-format.md``).
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import rigtools

path = Path(tempfile.mkdtemp()) / "dwell.h5"  # or the path of your own recording (then skip the next line)
rigtools.dwell("60 Hz", "15 N", path, gap="0.5 mm", record_periods=20, seed=1, backend="sim")

with rigtools.open_recording(path) as rec:
    print(f"{path.name}: {rec.status}, backend {rec.backend}, {len(rec.points)} point(s)")
    for point in rec.points:
        fe, f1 = point.params.get("fe"), point.params.get("force_amplitude_measured")
        print(f"  point {point.index}: fe {fe} Hz, F1 {f1} N, channels {', '.join(point.channels)}")
    point = rec.points[0]
    start, samples = point.record_window
    force = point.settled("force")  # N, only the settled record window
    print(f"settled window: samples {start}..{start + samples} at {point.sample_rate:g} Hz")
    print(f"force: {force.size} samples, peak {abs(force).max():.2f} N")
    table = point.to_dataframe()  # every sample of the point, index time (s)
    print(table.iloc[start : start + 3])

# %%
# The last five periods of the settled window: the force is nearly a sine, the shroud
# accelerations carry the spikes of the impacts.
with rigtools.open_recording(path) as rec:
    point = rec.points[0]
    fe = float(point.params["fe"])
    channels = {
        name: point.settled(name) for name in ("force", "active_shroud_accel", "passive_shroud_accel")
    }
    rate = point.sample_rate
n = round(5 * rate / fe)
t = np.arange(n) / rate * 1e3  # ms
fig, axes = plt.subplots(3, 1, sharex=True, figsize=(7, 6))
for ax, (name, values) in zip(axes, channels.items(), strict=True):
    ax.plot(t, values[-n:], lw=0.8)
    ax.set_ylabel(f"{name.replace('_', ' ')}\n({'N' if name == 'force' else 'm/s²'})")
axes[-1].set_xlabel("time in the last five periods (ms)")
fig.suptitle("settled record window of a dwell at 60 Hz, gap 0.5 mm")
