"""FRF and modes of an FRF test
==============================

H1 accelerance (response / force) over the averaged frames of an FRF test, its coherence, and
the modes identified (LSCF) with their stabilisation chart. The test is a short periodic chirp on
the simulated rig with the gap opened to 5 mm (no impacts); give your own recording's path instead.
"""

import tempfile
from pathlib import Path

import numpy as np

import rigtools
from rigtools.analysis.plots import frf_figure, stabilisation_figure

path = Path(tempfile.mkdtemp()) / "frf.h5"  # or the path of your own recording (then skip the next line)
rigtools.frf_test(("20 Hz", "500 Hz"), "1 V", path, averages=4, gap="5 mm", seed=1, backend="sim")

point = rigtools.analyze_recording(path).broadband[0]
est = point.frf.estimate
for response in point.frf.responses:
    for mode in point.frf.modes[response].modes:
        print(f"{response}: {mode.frequency_hz:7.1f} Hz, damping {mode.damping_ratio * 100:.2f} %")
band = (est.frequency_hz >= 20.0) & (est.frequency_hz <= 500.0)

# %%
# The H1 accelerance of both shrouds, magnitude and phase, with the coherence below (close to 1
# where the response is the force's; it drops at the anti-resonances, where little response is
# left above the noise).
frf = frf_figure(
    est.frequency_hz[band],
    {r: est.h1[i][band] for i, r in enumerate(point.frf.responses)},
    coherence={r: est.coherence[i][band] for i, r in enumerate(point.frf.responses)},
    kind=point.frf.kind,
    title="FRF test, gap 5 mm: H1 and coherence",
)

# %%
# The stabilisation chart of the active shroud: the LSCF poles at each model order over ``|H1|``,
# the stable ones filled, those that make the reported modes marked.
response = "active_shroud_accel"
identification = point.frf.modes[response]
chart_band = (est.frequency_hz >= identification.band[0]) & (est.frequency_hz <= identification.band[1])
row = point.frf.responses.index(response)
chart = stabilisation_figure(
    identification.chart,
    est.frequency_hz[chart_band],
    np.abs(est.h1[row][chart_band]),
    title="stabilisation chart of the active shroud",
)
