"""
Linear response of both blades, FEM against AM
==============================================

The paper's Figure 7 on the calibrated default rig: a force F0 = 15 N at the force-sensor
position, the gap open (no contact), peak displacement and acceleration at each shroud and each
excitation point over 10 Hz to 1.5 kHz, from the finite-element model (all-mode superposition)
and from the analytical assumed-modes model, with the rig's damping. The two are separate
implementations; where their curves meet, each checks the other. ``rig harmonic`` writes the same
curves as CSV or JSON.
"""

import numpy as np

from rigtools.analysis.plots import amplitude_frequency_figure
from rigtools.config import load_rig
from rigtools.sim.harmonic import LOCATIONS, harmonic_curves
from rigtools.sim.modal import flexural_frequencies
from rigtools.sim.rig_model import build_rig_model

rig_config = load_rig()  # the calibrated default rig (rigtools/data/default_rig.toml)
rig = build_rig_model(rig_config.to_params())
for blade in ("active", "passive"):
    f = flexural_frequencies(getattr(rig, blade), 3)
    print(f"{blade:7s} blade, first flexural natural frequencies (FEM): {np.round(f, 1)} Hz")

# %%
# The curves: FEM solid, AM dashed with open markers; the resonance peaks sit at the flexural
# frequencies printed above.

frequencies = np.linspace(10.0, 1500.0, 1500)
fem, am = harmonic_curves(rig, frequencies, force_amplitude=15.0)
curves = {
    label: {
        "displacement": {loc: res.displacement_amplitude(loc) for loc in LOCATIONS},
        "acceleration": {loc: res.acceleration_amplitude(loc) for loc in LOCATIONS},
    }
    for label, res in (("FEM", fem), ("AM", am))
}
fig = amplitude_frequency_figure(frequencies, curves, force_amplitude=15.0, title=rig_config.name)
peak = frequencies[np.argmax(fem.displacement_amplitude("passive_shroud"))]
print(f"passive shroud: largest FEM displacement at {peak:.1f} Hz")
