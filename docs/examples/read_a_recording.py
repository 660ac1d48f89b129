"""Read a recording: its points, parameters and settled record window
=====================================================================

    python docs/examples/read_a_recording.py [RECORDING.h5]

Opens a recording (by default it first makes a short dwell on the simulated rig), lists its
points with their parameters, and reads the settled record window of the first point as arrays
and as a pandas table. Any HDF5 tool reads the same file (``docs/recording-format.md``).
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
