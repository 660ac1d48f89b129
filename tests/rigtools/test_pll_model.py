"""The model's orbit at a set phase (rigtools.sim.phase_points) against the closed form: on the
simulated rig's model at 0.2 N (no contact, gap 0.5 mm) the continued branch's -90 deg orbit is the
modal model's linear phase resonance, and its amplitude the receptance's."""

from __future__ import annotations

import math

import numpy as np

from rigtools.branches import simulated_rig_model
from rigtools.sim.continuation import ContinuationSettings, continue_orbits
from rigtools.sim.phase_points import linear_phase_resonance, points_at_phase


def test_phase_point_on_the_linear_branch_is_the_closed_form():
    """The shooting orbit at -90 deg within 1e-5 of the closed-form frequency (the shooting's time
    step, 1/(fe steps) per period, moves it by ~3e-6) and 5e-3 in amplitude (measured 2e-3: at a
    resonance peak the amplitude is 1/damping, and the discrete integrator's effective damping
    differs from the modal one by that much at this step); the closed form's
    phase there is -90 deg (brentq to 1e-9 Hz) and its amplitude |H| F."""
    _, system, shaker = simulated_rig_model(None)
    f_closed = linear_phase_resonance(system)
    w = 2 * math.pi * f_closed
    h = np.sum(
        system.shapes[0] * system.shapes[2] / (system.omega**2 - w**2 + 2j * system.zeta * system.omega * w)
    )
    assert abs(math.degrees(np.angle(h)) + 90.0) < 1e-6
    branch = continue_orbits(
        system,
        "fe",
        51.5,
        52.5,
        force=0.2,
        gap=0.5e-3,
        shaker=shaker,
        settings=ContinuationSettings(refine=False),
    )
    (p,) = points_at_phase(system, branch, -90.0, shaker)
    assert abs(p.phase_deg + 90.0) < 1e-3
    assert abs(p.fe_hz / f_closed - 1) < 1e-5
    assert abs(p.amplitude_m / (abs(h) * 0.2) - 1) < 5e-3
    assert abs(p.force_fundamental_n / 0.2 - 1) < 1e-6 and p.stable
