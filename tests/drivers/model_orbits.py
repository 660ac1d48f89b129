"""Periodic orbits of the simulated rig's model at gap 0.5 mm, fe = 64 Hz, for the tests of the
real-time loop and of measured multipliers.

The orbits are computed here by the toolkit's own shooting (:func:`rigtools.sim.continuation.solve_orbit`,
the simulated rig's reduced model with its shaker at a fixed drive amplitude, 800 steps per
period: the step of the simulated rig at 51.2 kS/s) from the stored guesses below; the guesses
come from the continuation in fe at a held force fundamental of 5 N (``continue_orbits(system,
"fe", 56.0, 66.0, force=5.0, gap=5e-4, shaker=drive)`` then ``orbit_at(..., 64.0)``, 44 s), which
finds three orbits at 64 Hz: a stable impacting one (A 0.310 mm, |mu| 0.80), an unstable one on
the sheet between the folds (A 0.3534 mm, |mu| 1.098) and the stable one without impacts
(A 0.222 mm). Newton converges from the guesses in 4-5 iterations (0.1-1.5 s).
"""

from __future__ import annotations

import functools

import numpy as np

from rigtools.branches import simulated_rig_model
from rigtools.sim.continuation import BranchPoint, Forcing, PeriodMap, solve_orbit
from rigtools.sim.delayed_feedback import HarmonicTarget
from rigtools.sim.vibro_impact import OUT_COLUMNS

FE = 64.0
GAP = 5e-4
STEPS = 800  # per period: 51.2 kS/s
FS = FE * STEPS

# drive amplitude (V) and a guess of the modal state at drive phase zero (q, v, coil current)
_GUESS = {
    "stable": (
        0.4188707858076259,
        [-0.000135404, -2.33394e-06, 7.31132e-09, -1.19609e-09, 5.27215e-09, -7.77077e-10, -1.45429e-10,
         -3.81372e-11, 0.000127896, -3.36369e-07, -4.87724e-09, -9.77489e-10, 2.2812e-09, -5.6278e-11,
         -0.0259159, 0.00617871, 0.000866399, -0.000191053, -2.58581e-05, 3.24266e-06, 1.12084e-06,
         -1.08859e-07, -0.0122521, -0.00700785, 0.000696188, 0.000198917, 1.37278e-05, -5.50904e-06,
         0.0833395],
    ),
    "unstable": (
        0.3748711908436835,
        [-0.000115022, -7.67896e-07, 9.22048e-08, -6.46121e-09, 5.66403e-09, -2.61148e-10, -8.97921e-11,
         -2.52887e-11, 9.10331e-05, -1.51561e-06, 4.50746e-08, -4.71215e-09, 6.07764e-10, 1.2524e-10,
         -0.040057, -0.00756787, 0.000241659, -0.000175983, 3.25382e-05, 1.74901e-05, 2.40479e-06,
         -8.92975e-08, 0.00663298, 0.00282599, 0.000478601, -0.000164852, -6.07956e-05, 7.2052e-06,
         0.0554621],
    ),
}  # fmt: skip


@functools.cache
def model() -> tuple:
    """``(rig config, reduced system, shaker drive at a fixed amplitude, period map)``."""
    cfg, system, drive = simulated_rig_model(None, force_control=False)
    return cfg, system, drive, PeriodMap(system, STEPS, 1, drive)


@functools.cache
def orbit(kind: str) -> BranchPoint:
    """The model's orbit ``"stable"`` or ``"unstable"`` (its multipliers, measures, state)."""
    _, _, _, pmap = model()
    amplitude, guess = _GUESS[kind]
    return solve_orbit(pmap, Forcing(FE, amplitude, GAP), y0=np.array(guess) * pmap.scale)


def orbit_displacement(kind: str) -> np.ndarray:
    """The active shroud's displacement over one period of the orbit, at the step ends
    ``t = (i + 1) / FS`` after drive phase zero, m."""
    _, _, _, pmap = model()
    point = orbit(kind)
    data = pmap.flow(point.state * pmap.scale, point.forcing)[1]
    return data[:, OUT_COLUMNS.index("active_tip_displacement")].copy()


def orbit_target(kind: str, harmonics: int = 40) -> HarmonicTarget:
    """The orbit's displacement as a loop target (least squares over one period)."""
    x = orbit_displacement(kind)
    t = np.arange(1, x.size + 1) / FS
    return HarmonicTarget.fit(t, x, FE, harmonics)
