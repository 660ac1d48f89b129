"""Spectrum of a recorded point
==============================

The amplitude spectrum (flat-top window, peak amplitudes in SI units) of the force and the
active shroud acceleration over the settled window of the first point; with impacts the
acceleration shows harmonics k * fe far above the fundamental.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import rigtools

path = Path(tempfile.mkdtemp()) / "dwell.h5"  # or the path of your own recording (then skip the next line)
rigtools.dwell("60 Hz", "15 N", path, gap="0.5 mm", record_periods=20, seed=1, backend="sim")

with rigtools.open_recording(path) as rec:
    point = rec.points[0]
    fe = float(point.params["fe"])
    spectra = [rigtools.spectrum(point, name) for name in ("force", "active_shroud_accel")]

fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
for ax, s in zip(axes, spectra, strict=True):
    ax.semilogy(s.frequency_hz, s.amplitude)
    ax.set_ylabel(f"{s.channel}, peak ({s.units})")
    print(s.channel, " ".join(f"k={k}: {s.at(k * fe):.3g}" for k in (1, 2, 3, 5)), s.units)
axes[-1].set_xlim(0, 20 * fe)
axes[-1].set_xlabel("frequency (Hz)")
