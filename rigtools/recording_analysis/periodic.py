"""A periodic point (a sine dwell, a step of a stepped sine, a point of a study, a model run; it
has ``fe``): harmonics k = 1..30 of every channel over the whole record window (block by block),
peak levels and impacts over its last :data:`~rigtools.recording_analysis.samples.WINDOW_SAMPLES` samples. No modes: a sine excites
one frequency at a time."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from rigtools.analysis.harmonics import harmonics_from_blocks, relative_phases
from rigtools.analysis.point import analyze_dwell
from rigtools.errors import UserError
from rigtools.recording_analysis.results import PointAnalysis
from rigtools.recording_analysis.samples import WINDOW_SAMPLES, record_window, sample_blocks
from rigtools.sim.channel_names import FORCE

K_MAX = 30
NO_MODES_PERIODIC = (
    "no modes from a sine record: a sine excites one frequency at a time, so the "
    "force has no broadband content to identify poles from (use rig acquire frf)"
)


def analyze_periodic(point, *, channels: Sequence[str] | None = None, k_max: int = K_MAX) -> PointAnalysis:
    """Harmonics (whole record window, in blocks), peak levels and impacts (last
    :data:`~rigtools.recording_analysis.samples.WINDOW_SAMPLES`) of a point with ``fe``."""
    fe = float(point.params["fe"])
    rate = float(point.sample_rate)
    names = list(channels or point.channels)
    start, n = record_window(point)
    notes = []
    k = max(1, min(int(k_max), int(np.floor(rate / 2 / fe - 1e-9))))
    if k < k_max:
        notes.append(f"harmonics up to k = {k}: {k + 1}·fe is above the Nyquist frequency {rate / 2:g} Hz")
    if n < 2 * k + 1:
        raise UserError(f"point {point.index}: {n} samples in the record window, too few for {k} harmonics")
    # impacts and peaks from the last whole periods that fit in WINDOW_SAMPLES
    per = rate / fe
    m = n if n <= WINDOW_SAMPLES else int(np.floor(WINDOW_SAMPLES / per) * per)
    a = start + n - m
    arrays = {c: np.asarray(point.channels[c][a : a + m], dtype=float) for c in names}
    dwell = analyze_dwell(arrays, rate, fe, k_max=k, force=FORCE)
    if m < n:  # harmonics over the whole window, block by block
        fits = dict(
            zip(names, harmonics_from_blocks(sample_blocks(point, names, start, n), rate, fe, k), strict=True)
        )
        rel = {c: relative_phases(f, fits[FORCE]) for c, f in fits.items()} if FORCE in fits else {}
        dwell = replace(
            dwell,
            harmonics=fits,
            phases_to_force=rel,
            force_amplitude=float(fits[FORCE].amplitude[0]) if FORCE in fits else None,
        )
        notes.append(f"impacts and peak levels from the last {m} of {n} samples; harmonics over all")
    notes.append(NO_MODES_PERIODIC)
    return PointAnalysis.of_point(point, "periodic", names, (start, n), dwell=dwell, notes=notes)
