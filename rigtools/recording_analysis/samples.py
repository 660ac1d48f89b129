"""What is read of a recorded point: its record window, its samples in blocks (bounded memory
for any record length), its force and response channels, and a short window for waveform figures."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from rigtools.errors import UserError
from rigtools.recording import open_recording
from rigtools.recording_analysis.results import frf_kind_of_units
from rigtools.sim.channel_names import FORCE
from rigtools.vocabulary import excitation_frequency

BLOCK_SAMPLES = 1 << 18  # samples per channel read at a time
WINDOW_SAMPLES = 1 << 21  # at most this many samples per channel held for impacts and plots


def sample_blocks(
    point, names: Sequence[str], start: int, n: int, size: int | None = None
) -> Iterator[np.ndarray]:
    """``(len(names), m)`` blocks of samples ``start .. start + n`` in time order, ``size``
    (default :data:`BLOCK_SAMPLES`) samples per channel each."""
    size = size or BLOCK_SAMPLES
    for a in range(start, start + n, size):
        b = min(start + n, a + size)
        yield np.vstack([np.asarray(point.channels[c][a:b], dtype=float) for c in names])


def record_window(point) -> tuple[int, int]:
    """``(first sample, samples)`` of the point's record window (``record_start`` s and
    ``record_samples``), else the whole point: :attr:`rigtools.recording.reader.Point.record_window`."""
    return point.record_window


def force_channel(point) -> str | None:
    """The force channel: the point's ``reference_channel`` (an import's excitation, found from
    its quantity or named with ``--reference``), ``force`` (vocabulary), else the only channel
    of quantity force."""
    named = point.params.get("reference_channel")
    if isinstance(named, str) and named in point.channels:
        return named
    if FORCE in point.channels:
        return FORCE
    forces = [n for n, c in point.channels.items() if c.quantity == "force" and n != "contact_force"]
    return forces[0] if len(forces) == 1 else None


def response_channels(point, force: str | None) -> list[str]:
    """Channels analysed as responses of a broadband point: the shroud accelerations (or any
    acceleration, velocity or displacement channel), not the force, drive or contact force."""
    out = [
        n
        for n, c in point.channels.items()
        if n != force and frf_kind_of_units(c.units) is not None and c.quantity != "force"
    ]
    vocab = [n for n in out if n in ("active_shroud_accel", "passive_shroud_accel")]
    return vocab or out


def point_window(path: str | Path, index: int, periods: float = 5.0) -> tuple[dict, float, float, dict]:
    """The last ``periods`` periods (periodic) or the first frame (broadband) of a point, for
    waveform figures: ``({channel: samples}, sample_rate, t0 s, units)``."""
    with open_recording(path) as rec:
        point = next(p for p in rec.points if p.index == index)
        rate = point.sample_rate
        if rate is None:
            raise UserError(f"{path}: point {index} has channels at different sample rates")
        start, n = record_window(point)
        fe = excitation_frequency(point.params)
        if fe:
            m = min(n, round(max(periods, 1.0) * 40 * rate / fe), WINDOW_SAMPLES)
        else:
            m = min(n, int(point.params.get("frame_samples", n)), WINDOW_SAMPLES)
        a = start + n - m if fe else start
        data = {c: np.asarray(ch[a : a + m], dtype=float) for c, ch in point.channels.items()}
        units = {c: ch.units for c, ch in point.channels.items()}
        t0 = point.channels[next(iter(point.channels))].t0 + a / rate
    return data, rate, t0, units
