"""The contact half of ``rig update``: force-controlled dwells with impacts (``rig acquire
dwell``) read as harmonic targets (:func:`read_dwell`), the model's harmonics at the measured force
(:func:`model_dwell`), the EM-versus-FEM score of a dwell (:func:`agreement`) and the contact fit
(:func:`fit_contact_to_dwells`: :func:`rigtools.sim.contact_fit.fit_contact`, vibro-impact integrator
in the loop)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np

from rigtools.analysis.correlation import point_agreement
from rigtools.analysis.harmonics import derivative_harmonics, harmonic_amplitudes
from rigtools.analysis.point import DwellAnalysis, analyze_dwell
from rigtools.errors import UserError
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL as ACTIVE
from rigtools.sim.channel_names import FORCE
from rigtools.sim.channel_names import PASSIVE_SHROUD_ACCEL as PASSIVE
from rigtools.sim.contact_fit import HarmonicTarget, fit_contact
from rigtools.sim.params import SimulationInputError
from rigtools.sim.reduction import reduced_system
from rigtools.simulation import RunSettings, simulate_point
from rigtools.update_modes import open_test_recording

DWELL_CHANNELS = (FORCE, ACTIVE, PASSIVE)
ContactLaw = Literal["linear", "hertz"]
K_HARMONICS = 10  # harmonics fitted and scored (k = 1..10: most of each shroud's energy at 60 Hz)


@dataclass
class DwellData:
    """A settled force-controlled dwell: what the contact fit and the scores use."""

    name: str
    fe: float
    force_amplitude: float  # measured fundamental of the force, N (the model is driven at it)
    gap: float
    analysis: DwellAnalysis  # of the settled window

    def amplitudes(self, channel: str, k_max: int = K_HARMONICS) -> np.ndarray:
        return np.asarray(self.analysis.harmonics[channel].amplitude[:k_max], dtype=float)


def read_dwell(path: str | Path, *, k_max: int = 30) -> list[DwellData]:
    """The settled windows of the force-controlled dwell points of a recording (``rig acquire
    dwell`` / ``sweep`` / ``study``), analysed (harmonics k = 1..k_max).

    Raises
    ------
    UserError
        Unreadable file, or no settled dwell point with a force and a shroud channel.
    """
    name = Path(path).name
    out = []
    with open_test_recording(path) as rec:
        for point in rec.complete_points:
            prm = point.params
            if not {"fe", "record_start", "record_samples", "gap"} <= set(prm) or "frame_samples" in prm:
                continue
            if not prm.get("settled", True) or point.sample_rate is None:
                continue
            if FORCE not in point.channels or ACTIVE not in point.channels:
                continue
            rate = float(point.sample_rate)
            start = round(float(prm["record_start"]) * rate)
            n = int(prm["record_samples"])
            chans = {c: point.channels[c][start : start + n] for c in DWELL_CHANNELS if c in point.channels}
            ana = analyze_dwell(chans, rate, float(prm["fe"]), k_max=k_max)
            f0 = prm.get("force_amplitude_measured") or ana.force_amplitude
            if f0 is None:  # no force fundamental to drive the model at
                continue
            out.append(
                DwellData(f"{name}:{point.index}", float(prm["fe"]), float(f0), float(prm["gap"]), ana)
            )
    if not out:
        raise UserError(
            f"{name} holds no settled force-controlled dwell point (record one with 'rig acquire dwell')"
        )
    return out


def model_dwell(params, dwell: DwellData, *, system=None, duration: float = 0.5):
    """The model's settled run at a dwell's frequency, measured force amplitude and gap, as a
    :class:`rigtools.analysis.point.DwellAnalysis` (shroud accelerations from the velocity, ``k w |V_k|``;
    the force as run)."""
    system = system if system is not None else reduced_system(params, "fem")
    system = replace(system, contact=params.contact).with_contact(gap=dwell.gap)
    run = simulate_point(system, dwell.fe, dwell.force_amplitude, RunSettings(duration=duration))
    k = 30
    fits = {
        FORCE: harmonic_amplitudes(run.outputs["excitation_force"], run.sample_rate, run.fe, k),
        ACTIVE: derivative_harmonics(
            harmonic_amplitudes(run.outputs["active_tip_velocity"], run.sample_rate, run.fe, k), 1
        ),
        PASSIVE: derivative_harmonics(
            harmonic_amplitudes(run.outputs["passive_tip_velocity"], run.sample_rate, run.fe, k), 1
        ),
    }
    return DwellAnalysis(run.fe, run.sample_rate, fits, force_amplitude=fits[FORCE].at(1))


def agreement(dwell: DwellData, model, *, k_max: int = K_HARMONICS):
    """EM-versus-FEM :class:`rigtools.analysis.correlation.Agreement` over the force and both shroud
    accelerations, harmonics 1..k_max."""
    return point_agreement(dwell.analysis, model, channels=list(DWELL_CHANNELS), k_max=k_max)


def harmonic_targets(
    dwells: Sequence[DwellData], *, k_max: int = K_HARMONICS, sigma: float = 0.05, floor: float = 0.01
) -> list:
    """:class:`rigtools.sim.contact_fit.HarmonicTarget` of each dwell (both shroud accelerations)."""
    return [
        HarmonicTarget(
            d.fe,
            d.force_amplitude,
            d.gap,
            {c: d.amplitudes(c, k_max) for c in (ACTIVE, PASSIVE) if c in d.analysis.harmonics},
            sigma=sigma,
            floor=floor,
        )
        for d in dwells
    ]


def fit_contact_to_dwells(
    params,
    dwells: Sequence[DwellData],
    *,
    law: ContactLaw | None = None,
    names: Sequence[str] = ("contact.stiffness", "contact.damping"),
    k_max: int = K_HARMONICS,
):
    """:func:`rigtools.sim.contact_fit.fit_contact` to the dwells' shroud harmonics; one-line errors."""
    try:
        return fit_contact(params, harmonic_targets(dwells, k_max=k_max), list(names), law=law)
    except (ValueError, SimulationInputError) as exc:
        raise UserError(f"contact fit: {exc}") from None
