"""The points a comparison reads (:mod:`rigtools.recording_comparison`), analysed: an EM point
over its settled window, a model point or model run over its whole record with the shroud
accelerations' harmonics taken from the velocity (``k w |V_k|``, exact for a periodic response),
and the EM force's harmonics that drive a model run."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rigtools.analysis.harmonics import derivative_harmonics, harmonic_amplitudes
from rigtools.analysis.point import analyze_dwell
from rigtools.errors import UserError
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL as ACTIVE
from rigtools.sim.channel_names import FORCE, VELOCITY_OF
from rigtools.sim.channel_names import PASSIVE_SHROUD_ACCEL as PASSIVE

COMPARED = (FORCE, ACTIVE, PASSIVE)
SCORED = (ACTIVE, PASSIVE)
K_MAX = 30


def settled_window(point) -> tuple[int, int]:
    """Settled window of a point, samples: ``record_start`` / ``record_samples`` if recorded."""
    n = point.n_samples
    fs = point.sample_rate
    start = point.params.get("record_start")
    count = point.params.get("record_samples")
    if start is None or count is None or fs is None:
        return 0, n
    a = round(float(start) * fs)
    b = min(n, a + int(count))
    if b - a <= 0:
        return 0, n
    return a, b


def too_short(point, k_max: int, who: str) -> str | None:
    """The note that leaves ``point`` out when a compared channel's record window holds fewer
    samples than a fit of ``k_max`` harmonics needs (``2 k_max + 1``), or ``None``."""
    total = {len(point.channels[c]) for c in COMPARED if c in point.channels}
    if len(total) > 1:
        return f"{who} point {point.index}: its channels differ in length ({min(total)} to {max(total)} samples), left out"
    a, b = settled_window(point)
    lengths = {c: min(b, len(point.channels[c])) - a for c in COMPARED if c in point.channels}
    short = {c: n for c, n in lengths.items() if n < 2 * k_max + 1}
    if not short:
        return None
    what = ", ".join(f"{c} {max(n, 0)}" for c, n in short.items())
    return f"{who} point {point.index}: too few samples to fit {k_max} harmonics ({what}; need {2 * k_max + 1}), left out"


def is_frf_point(point) -> bool:
    return "frame_samples" in point.params and "signal" in point.params


def em_point_analysis(point, k_max: int = K_MAX):
    """``(DwellAnalysis, {channel: samples}, rate)`` of an EM point over its settled window."""
    fs = point.sample_rate
    if fs is None:
        raise UserError(f"EM point {point.index}: its channels have different sample rates")
    a, b = settled_window(point)
    waves = {c: np.asarray(point.channels[c][a:b], dtype=float) for c in COMPARED if c in point.channels}
    fe = float(point.params["fe"])
    return analyze_dwell(waves, fs, fe, k_max=k_max), waves, fs


def _with_velocity_harmonics(analysis, velocities: dict, rate: float):
    """Replace the acceleration harmonics by ``derivative_harmonics`` of the velocity ones."""
    fits = dict(analysis.harmonics)
    for ch, v in velocities.items():
        if ch in fits:
            k = int(fits[ch].k[-1])
            fits[ch] = derivative_harmonics(harmonic_amplitudes(v, rate, analysis.fe, k), 1)
    return dataclasses.replace(analysis, harmonics=fits)


def model_run_analysis(run, k_max: int = K_MAX):
    """``(DwellAnalysis, {channel: samples}, rate)`` of a :class:`rigtools.sim.vibro_impact.VibroImpactRun`."""
    o = run.outputs
    waves = {
        FORCE: o["excitation_force"],
        ACTIVE: o["active_tip_acceleration"],
        PASSIVE: o["passive_tip_acceleration"],
    }
    res = analyze_dwell(waves, run.sample_rate, run.fe, k_max=k_max)
    res = _with_velocity_harmonics(
        res, {ACTIVE: o["active_tip_velocity"], PASSIVE: o["passive_tip_velocity"]}, run.sample_rate
    )
    return res, waves, run.sample_rate


def model_point_analysis(point, k_max: int = K_MAX):
    """Same for a point of a model recording (its record window, the whole point where none is set,
    as a model run's; velocities used when present)."""
    fs = point.sample_rate
    waves = {c: point.settled(c) for c in COMPARED if c in point.channels}
    res = analyze_dwell(waves, fs, float(point.params["fe"]), k_max=k_max)
    vel = {c: point.settled(v) for c, v in VELOCITY_OF.items() if v in point.channels and c in waves}
    return _with_velocity_harmonics(res, vel, fs), waves, fs


def em_force_harmonics(analysis) -> list[tuple[int, float, float]]:
    """``(k, A_k, phi_k)`` of the EM force, phases shifted so the fundamental is ``-pi/2`` (a sine
    from t = 0, as the nominal force): ``phi_k - k (phi_1 + pi/2)``."""
    fit = analysis.harmonics[FORCE]
    shift = fit.phase[0] + math.pi / 2
    return [
        (int(k), float(a), float(np.angle(np.exp(1j * (p - k * shift)))))
        for k, a, p in zip(fit.k, fit.amplitude, fit.phase, strict=True)
    ]
