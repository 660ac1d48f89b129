"""The names of the rig's channels, defined once, where the physics and the analysis may import
them (standard library only). What each name means, its unit and who writes it (rig, model or
both) is the vocabulary's (:mod:`rigtools.vocabulary`), built on these names.
"""

from __future__ import annotations

FORCE = "force"  # force into the active blade at the force sensor (measured, or applied to the model)
ACTIVE_SHROUD_ACCEL = "active_shroud_accel"
PASSIVE_SHROUD_ACCEL = "passive_shroud_accel"
DRIVE = "drive"  # DAQ analog output to the shaker amplifier (rig only)
ACTIVE_SHROUD_DISP = "active_shroud_disp"
PASSIVE_SHROUD_DISP = "passive_shroud_disp"
FORCE_POINT_DISP = "force_point_disp"
ACTIVE_SHROUD_VEL = "active_shroud_vel"
PASSIVE_SHROUD_VEL = "passive_shroud_vel"
FORCE_POINT_VEL = "force_point_vel"
FORCE_POINT_ACCEL = "force_point_accel"
CONTACT_FORCE = "contact_force"

#: The two shroud accelerations, active first (what a comparison scores).
SHROUD_ACCELS = (ACTIVE_SHROUD_ACCEL, PASSIVE_SHROUD_ACCEL)
#: Blade of each shroud channel.
BLADE_OF = {
    ACTIVE_SHROUD_ACCEL: "active",
    PASSIVE_SHROUD_ACCEL: "passive",
    ACTIVE_SHROUD_VEL: "active",
    PASSIVE_SHROUD_VEL: "passive",
    ACTIVE_SHROUD_DISP: "active",
    PASSIVE_SHROUD_DISP: "passive",
}
#: The velocity channel of each shroud acceleration (a model's exact harmonics come from it).
VELOCITY_OF = {ACTIVE_SHROUD_ACCEL: ACTIVE_SHROUD_VEL, PASSIVE_SHROUD_ACCEL: PASSIVE_SHROUD_VEL}
