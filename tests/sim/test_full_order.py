"""Full-order HHT-alpha reference: its two solvers agree, and it matches the closed-form linear
steady state (frequency-domain modal superposition of the same FE model)."""

from dataclasses import replace

import numpy as np
import pytest

from rigtools.config import load_rig
from rigtools.sim.full_order import FullOrderIntegrator, full_modal_system, run_full_order
from rigtools.sim.rig_model import build_rig_model
from rigtools.sim.vibro_impact import OUT_COLUMNS, SimulationInputError


@pytest.fixture(scope="module")
def model():
    return build_rig_model(load_rig().to_params())


@pytest.mark.parametrize("alpha", [0.0, 0.1])
def test_physical_and_modal_solvers_agree(model, alpha):
    """Dense Cholesky on the full M, C, K versus the decoupled modal form, through impacts.
    Agreement 1e-4 relative: the low modes of the dense eigensolution carry ~1e-7 relative
    error (stiffness range of the full model) which the impacts then amplify."""
    params = replace(model.params, contact=replace(model.params.contact, gap=2e-4))
    m = replace(model, params=params)
    dt = 1 / (60 * 600)
    t = dt * np.arange(1, 701)
    force = 40 * np.sin(2 * np.pi * 60 * t)
    a = FullOrderIntegrator(m, dt, alpha, solver="modal").step(force)
    b = FullOrderIntegrator(m, dt, alpha, solver="physical").step(force)
    assert b[:, OUT_COLUMNS.index("contact_force")].max() > 1.0  # impacts happened
    for name in (
        "active_tip_displacement",
        "passive_tip_acceleration",
        "force_point_velocity",
        "contact_force",
    ):
        i = OUT_COLUMNS.index(name)
        assert np.max(np.abs(a[:, i] - b[:, i])) <= 1e-4 * np.max(np.abs(b[:, i]))


def test_modal_form_drops_only_unexcited_modes(model):
    fs = full_modal_system(model)
    # y-bending modes only: (uy, rz) per free node, both blades
    assert fs.omega.size == 2 * 2 * model.params.active.elements
    assert fs.damping_offdiag < 1e-10


def test_linear_steady_state_matches_frequency_domain(model):
    """Gap never closed: steady amplitude at the active shroud equals |H(w)| F0 from all-mode
    superposition (0.1 %: Newmark period error (w dt)^2/12 ~ 1e-4 at 400 steps per period)."""
    from rigtools.sim.harmonic import fem_harmonic_response

    params = replace(model.params, contact=replace(model.params.contact, gap=1.0))
    fe = 90.0
    out = run_full_order(model, fe, 10.0, 3.0, 1 / (fe * 400), record_periods=2, contact=params.contact)
    amp = np.ptp(out["active_tip_displacement"]) / 2
    ref = fem_harmonic_response(model, np.array([fe]), 10.0).displacement_amplitude("active_shroud")[0]
    assert amp == pytest.approx(ref, rel=1e-3)


def test_bad_alpha_and_coarse_step_are_refused(model):
    with pytest.raises(SimulationInputError, match="alpha"):
        FullOrderIntegrator(model, 1e-5, alpha=0.5)
    with pytest.raises(SimulationInputError, match="too coarse"):
        FullOrderIntegrator(model, 1e-3)
    # 3 periods cannot hold a record of 5 that starts at the end of a whole period
    with pytest.raises(SimulationInputError, match="needs at least 6"):
        run_full_order(model, 60.0, 1.0, 3 / 60.0, 1 / (60.0 * 600), record_periods=5)
