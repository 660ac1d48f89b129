"""The simulated rig's test article: how its blades and sensors differ from the nominal rig.

The rig file's ``[test_article]`` (:class:`rigtools.config.TestArticleConfig`) validates into it,
and :class:`rigtools.drivers.simulated.SimulatedRig` builds its model from it. Its own small module
(standard library and :mod:`rigtools.sim.params` only) so that reading a rig file does not load the
simulated rig's physics (numba).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from rigtools.sim.params import DampingParams, RigParams, RootParams


@dataclass(frozen=True)
class TestArticle:
    """How the simulated rig's blades and sensors differ from the nominal rig (SI).

    Parameters
    ----------
    root_rotational_stiffness, root_translational_stiffness
        The bolted root of both blades, as springs on every root DOF (N*m/rad, N/m).
    damping_ratio
        Modal damping ratio of every mode of the test article.
    shroud_mass_deviation, sensor_mass_deviation
        Relative deviations of the shroud and force-sensor masses (and rotary inertias) from
        nominal, e.g. 0.01 for +1 %.
    force_noise, accel_noise
        Sensor noise, rms over the full band, N and m/s^2.
    adc_noise
        ADC input noise, V rms.
    iepe_highpass
        Corner of the IEPE coupling high-pass, Hz (0: DC coupled).
    input_to_output_delay
        Delay of the simulated DAQ between drive and inputs, s: a delay line of whole samples
        plus the integrating sampler's half sample, the line chosen so that the sum comes
        nearest to this value (at least half a sample).
    """

    __test__ = False  # not a pytest class

    root_rotational_stiffness: float = 1.2e4
    root_translational_stiffness: float = 3e8
    damping_ratio: float = 0.012
    shroud_mass_deviation: float = 0.01
    sensor_mass_deviation: float = -0.01
    force_noise: float = 0.005
    accel_noise: float = 0.02
    adc_noise: float = 2e-5
    iepe_highpass: float = 0.5
    input_to_output_delay: float = 8e-4

    def apply(self, nominal: RigParams) -> RigParams:
        """The test article's parameters: ``nominal`` with this root, damping and masses."""
        root = RootParams("springs", self.root_rotational_stiffness, self.root_translational_stiffness)
        s, m = 1.0 + self.shroud_mass_deviation, 1.0 + self.sensor_mass_deviation
        shroud = replace(
            nominal.shroud, mass=nominal.shroud.mass * s, rotary_inertia=nominal.shroud.rotary_inertia * s
        )
        sensor = replace(
            nominal.force_sensor,
            mass=nominal.force_sensor.mass * m,
            rotary_inertia=nominal.force_sensor.rotary_inertia * m,
        )
        return replace(
            nominal,
            root=root,
            passive_root=None,
            shroud=shroud,
            force_sensor=sensor,
            damping=DampingParams(ratio=self.damping_ratio),
        )

    def ideal(self) -> TestArticle:
        """The same deviations with a noise-free, DC-coupled measurement chain without delay line
        (the integrating sampler's half sample remains)."""
        return replace(
            self,
            force_noise=0.0,
            accel_noise=0.0,
            adc_noise=0.0,
            iepe_highpass=0.0,
            input_to_output_delay=0.0,
        )
