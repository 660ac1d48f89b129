"""Impact-hammer (tap) test of the passive blade
===============================================

The passive blade has no shaker: it is hit at 85 mm from the root, where its first three
flexural modes all move, five times (one recorded point per hit). The modes come from H1 (shroud
acceleration over hammer force) over the accepted hits; the figure is that FRF with its coherence.

On the NI rig (``backend="nidaq"``, ``rig="lab.toml"``) the rig file needs the hammer's force
channel, e.g. ::

    [daq.channels.hammer]
    physical_channel = "Dev1/ai3"
    kind = "force"
    sensitivity = "2.25 mV/N"      # IEPE modal hammer (calibration sheet)
    excitation_current = "4 mA"
    range = "2200 N"
    location = "impact hammer"

and the operator taps when the script says so (the gap opened by hand first).
"""

import tempfile
from pathlib import Path

import rigtools
from rigtools.analysis.plots import frf_figure

run = rigtools.tap_test(
    "85 mm", Path(tempfile.mkdtemp()) / "tap.h5", blade="passive", hits=5, gap="5 mm", seed=1, backend="sim"
)
print(f"{run.status}: {len(run.points)} hits recorded")

analysis = rigtools.analyze_recording(run.file)
point = analysis.broadband[0]
estimate = point.frf.estimate
for response in point.frf.responses:
    for mode in point.frf.modes[response].modes:
        print(f"{response}: mode {mode.frequency_hz:8.2f} Hz, damping {mode.damping_ratio * 100:.2f} %")
band = (estimate.frequency_hz >= 20.0) & (estimate.frequency_hz <= 1600.0)
figure = frf_figure(
    estimate.frequency_hz[band],
    {r: estimate.h1[i][band] for i, r in enumerate(point.frf.responses)},
    coherence={r: estimate.coherence[i][band] for i, r in enumerate(point.frf.responses)},
    kind=point.frf.kind,
    title="tap test of the passive blade at 85 mm: H1 and coherence",
)
