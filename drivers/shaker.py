"""The power amplifier and electrodynamic shaker of the simulated rig.

A voltage amplifier of gain ``G`` puts ``e = G * drive`` across the shaker coil; the armature
(mass ``m_a`` on a suspension ``k_s``, ``c_s``) is rigidly attached to the active blade through
the force sensor, so it moves with the blade's force point (displacement ``x``)::

    L di/dt + R i + Bl dx/dt = G * drive          (coil, with back-EMF)
    F_sensor = Bl i - m_a x'' - k_s x - c_s x'     (force passed through the sensor into the blade)

Near a resonance of the blade the force point moves a lot, the back-EMF and the armature's own
dynamics take up the coil's force, and the sensor force dips, as on a real rig.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from rigtools.sim.shaker_params import SHAKER_BOUNDS, ShakerCoupling


@dataclass(frozen=True)
class ShakerParams:
    """Amplifier and shaker (SI).

    Parameters
    ----------
    armature_mass
        Moving mass of armature, table and stinger, kg.
    suspension_stiffness
        Armature suspension, N/m.
    suspension_damping
        Armature suspension, N*s/m.
    force_factor
        Bl, N/A (equally V*s/m for the back-EMF).
    coil_resistance
        Ohm.
    coil_inductance
        H.
    amplifier_gain
        Voltage gain of the power amplifier, V at the coil per V of drive.
    """

    armature_mass: float = SHAKER_BOUNDS["armature_mass"].default
    suspension_stiffness: float = SHAKER_BOUNDS["suspension_stiffness"].default
    suspension_damping: float = SHAKER_BOUNDS["suspension_damping"].default
    force_factor: float = SHAKER_BOUNDS["force_factor"].default
    coil_resistance: float = SHAKER_BOUNDS["coil_resistance"].default
    coil_inductance: float = SHAKER_BOUNDS["coil_inductance"].default
    amplifier_gain: float = SHAKER_BOUNDS["amplifier_gain"].default

    def __post_init__(self) -> None:
        for f in fields(self):
            SHAKER_BOUNDS[f.name].check(f.name, getattr(self, f.name))

    def coupling(self) -> ShakerCoupling:
        """The shaker as :class:`rigtools.sim.shaker_params.ShakerCoupling` (the amplifier gain is
        applied to the drive before the stepper sees it)."""
        return ShakerCoupling(
            armature_mass=self.armature_mass,
            suspension_stiffness=self.suspension_stiffness,
            suspension_damping=self.suspension_damping,
            force_factor=self.force_factor,
            coil_resistance=self.coil_resistance,
            coil_inductance=self.coil_inductance,
        )

    def sensor_force_per_drive(self, frequency_hz: np.ndarray, receptance: np.ndarray) -> np.ndarray:
        """Closed-form sensor force per drive volt, ``F / drive`` (N/V), of the linear coupled system.

        Parameters
        ----------
        frequency_hz
            Frequencies, Hz.
        receptance
            The blade's driving-point receptance ``x / F`` at the force point (m/N), complex,
            ``exp(+i w t)`` convention.

        Notes
        -----
        With ``Zb = 1 / receptance``, ``Zs = k_s + i w c_s - w**2 m_a`` and ``Ze = R + i w L``:
        ``x (Zb + Zs + i w Bl**2 / Ze) = Bl G drive / Ze`` and ``F = Zb x``.
        """
        w = 2.0 * np.pi * np.asarray(frequency_hz, dtype=float)
        zb = 1.0 / np.asarray(receptance)
        zs = self.suspension_stiffness + 1j * w * self.suspension_damping - w**2 * self.armature_mass
        ze = self.coil_resistance + 1j * w * self.coil_inductance
        x = self.force_factor * self.amplifier_gain / ze / (zb + zs + 1j * w * self.force_factor**2 / ze)
        return zb * x
