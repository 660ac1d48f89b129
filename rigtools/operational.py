"""The modes of a point without a force channel (an operational log): what ``rig analyze`` adds
to its spectra (:func:`analyze_operational`).

The motion channels of the point (acceleration, velocity or displacement: units m/s^2, m/s, m)
go together into the operational modal analysis of :func:`rigtools.analysis.oma.operational_modes`
(SSI-cov, harmonic tones flagged); other channels (temperature, wind, voltage) are left out and
a point without motion channels gets a note instead of modes.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rigtools.analysis.oma import operational_modes
from rigtools.analysis.spectra import response_spectra
from rigtools.recording_analysis.results import PointAnalysis
from rigtools.recording_analysis.samples import WINDOW_SAMPLES, record_window

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


def analyze_operational(
    point,
    *,
    fe: float | None = None,
    channels: Sequence[str] | None = None,
    band: tuple[float, float] | None = None,
) -> PointAnalysis:
    """A point without a force channel (an operational log): per channel the PSD, the
    peak-amplitude spectrum, the peaks of the PSD and, with ``fe``, the harmonics k·fe
    (:func:`rigtools.analysis.spectra.response_spectra`); the modes of its motion channels
    together, harmonic tones flagged, in ``band`` (:func:`point_modes`)."""
    rate = float(point.sample_rate)
    start, n = record_window(point)
    if n > WINDOW_SAMPLES:
        start, n = start + n - WINDOW_SAMPLES, WINDOW_SAMPLES
    names = list(channels or point.channels)
    spectra = {
        c: response_spectra(np.asarray(point.channels[c][start : start + n], dtype=float), rate, fe=fe)
        for c in names
    }
    spectra_note = (
        "no force channel: PSD in units²/Hz (Welch, Hann; its peaks are the spectral peaks), "
        "amplitudes are peak (flattop)"
    )
    notes = [spectra_note]
    oma, oma_notes = point_modes(point, (start, n), names, band=band, fe=fe)
    notes += oma_notes
    if fe is None:
        notes.append("give --fe to read the harmonics of an excitation frequency")
    return PointAnalysis.of_point(
        point, "operational", names, (start, n), spectra=spectra, notes=notes, oma=oma
    )
