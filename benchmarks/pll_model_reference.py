"""The model's reference points for the PLL tests (issue 33), from the toolkit's own continuation.

The simulated rig's model (test article plus shaker, force fundamental held,
:func:`rigtools.branches.simulated_rig_model`), gap 0.5 mm: the linear phase resonance (closed
form of the modal model and the continued 0.2 N branch), the 5 N branch's orbits at -152, -156 and
-165 deg, its fold, and the -90 deg (backbone) orbits at F1 = 1, 2, 5 and 10 N. Prints the table
tests/rigtools/test_pll_model.py holds (``REFERENCE``); about two minutes of CPU.

    PYTHONPATH=. python benchmarks/pll_model_reference.py
"""

from __future__ import annotations

import json
import time

from rigtools.branches import simulated_rig_model
from rigtools.sim.continuation import ContinuationSettings, continue_orbits
from rigtools.sim.phase_points import branch_phases, linear_phase_resonance, points_at_phase

GAP = 0.5e-3
SETTINGS = ContinuationSettings(refine=False)


def main() -> None:
    t0 = time.process_time()
    _, system, shaker = simulated_rig_model(None)
    ref: dict = {"gap_m": GAP, "linear_phase_resonance_hz": linear_phase_resonance(system)}
    low = continue_orbits(system, "fe", 51.5, 52.5, force=0.2, gap=GAP, shaker=shaker, settings=SETTINGS)
    p = points_at_phase(system, low, -90.0, shaker)[0]
    ref["linear_0.2N"] = {"fe_hz": p.fe_hz, "amplitude_m": p.amplitude_m}
    b5 = continue_orbits(system, "fe", 55.0, 67.0, force=5.0, gap=GAP, shaker=shaker, settings=SETTINGS)
    phases = branch_phases(system, b5, shaker)
    fold = max((q for q in phases if q.amplitude_m > 0.3e-3), key=lambda q: q.fe_hz)
    ref["fold_5N"] = {"fe_hz": fold.fe_hz, "amplitude_m": fold.amplitude_m, "phase_deg": fold.phase_deg}
    ref["stepped_5N"] = {}
    for target in (-150.0, -152.0, -156.0, -160.0, -165.0, -170.0):
        # the impacting sheet past the fold: the last crossing before grazing
        pts = [q for q in points_at_phase(system, b5, target, shaker) if q.amplitude_m > 0.33e-3]
        q = pts[-1]
        ref["stepped_5N"][f"{target:g}"] = {
            "fe_hz": q.fe_hz,
            "amplitude_m": q.amplitude_m,
            "stable": q.stable,
            "max_multiplier": q.max_multiplier,
        }
    ref["backbone"] = {}
    for force in (1.0, 2.0, 5.0, 10.0):
        b = continue_orbits(system, "fe", 48.0, 56.0, force=force, gap=GAP, shaker=shaker, settings=SETTINGS)
        q = points_at_phase(system, b, -90.0, shaker)[0]
        ref["backbone"][f"{force:g}"] = {"fe_hz": q.fe_hz, "amplitude_m": q.amplitude_m, "stable": q.stable}
    print(json.dumps(ref, indent=1))
    print(f"CPU {time.process_time() - t0:.0f} s")


if __name__ == "__main__":
    main()
