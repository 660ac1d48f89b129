"""Stepped sine up and down across the impact range, with its jumps
===================================================================

15 N held at every step from 62 Hz to 72 Hz and back, gap 0.7 mm, on the simulated rig. Where
the shrouds start or stop impacting the response jumps, at a higher frequency going up than
coming down: the figure is the response amplitude (first harmonic of the active shroud
acceleration) against the excitation frequency, one curve per direction, the jumps shaded.
"""

import tempfile
from pathlib import Path

import numpy as np

import rigtools
from rigtools.analysis.branches import MeasuredSweep, branch_figure
from rigtools.analysis.jumps import find_jumps

frequencies = list(np.arange(62.0, 72.5, 1.0))  # Hz
sweep = rigtools.stepped_sine(
    frequencies,
    "15 N",
    Path(tempfile.mkdtemp()) / "sweep.h5",
    gap="0.7 mm",
    direction="both",
    seed=1,
    backend="sim",
)
print(f"{sweep.status}: {len(sweep.points)} points")

runs = {}
for direction in ("up", "down"):
    points = [p for p in sweep.points if p.extra.get("direction") == direction]
    runs[direction] = (
        np.array([p.fe for p in points]),
        np.array([p.harmonics["active_shroud_accel"][0] for p in points]),
    )
measured = []
for direction, (fe, response) in runs.items():
    other = runs["down" if direction == "up" else "up"]
    jumps = find_jumps(fe, response, 0.3, other=other)  # a step changing the response by 30 % or more
    for jump in jumps:
        print(f"{direction}: jump between {jump.start:g} Hz and {jump.stop:g} Hz ({jump.evidence})")
    spans = [(j.start, j.stop) for j in jumps]
    measured.append(MeasuredSweep(fe, response, direction, f"stepped sine ({direction})", spans))

figure = branch_figure(
    [],
    "excitation frequency (Hz)",
    "active shroud acceleration, k = 1 (m/s²)",
    measured=measured,
    title="stepped sine at 15 N, gap 0.7 mm",
)
