"""The modes of a point without a force channel (an operational log): what ``rig analyze`` adds
to its spectra (:func:`rigtools.analyze.analyze_operational`).

The motion channels of the point (acceleration, velocity or displacement: units m/s^2, m/s, m)
go together into the operational modal analysis of :func:`rigtools.analysis.oma.operational_modes`
(SSI-cov, harmonic tones flagged); other channels (temperature, wind, voltage) are left out and
a point without motion channels gets a note instead of modes.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rigtools.analysis.oma import operational_modes

MOTION_UNITS = ("m/s^2", "m/s", "m")


def motion_channels(point, names: Sequence[str]) -> list[str]:
    """The channels of ``names`` that measure motion (their units), not force."""
    return [
        c for c in names if point.channels[c].units in MOTION_UNITS and point.channels[c].quantity != "force"
    ]


def point_modes(
    point,
    window: tuple[int, int],
    names: Sequence[str],
    *,
    band: tuple[float, float] | None = None,
    fe: float | None = None,
):
    """``(OMAResult or None, notes)`` of the motion channels among ``names`` over ``window``
    (first sample, samples). None, with a note saying why, for a point without motion
    channels, one whose rate cannot hold ``band`` or too short for it (a recording may hold
    such points beside the one with the modes, e.g. a logger's weather channels)."""
    motion = motion_channels(point, names)
    if not motion:
        return None, ["no motion channel (acceleration, velocity, displacement): no modes"]
    start, n = window
    y = np.vstack([np.asarray(point.channels[c][start : start + n], dtype=float) for c in motion])
    rate = float(point.sample_rate)
    try:
        res = operational_modes(y, rate, band=band, fe=fe, channels=motion)
    except ValueError as exc:
        return None, [f"no modes: {exc}"]
    notes = [
        f"modes without a force (operational modal analysis of {len(motion)} motion channel(s)): "
        + res.notes[0]
    ]
    notes += res.notes[1:]
    if res.harmonics:
        notes.append(
            f"{len(res.harmonics)} harmonic tone(s) flagged, not modes: "
            + ", ".join(f"{h.frequency_hz:.4g} Hz" for h in res.harmonics)
        )
    return res, notes
