"""Linear harmonic response (no contact): amplitude-frequency curves, FEM and AM side by side.

A force ``F0 sin(2 pi f t)`` acts in y at the force-sensor position. With the shroud gap open the
blades are uncoupled, so each blade is driven on its own:

* the **active** blade carries the force sensor (mass m2) and is driven through it, as on the rig;
* the **passive** blade has no sensor; it is driven at the same position (the paper's "without
  force sensor" curves of its Figure 7).

Responses are the steady-state amplitudes at the shroud (tip) and at the excitation point, in
displacement (m) and acceleration (``w^2 |X|``, m/s^2).

FEM: modal superposition over *all* modes of the blade, which is exact for the modal-ratio and
Rayleigh damping of :class:`rigtools.sim.params.DampingParams` (both are diagonal in the modal basis):
``X_j = F0 sum_r phi_jr phi_kr / (w_r^2 - w^2 + 2 i zeta_r w_r w)``,
``zeta_r = zeta`` or ``alpha / (2 w_r) + beta w_r / 2``.
AM: the same formula on the assumed-modes model's own modes (:mod:`rigtools.sim.analytical`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rigtools.sim.analytical import assumed_modes_blade
from rigtools.sim.blade import BladeModel, build_blade
from rigtools.sim.modal import blade_modes
from rigtools.sim.params import LumpedMass, RigParams
from rigtools.sim.reduction import damping_ratios
from rigtools.sim.rig_model import RigModel, blade_masses

LOCATIONS = ("active_shroud", "active_force_point", "passive_shroud", "passive_force_point")
UY = 1


@dataclass
class HarmonicResponse:
    """Complex steady-state displacement amplitudes per location over a frequency grid.

    Attributes
    ----------
    model
        ``"fem"`` or ``"am"``.
    frequencies_hz
        (n,) excitation frequencies, Hz.
    force_amplitude
        F0, N.
    displacement
        Location -> (n,) complex displacement amplitude, m (phase relative to the force).
    """

    model: str
    frequencies_hz: np.ndarray
    force_amplitude: float
    displacement: dict[str, np.ndarray] = field(default_factory=dict)

    def displacement_amplitude(self, location: str) -> np.ndarray:
        """``|X|`` at a location, m."""
        return np.abs(self.displacement[location])

    def acceleration_amplitude(self, location: str) -> np.ndarray:
        """``w^2 |X|`` at a location, m/s^2."""
        w = 2.0 * np.pi * self.frequencies_hz
        return w**2 * np.abs(self.displacement[location])


def _superpose(omegas, zetas, out_shapes, in_shape, frequencies_hz, force) -> np.ndarray:
    """Displacement at outputs (rows of out_shapes, n_out x n_modes) for a unit-shape force."""
    w = 2.0 * np.pi * np.asarray(frequencies_hz)[:, None]
    denom = omegas[None, :] ** 2 - w**2 + 2j * zetas[None, :] * omegas[None, :] * w
    participation = in_shape[None, :] / denom  # (n_freq, n_modes)
    return force * participation @ out_shapes.T  # (n_freq, n_out)


def _add_blade(
    out: HarmonicResponse,
    name: str,
    omegas: np.ndarray,
    zetas: np.ndarray,
    tip: np.ndarray,
    drive: np.ndarray,
) -> None:
    """Blade ``name``'s shroud and force-point displacements into ``out``, by modal superposition
    of its modes (``tip``, ``drive``: the mode shapes there) for the force at the drive point."""
    x = _superpose(omegas, zetas, np.vstack([tip, drive]), drive, out.frequencies_hz, out.force_amplitude)
    out.displacement[f"{name}_shroud"] = x[:, 0]
    out.displacement[f"{name}_force_point"] = x[:, 1]


def _passive_fe_blade(rig: RigModel, position: float) -> BladeModel:
    """The passive blade, rebuilt with a node at the drive position if it has none there."""
    blade = rig.passive
    if np.min(np.abs(blade.node_x - position)) < 1e-9 * blade.params.length:
        return blade
    marker = LumpedMass(0.0, 0.0, position)
    return build_blade(
        "passive", blade.params, [*blade.masses, marker], blade.root, None, blade.rotary_inertia
    )


def fem_harmonic_response(
    rig: RigModel, frequencies_hz: np.ndarray, force_amplitude: float
) -> HarmonicResponse:
    """Linear harmonic response of the FE model (modal superposition over all modes).

    Parameters
    ----------
    rig
        The FE rig model.
    frequencies_hz
        Excitation frequencies, Hz.
    force_amplitude
        F0, N.

    Returns
    -------
    HarmonicResponse
        ``model = "fem"``, all four :data:`LOCATIONS`.
    """
    params = rig.params
    position = params.force_sensor.position
    out = HarmonicResponse("fem", np.asarray(frequencies_hz, dtype=float), float(force_amplitude))
    for name, blade in (("active", rig.active), ("passive", _passive_fe_blade(rig, position))):
        modes = blade_modes(blade)
        omegas = modes.omegas
        drive_dof = blade.sensor_dof(UY) if name == "active" else blade.dof(blade.node_at(position), UY)
        tip = modes.shapes[blade.dof(blade.tip_node, UY)]
        _add_blade(out, name, omegas, damping_ratios(omegas, params.damping), tip, modes.shapes[drive_dof])
    return out


def am_harmonic_response(
    params: RigParams, frequencies_hz: np.ndarray, force_amplitude: float, n_terms: int = 40
) -> HarmonicResponse:
    """Linear harmonic response of the analytical (assumed-modes) model.

    Parameters
    ----------
    params
        Rig parameters.
    frequencies_hz
        Excitation frequencies, Hz.
    force_amplitude
        F0, N.
    n_terms
        Assumed modes per blade.

    Returns
    -------
    HarmonicResponse
        ``model = "am"``, all four :data:`LOCATIONS`.
    """
    position = params.force_sensor.position
    out = HarmonicResponse("am", np.asarray(frequencies_hz, dtype=float), float(force_amplitude))
    for name, bp in (("active", params.active), ("passive", params.passive)):
        am = assumed_modes_blade(bp, blade_masses(params, name), params.root_of(name), n_terms)
        f, vec = am.modes()
        omegas = 2.0 * np.pi * f
        tip = am.shape(bp.length) @ vec
        _add_blade(out, name, omegas, damping_ratios(omegas, params.damping), tip, am.shape(position) @ vec)
    return out


def harmonic_curves(
    rig: RigModel, frequencies_hz: np.ndarray, force_amplitude: float, n_terms: int = 40
) -> tuple[HarmonicResponse, HarmonicResponse]:
    """FEM and AM amplitude-frequency curves on the same grid (the paper's Figure 7).

    Examples
    --------
    The active shroud's displacement per newton at 50 and 60 Hz, mm, from the finite elements and
    from the assumed modes:

    >>> import numpy as np
    >>> import rigtools
    >>> from rigtools.sim.harmonic import harmonic_curves
    >>> from rigtools.sim.rig_model import build_rig_model
    >>> rig = build_rig_model(rigtools.load_rig().to_params())
    >>> fem, am = harmonic_curves(rig, np.array([50.0, 60.0]), 1.0)
    >>> np.round(fem.displacement_amplitude("active_shroud") * 1e3, 4)
    array([0.1806, 0.0794])
    >>> np.round(am.displacement_amplitude("active_shroud") * 1e3, 4)
    array([0.1805, 0.0794])
    """
    return (
        fem_harmonic_response(rig, frequencies_hz, force_amplitude),
        am_harmonic_response(rig.params, frequencies_hz, force_amplitude, n_terms),
    )
