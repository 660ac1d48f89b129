"""Natural frequencies of the rig's two blades, the one place they are computed.

* :func:`reduced_natural_frequencies`: the kept flexural modes of a reduced system (what the
  vibro-impact runs, the comparison and the report use);
* :func:`analytical_natural_frequencies`: the exact Euler-Bernoulli solution of each blade with its
  lumped masses (the analytical model, AM);
* :func:`blade_mode_table`: the lowest FE modes of each blade with their kind beside the AM's
  flexural modes (``rig modal``, the demo).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rigtools.sim.analytical import exact_flexural_frequencies
from rigtools.sim.modal import blade_modes
from rigtools.sim.params import RigParams
from rigtools.sim.reduction import ACTIVE, PASSIVE
from rigtools.sim.rig_model import blade_masses, build_rig_model

BLADES = ("active", "passive")


def reduced_natural_frequencies(system: Any) -> dict[str, np.ndarray]:
    """The kept (not static-correction) mode frequencies of each blade of a reduced system, Hz:
    its flexural natural frequencies, ``{"active": ..., "passive": ...}`` ascending."""
    real = np.ones(system.n_modes, bool) if system.pseudo is None else ~np.asarray(system.pseudo, bool)
    f = system.frequencies_hz
    return {
        "active": np.sort(f[real & (system.blade == ACTIVE)]),
        "passive": np.sort(f[real & (system.blade == PASSIVE)]),
    }


def analytical_natural_frequencies(params: RigParams, n_modes: int) -> dict[str, np.ndarray]:
    """The ``n_modes`` lowest flexural natural frequencies (Hz) of each blade by the exact
    Euler-Bernoulli solution with its shroud (and, on the active blade, the force sensor)."""
    return {
        b: np.asarray(
            exact_flexural_frequencies(params.blade(b), blade_masses(params, b), n_modes, params.root_of(b))
        )
        for b in BLADES
    }


def blade_mode_table(params: RigParams, n_modes: int) -> dict[str, dict[str, list[dict]]]:
    """FEM and AM modes of both blades: ``{"fem": {blade: [{"mode", "frequency_hz", "kind"}]},
    "am": {blade: [...]}}``. FEM: the ``n_modes`` lowest modes of each blade's full FE model with
    their kind (flexural, edgewise, torsional, axial); AM: its ``n_modes`` lowest flexural modes."""
    rig = build_rig_model(params)
    am = analytical_natural_frequencies(params, n_modes)
    out: dict[str, dict[str, list[dict]]] = {"fem": {}, "am": {}}
    for name in BLADES:
        modes = blade_modes(rig.blade(name), n_modes)
        out["fem"][name] = [
            {"mode": i + 1, "frequency_hz": float(f), "kind": k}
            for i, (f, k) in enumerate(zip(modes.frequencies_hz, modes.kinds, strict=True))
        ]
        out["am"][name] = [
            {"mode": i + 1, "frequency_hz": float(f), "kind": "flexural"} for i, f in enumerate(am[name])
        ]
    return out
