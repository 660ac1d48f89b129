"""Harmonics of a dwell and the impacts behind them
==================================================

    python docs/examples/harmonics_of_a_dwell.py [RECORDING.h5]

:func:`rigtools.analyze_recording` fits the harmonics k * fe of every channel over each point's
settled window (peak amplitudes, phases to the force) and detects the shroud impacts.
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
