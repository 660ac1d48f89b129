"""The batched finite-difference Jacobian of the shooting map (all state columns in one compiled
call, :meth:`rigtools.sim.orbit_map.PeriodMap.flows`) equals the reference, one
:meth:`~rigtools.sim.orbit_map.PeriodMap.flow` per column, bit for bit (exact equality, no
tolerance: the same compiled kernel runs the same arithmetic per column; the continuation's
bifurcation locations are pinned to many digits downstream). Its speed is in
benchmarks/bench_continuation_speed.py.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigtools.sim.orbit_map import Forcing, PeriodMap, map_for_range
from rigtools.sim.vibro_impact import SimulationDivergedError, SimulationInputError


@pytest.fixture(scope="module")
def maps(fem_model):
    """``{name: (map, forcing)}``: the FEM blades alone, through the shaker under force control
    (the ``rig continuation`` model) and at a fixed drive (V)."""
    from rigtools.branches import simulated_rig_model

    system = fem_model[2]
    _, rig_system, drive = simulated_rig_model(None)
    fixed = type(drive)(drive.coupling, drive.amplifier_gain, force_control=False)
    out = {}
    for name, sys_, shaker, force in (
        ("blades", system, None, 15.0),
        ("force control", rig_system, drive, 15.0),
        ("fixed drive", rig_system, fixed, 2.0),
    ):
        out[name] = map_for_range(sys_, "fe", 60.0, 61.0, 60.0, force, 0.7e-3, 1, shaker, None)
    return out


def _state(pmap: PeriodMap, p: Forcing, scale: float) -> np.ndarray:
    """The orbit without contact, ``scale`` times (beyond the gap: impacts in the flow)."""
    y = pmap.linear_orbit(p) * scale
    if pmap.force_control:
        y[-1] /= scale  # the drive amplitude as it is
    return y


@pytest.mark.parametrize("name", ["blades", "force control", "fixed drive"])
@pytest.mark.parametrize("param", [None, "fe", "force", "gap"])
def test_batched_jacobian_equals_the_per_column_one(maps, name, param):
    pmap, p = maps[name]
    for scale in (1.0, 3.0):
        y = _state(pmap, p, scale)
        ref = pmap.jacobian(y, p, param, batched=False)
        fast = pmap.jacobian(y, p, param, batched=True)
        for a, b in zip(ref, fast, strict=True):
            if a is None:
                assert b is None
            else:
                assert np.array_equal(a, b)
    _, data = pmap.flow(y, p)
    assert np.count_nonzero(data[:, 9]) > 0, "the states must impact"


def test_flows_raise_as_the_first_failing_flow(maps):
    """A diverging row and a non-finite row: the error of the first in order, as per flow."""
    pmap, p = maps["force control"]
    y = _state(pmap, p, 1.0)
    ys = np.repeat(y[None, :], 3, axis=0)
    ys[1, :] *= 1e12  # diverges (a tip beyond a kilometre)
    ys[2, -1] = np.inf  # a non-finite drive
    with pytest.raises(SimulationDivergedError) as ref:
        [pmap.flow(row, p) for row in ys]
    with pytest.raises(SimulationDivergedError) as fast:
        pmap.flows(ys, p)
    assert str(fast.value) == str(ref.value)
    with pytest.raises(SimulationInputError, match="non-finite") as fast_input:
        pmap.flows(ys[[0, 2]], p)
    assert not isinstance(fast_input.value, SimulationDivergedError)
