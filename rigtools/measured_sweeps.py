"""Recorded sweeps and studies read as curves to overlay on continued branches
(:func:`measured_sweeps`): stepped sines of ``rig acquire sweep`` and studies of ``rig study`` /
``rig acquire study``, with each point's contact (:func:`point_contact`) and the jumps between
neighbouring steps (:func:`rigtools.procedures.detect_jumps`).

It loads the procedures (scipy.signal) and the recording analysis: ``rig continuation`` imports it
only when given ``--measured``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rigtools.analysis.branches import MeasuredSweep
from rigtools.analysis.jumps import contact_seen
from rigtools.branches_file import MEASURES, POINT_PARAM
from rigtools.errors import UserError
from rigtools.procedures import detect_jumps
from rigtools.recording import open_recording
from rigtools.recording_analysis.periodic import analyze_periodic
from rigtools.recording_analysis.samples import record_window
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL, ACTIVE_SHROUD_DISP, FORCE, PASSIVE_SHROUD_ACCEL

JUMP_THRESHOLD = 0.3  # as rig acquire sweep's default --jump-threshold


def measured_sweeps(paths, param: str, measure: str = "contact") -> list:
    """The recorded sweeps of ``paths`` (stepped sines of ``rig acquire sweep``, studies of
    ``rig study`` / ``rig acquire study``) as :class:`rigtools.analysis.branches.MeasuredSweep`,
    one per file and direction, points in run order, with the contact of each point
    (:func:`point_contact`) and their jumps (a change above :data:`JUMP_THRESHOLD` between
    neighbouring steps that the contact or the other direction confirms,
    :func:`rigtools.procedures.detect_jumps`).

    ``measure`` is read as the branches have it: ``accel1`` the fundamental of the active shroud
    acceleration (fitted over each point's record window), ``contact`` and ``impacts`` the
    model's point parameters (a rig recording has no contact force: a one-line error says so),
    ``tip`` half the peak-to-peak active shroud displacement channel of a model recording.
    """

    def value(path, point) -> float:
        if measure == "accel1":
            a = analyze_periodic(point, channels=[FORCE, ACTIVE_SHROUD_ACCEL], k_max=1)
            return float(a.dwell.harmonics[ACTIVE_SHROUD_ACCEL].amplitude[0])
        if measure == "tip" and ACTIVE_SHROUD_DISP in point.channels:
            start, n = record_window(point)
            return 0.5 * float(np.ptp(point.channels[ACTIVE_SHROUD_DISP][start : start + n]))
        name = {"contact": "peak_contact_force", "impacts": "impacts_per_period"}.get(measure, "")
        if name not in point.params:
            raise UserError(
                f"--measured {path}: point {point.index} has no {MEASURES[measure][2]} "
                f"(a rig recording measures accelerations: use --measure accel1)"
            )
        return float(point.params[name])

    out = []
    for path in paths:
        with open_recording(path) as rec:
            runs: dict[str, tuple[list[float], list[float], list[bool | None]]] = {}
            for point in rec.complete_points:
                if POINT_PARAM[param] not in point.params or "fe" not in point.params:
                    raise UserError(f"--measured {path}: point {point.index} has no {POINT_PARAM[param]}")
                x, y, touch = runs.setdefault(str(point.params.get("direction", "up")), ([], [], []))
                x.append(float(point.params[POINT_PARAM[param]]))
                y.append(value(path, point))
                touch.append(point_contact(point.params))
        if not runs:
            raise UserError(f"--measured {path}: no complete point to overlay")
        for direction, (x, y, touch) in runs.items():
            other = next(((ox, oy) for d, (ox, oy, _) in runs.items() if d != direction), None)
            jumps = [
                (j["from_hz"], j["to_hz"])
                for j in detect_jumps(x, y, JUMP_THRESHOLD, contact=touch, other=other)
            ]
            name = f"{Path(path).stem} ({direction})"
            out.append(MeasuredSweep(np.array(x), np.array(y), direction, name, jumps, touch))
    return out


def point_contact(params: dict) -> bool | None:
    """Whether the shrouds touch at a recorded point: a model point's impacts per period (or peak
    contact force), a rig point's shroud acceleration harmonics
    (:func:`rigtools.analysis.jumps.contact_seen`); ``None`` if the point says neither."""
    for key in ("impacts_per_period", "peak_contact_force"):
        if key in params:
            return bool(float(params[key]) > 0)
    active = params.get(f"{ACTIVE_SHROUD_ACCEL}_harmonic_amplitude")
    if active is None:
        return None
    return contact_seen(active, params.get(f"{PASSIVE_SHROUD_ACCEL}_harmonic_amplitude"))
