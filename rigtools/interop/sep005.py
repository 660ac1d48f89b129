"""Recordings as SDyPy SEP005 channel dictionaries, so pyFRF and sdypy users take them as they are.

SEP005 describes a time series as a dict with ``name``, ``data`` (1-D array), ``fs`` (Hz) and
``unit_str``; a measurement is a list of such dicts.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def point_to_sep005(point: Any) -> list[dict]:
    """The channels of one recording point (:class:`rigtools.recording.reader.Point`) as SEP005
    dicts (``name``, ``data``, ``fs``, ``unit_str``, plus ``start_timestamp`` and ``t0``)."""
    out = []
    for name, channel in point.channels.items():
        out.append(
            {
                "name": name,
                "data": np.asarray(channel.read(), dtype=float),
                "fs": float(channel.sample_rate),
                "unit_str": channel.units,
                "start_timestamp": point.start_time,
                "t0": float(channel.t0),
            }
        )
    return out


def to_sep005(recording: Any, point: int | None = None) -> list[dict] | list[list[dict]]:
    """SEP005 channel dicts of a recording (open :class:`~rigtools.recording.reader.Recording`).

    Parameters
    ----------
    recording
        An open recording (``rigtools.open_recording(path)``).
    point
        A point index: its channels as one list; ``None``: one list per point.
    """
    if point is not None:
        matches = [p for p in recording.points if p.index == point]
        if not matches:
            raise IndexError(
                f"point {point} not in the recording (points {[p.index for p in recording.points]})"
            )
        return point_to_sep005(matches[0])
    return [point_to_sep005(p) for p in recording.points]
