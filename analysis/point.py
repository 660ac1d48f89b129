"""One call per recorded point: the entry points ``rig analyze`` builds on.

- :func:`analyze_dwell`: a periodic point (sine dwell, a step of a stepped sine or of a study):
  harmonics k = 1..K of every channel (amplitude and phase, also relative to the force
  fundamental), peak levels, and impacts from the shroud accelerations.
- :func:`analyze_frf_test`: a broadband point (burst random, periodic chirp, random) given block
  by block: H1, H2, Hv and coherence of every response over the force, converted to the FRF kind
  asked for, and the modes the data support (:func:`rigtools.analysis.modal_id.identify`).

Channel names default to the rig's (``force``, ``active_shroud_accel``, ``passive_shroud_accel``)
and can be given. Nothing here reads files: the caller passes arrays or blocks.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from rigtools.analysis.frf import FRFEstimate, FRFKind, FRFMethod
from rigtools.analysis.harmonics import HarmonicFit, harmonic_amplitudes, relative_phases
from rigtools.analysis.impacts import ImpactAnalysis, detect_impacts
from rigtools.analysis.modal_id import ModalIdentification, identify
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL as ACTIVE
from rigtools.sim.channel_names import FORCE
from rigtools.sim.channel_names import PASSIVE_SHROUD_ACCEL as PASSIVE


@dataclass(frozen=True)
class DwellAnalysis:
    """Result of :func:`analyze_dwell`.

    Attributes
    ----------
    fe, sample_rate
        Hz.
    harmonics
        ``{channel: HarmonicFit}`` (peak amplitudes, phases from the first analysed sample).
    phases_to_force
        ``{channel: (K,) phases relative to the force fundamental}``
        (:func:`rigtools.analysis.harmonics.relative_phases`); empty without a force channel.
    force_amplitude
        Peak amplitude of the force fundamental (N), None without a force channel.
    peak_levels
        ``{channel: max |x|}`` over the analysed samples (peak).
    impacts
        :class:`rigtools.analysis.impacts.ImpactAnalysis`, or None without an active shroud channel.
    """

    fe: float
    sample_rate: float
    harmonics: dict[str, HarmonicFit]
    phases_to_force: dict[str, np.ndarray] = field(default_factory=dict)
    force_amplitude: float | None = None
    peak_levels: dict[str, float] = field(default_factory=dict)
    impacts: ImpactAnalysis | None = None

    def to_dict(self) -> dict:
        """Plain-Python summary for ``--json``: per channel ``harmonics`` records (k, frequency_hz,
        amplitude (peak), phase, phase_to_force), ``peak``; ``force_amplitude``; ``impacts``."""
        channels = {}
        for name, fit in self.harmonics.items():
            recs = fit.to_records()
            rel = self.phases_to_force.get(name)
            if rel is not None:
                for r, p in zip(recs, rel, strict=True):
                    r["phase_to_force"] = float(p)
            channels[name] = {
                "harmonics": recs,
                "offset": fit.offset,
                "residual_rms": fit.residual_rms,
                "peak": self.peak_levels.get(name),
            }
        return {
            "fe": self.fe,
            "sample_rate": self.sample_rate,
            "amplitude": "peak",
            "force_amplitude": self.force_amplitude,
            "channels": channels,
            "impacts": None if self.impacts is None else self.impacts.to_dict(),
        }


def analyze_dwell(
    channels: Mapping[str, np.ndarray],
    sample_rate: float,
    fe: float,
    *,
    k_max: int = 30,
    force: str = FORCE,
    active: str = ACTIVE,
    passive: str = PASSIVE,
    impact_options: Mapping | None = None,
) -> DwellAnalysis:
    """Harmonics, peak levels and impacts of a periodic point.

    Parameters
    ----------
    channels
        ``{name: (n,) samples}`` of the settled part of the point, SI units, common rate.
    sample_rate, fe
        Hz.
    k_max
        Highest harmonic; lowered to the largest below the Nyquist frequency.
    force, active, passive
        Channel names of the force into the blade and the shroud accelerations (missing ones are
        skipped).
    impact_options
        Extra keyword arguments of :func:`rigtools.analysis.impacts.detect_impacts`.
    """
    k_top = int(np.floor((sample_rate / 2) / fe - 1e-9))
    k = max(1, min(int(k_max), k_top))
    fits = {
        name: harmonic_amplitudes(np.asarray(x, dtype=float), sample_rate, fe, k)
        for name, x in channels.items()
    }
    rel, f_amp = {}, None
    if force in fits:
        f_amp = float(fits[force].amplitude[0])
        rel = {name: relative_phases(fit, fits[force]) for name, fit in fits.items()}
    impacts = None
    if active in channels:
        impacts = detect_impacts(
            channels[active],
            sample_rate,
            fe,
            passive_acceleration=channels.get(passive),
            force=channels.get(force),
            **dict(impact_options or {}),
        )
    peaks = {name: float(np.max(np.abs(x))) for name, x in channels.items()}
    return DwellAnalysis(float(fe), float(sample_rate), fits, rel, f_amp, peaks, impacts)


@dataclass(frozen=True)
class FRFTestAnalysis:
    """Result of :func:`analyze_frf_test`.

    Attributes
    ----------
    responses
        Response channel names, in the order of the rows of ``estimate``.
    estimate
        :class:`rigtools.analysis.frf.FRFEstimate` in ``kind`` units, (n_responses, n_freq) arrays.
    kind
        FRF kind of ``estimate``.
    modes
        ``{response: ModalIdentification}`` from ``estimator``.
    frf_method
        How the estimate was made (:class:`rigtools.analysis.frf.FRFMethod`), when known.
    """

    responses: list[str]
    estimate: FRFEstimate
    kind: str
    modes: dict[str, ModalIdentification]
    frf_method: FRFMethod | None = None

    def to_dict(self) -> dict:
        """Modes and notes per response (the FRF arrays themselves are for plots/files)."""
        return {
            "kind": self.kind,
            "n_averages": self.estimate.n_averages,
            "resolution_hz": self.estimate.resolution_hz,
            "modes": {
                r: {
                    "method": m.method,
                    "band_hz": list(m.band) if m.band else None,
                    "orders_judged": list(m.chart.judged) if m.chart is not None else None,
                    "notes": list(m.notes),
                    "n_modes": len(m.modes),
                    "no_mode": m.no_mode or None,
                    "tried": dict(m.tried),
                    "modes": [
                        {
                            "frequency_hz": x.frequency_hz,
                            "damping_ratio": x.damping_ratio,
                            "evidence": x.evidence(),
                        }
                        for x in m.modes
                    ],
                    "dropped": list(m.dropped),
                }
                for r, m in self.modes.items()
            },
        }


def analyze_frf_test(
    blocks: Iterable[Mapping[str, np.ndarray]],
    sample_rate: float,
    *,
    frf_method: FRFMethod,
    responses: Sequence[str] = (ACTIVE, PASSIVE),
    force: str = FORCE,
    measured: FRFKind = "accelerance",
    kind: FRFKind = "accelerance",
    estimator: str = "h1",
    f_min: float | None = None,
    f_max: float | None = None,
    method: str = "lscf",
    n_modes: int | None = None,
) -> FRFTestAnalysis:
    """FRFs and modes of a broadband test, processed block by block (bounded memory).

    Parameters
    ----------
    blocks
        Iterable of ``{channel: (n,) samples}`` in time order (any block lengths); for an
        ``impact`` method, one block per frame of exactly ``frame_samples``.
    frf_method
        The estimate (:class:`rigtools.analysis.frf.FRFMethod`), the one every reader uses;
        a recording's is chosen by :func:`rigtools.recording_analysis.frf_estimate.frf_method_of`.
    responses, force
        Channel names.
    measured, kind
        What the responses measure over force (``"accelerance"`` for accelerometers) and the FRF
        kind wanted.
    estimator
        ``"h1"``, ``"h2"`` or ``"hv"`` for the modal identification.
    f_min, f_max, method, n_modes
        :func:`rigtools.analysis.modal_id.identify`.
    """
    names = [force, *responses]
    rows = (np.vstack([np.asarray(block[n], dtype=float) for n in names]) for block in blocks)
    est = frf_method.estimate(rows, sample_rate).as_kind(measured, kind)
    h = est.estimator(estimator)
    modes = {}
    for i, name in enumerate(responses):
        modes[name] = identify(
            est.frequency_hz,
            h[i],
            kind=kind,
            excitation_psd=est.sxx,
            coherence=est.coherence[i] if est.n_averages > 1 else None,
            f_min=f_min,
            f_max=f_max,
            method=method,
            n_modes=n_modes,
        )
    return FRFTestAnalysis(list(responses), est, kind, modes, frf_method)
