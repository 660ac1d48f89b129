"""The phase of a periodic orbit's response to its force, and the orbit of a branch at a set phase.

What a phase-locked-loop test measures on the rig, computed on the model: the phase of the active
shroud's displacement fundamental relative to the force fundamental (the force into the blade,
as the sensor measures it), ``angle(X1 / F1)`` in degrees, -90 at phase resonance. Along a
branch of :func:`rigtools.sim.continuation.continue_orbits` (force fundamental held, frequency
continued) the orbit at a set phase is found by a secant iteration on the frequency, each step a
Newton solve of the orbit at that frequency (:func:`rigtools.sim.continuation.orbit_at`) started
from the branch points that bracket the phase. The linear phase resonance of the modal model
(:func:`linear_phase_resonance`) is its closed form without contact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from rigtools.sim.continuation import Branch, BranchPoint, PeriodMap, ShakerDrive, orbit_at
from rigtools.sim.reduction import ReducedSystem
from rigtools.sim.vibro_impact import OUT_COLUMNS

_X = OUT_COLUMNS.index("active_tip_displacement")
_F = OUT_COLUMNS.index("excitation_force")


@dataclass(frozen=True)
class PhasePoint:
    """One orbit with its response phase (SI).

    Attributes
    ----------
    fe_hz, amplitude_m, force_fundamental_n, phase_deg
        Frequency; amplitude of the active shroud's displacement fundamental; force fundamental;
        phase of the displacement fundamental relative to the force's, degrees in (-360, 0].
    stable
        The orbit's Floquet multipliers are all inside the unit circle (at a fixed drive).
    max_multiplier
        Largest multiplier modulus.
    """

    fe_hz: float
    amplitude_m: float
    force_fundamental_n: float
    phase_deg: float
    stable: bool
    max_multiplier: float


def orbit_phase(pmap: PeriodMap, point: BranchPoint) -> PhasePoint:
    """The phase point of ``point`` (an orbit of ``pmap``'s branch): one integration of the orbit.

    Parameters
    ----------
    pmap
        The branch's period map (its steps per period, periods and shaker).
    point
        A converged orbit of that map.

    Returns
    -------
    PhasePoint
    """
    _, data = pmap.flow(point.state * pmap.scale, point.forcing)
    n = data.shape[0]
    k = pmap.periods  # the fundamental is bin `periods` of an orbit over `periods` periods
    x1 = np.fft.rfft(data[:, _X])[k] * 2.0 / n
    f1 = np.fft.rfft(data[:, _F])[k] * 2.0 / n
    phase = math.degrees(float(np.angle(x1 / f1)))
    if phase > 0:
        phase -= 360.0
    return PhasePoint(
        fe_hz=float(point.forcing.fe),
        amplitude_m=float(abs(x1)),
        force_fundamental_n=float(abs(f1)),
        phase_deg=phase,
        stable=bool(point.stable),
        max_multiplier=float(point.max_multiplier),
    )


def branch_phases(system: ReducedSystem, branch: Branch, shaker: ShakerDrive | None) -> list[PhasePoint]:
    """:func:`orbit_phase` of every point of a frequency branch (one integration per point)."""
    pmap = PeriodMap(system, branch.steps_per_period, branch.periods, shaker)
    return [orbit_phase(pmap, p) for p in branch.points]


def points_at_phase(
    system: ReducedSystem,
    branch: Branch,
    phase_deg: float,
    shaker: ShakerDrive | None,
    *,
    tolerance_deg: float = 1e-3,
    max_iterations: int = 12,
) -> list[PhasePoint]:
    """Every orbit of a frequency branch at the response phase ``phase_deg``.

    Each pair of consecutive branch points whose phases bracket ``phase_deg`` gives one orbit: a
    secant (regula falsi) iteration on the frequency between them, each step an orbit solved at
    that frequency from the bracketing points, until the phase is within ``tolerance_deg``.

    Parameters
    ----------
    system
        The model the branch was traced on (with ``shaker``).
    branch
        A branch of ``"fe"`` with the force fundamental held.
    phase_deg
        Phase of the displacement fundamental relative to the force's, degrees (e.g. -90).
    shaker
        The shaker drive of ``system``.
    tolerance_deg, max_iterations
        Stop when the phase is this close, or after this many solves.

    Returns
    -------
    list of PhasePoint
        In branch order (a branch whose phase is not monotonic holds several).
    """
    if branch.param != "fe":
        raise ValueError(f"a frequency branch is needed, got param {branch.param!r}")
    pmap = PeriodMap(system, branch.steps_per_period, branch.periods, shaker)
    phases = [orbit_phase(pmap, p) for p in branch.points]
    out: list[PhasePoint] = []
    for i in range(len(phases) - 1):
        a, b = phases[i], phases[i + 1]
        if (a.phase_deg - phase_deg) * (b.phase_deg - phase_deg) > 0 or a.fe_hz == b.fe_hz:
            continue
        pair = [branch.points[i], branch.points[i + 1]]
        sub = Branch("fe", branch.periods, points=pair, steps_per_period=branch.steps_per_period)
        lo, hi = a, b
        best = min((a, b), key=lambda p: abs(p.phase_deg - phase_deg))
        for _ in range(max_iterations):
            w = (phase_deg - lo.phase_deg) / (hi.phase_deg - lo.phase_deg)
            fe = lo.fe_hz + w * (hi.fe_hz - lo.fe_hz)
            solved = orbit_at(system, sub, fe, shaker=shaker)
            if not solved:
                break
            p = orbit_phase(pmap, solved[0])
            best = p if abs(p.phase_deg - phase_deg) < abs(best.phase_deg - phase_deg) else best
            if abs(p.phase_deg - phase_deg) <= tolerance_deg:
                break
            if (p.phase_deg - phase_deg) * (lo.phase_deg - phase_deg) > 0:
                lo = p
            else:
                hi = p
        out.append(best)
    return out


def linear_phase_resonance(
    system: ReducedSystem, phase_deg: float = -90.0, band: tuple[float, float] | None = None
) -> float:
    """The frequency (Hz) where the modal model without contact puts the active shroud's
    displacement at ``phase_deg`` from the force at the force point: the root of
    ``angle(H(f)) = phase`` with ``H = sum_j phi_tip,j phi_F,j / (w_j^2 - w^2 + 2 i zeta_j w_j w)``
    (the blade's own receptance; the force is the sensor's, between shaker and blade).

    Parameters
    ----------
    system
        The reduced system (its first mode sets the default band, 0.8 to 1.05 times its frequency).
    phase_deg
        The phase, degrees in (-180, 0).
    band
        Search interval, Hz.
    """
    shapes = np.asarray(system.shapes)
    omega, zeta = np.asarray(system.omega), np.asarray(system.zeta)
    f1 = float(np.min(omega)) / (2 * math.pi)
    lo, hi = band if band is not None else (0.8 * f1, 1.05 * f1)

    def phase(f: float) -> float:
        w = 2 * math.pi * f
        h = np.sum(shapes[0] * shapes[2] / (omega**2 - w**2 + 2j * zeta * omega * w))
        return float(np.angle(h)) - math.radians(phase_deg)

    return float(brentq(phase, lo, hi, xtol=1e-9))
