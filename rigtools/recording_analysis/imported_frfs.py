"""The modes of an FRF set (FRFs estimated elsewhere and stored by ``rig import uff``, see
:mod:`rigtools.frf_set`): one broadband point identified from the stored FRFs and coherence."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from rigtools.analysis.frf import FRFEstimate, FRFKind
from rigtools.analysis.modal_id import identify
from rigtools.analysis.point import FRFTestAnalysis
from rigtools.errors import UserError
from rigtools.frf_set import read_frf_set
from rigtools.recording_analysis.frf_estimate import FRFOptions
from rigtools.recording_analysis.results import PointAnalysis, RecordingAnalysis, frf_kind


def analyze_frf_set(
    path: str | Path,
    *,
    kind: str = "accelerance",
    method: str = "lscf",
    channels: Sequence[str] | None = None,
    options: FRFOptions | None = None,
) -> RecordingAnalysis:
    """Modes of the FRFs of an FRF set (:mod:`rigtools.frf_set`, e.g. ``rig import uff``), one
    broadband point: the identification :func:`rigtools.recording_analysis.broadband.analyze_broadband` runs, on the stored FRFs and
    coherence; the band is ``options.band`` or the whole grid above 0 Hz (an FRF set holds no
    force spectrum). Never compared with this rig's FEM (it does not describe this rig)."""
    (options or FRFOptions()).refuse_unused(
        f"{path} is an FRF set: its FRFs were estimated elsewhere", band=False
    )
    fs = read_frf_set(path)
    kind_out = frf_kind(kind)
    rows = list(range(len(fs.responses)))
    if channels:
        unknown = [c for c in channels if c not in fs.responses and c != fs.reference]
        if unknown:
            raise UserError(f"{path}: no FRF of {', '.join(unknown)} (responses: {', '.join(fs.responses)})")
        rows = [i for i, r in enumerate(fs.responses) if r in channels]
    f = fs.frequency_hz
    h = fs.frf[rows]
    coh = fs.coherence[rows]
    with_coherence = bool(np.all(np.isfinite(coh)))
    est = FRFEstimate(
        f, h, h, coh, 2 if with_coherence else 1, np.full(f.size, np.nan), np.abs(h) * np.nan, h * np.nan
    ).as_kind(frf_kind(fs.kind), kind_out)
    band = (options or FRFOptions()).band
    responses = [fs.responses[i] for i in rows]
    together = method == "lscf" and len(responses) > 1
    try:
        modes = _identified(
            f, est, responses, kind_out, band, method, together=together, coherent=with_coherence
        )
    except ValueError as exc:
        raise UserError(f"{path}: {exc}") from None
    first = next(iter(modes.values()), None)
    params: dict[str, Any] = {"reference_channel": fs.reference}
    if first is not None and first.band is not None:
        params["band_low"], params["band_high"] = first.band
    notes = [
        f"FRF set from {fs.source.get('file', '?')} ({fs.kind} as imported); no force spectrum: band "
        + ("as asked" if band else "the whole grid above 0 Hz (--band narrows it)")
    ]
    if not with_coherence:
        notes.append("no coherence in the FRF set: peaks are not checked against it")
    if together:
        notes.append(
            f"the {len(responses)} FRFs identified together (common poles; shapes stable between orders)"
        )
        notes.extend(next(iter(modes.values())).notes)
    else:
        for r, m in modes.items():
            notes.extend(f"{r}: {t}" for t in m.notes)
    units = {r: {"accelerance": "m/s^2", "mobility": "m/s", "receptance": "m"}[fs.kind] for r in responses}
    point = PointAnalysis(
        0,
        "broadband",
        params,
        {fs.reference: "N", **units},
        2.0 * float(f[-1]),
        (0, 0),
        frf=FRFTestAnalysis(responses, est, kind_out, modes, None),
        excitation="measured FRF",
        notes=notes,
    )
    out = RecordingAnalysis(str(path), "frf set", "frf set", "em", "complete", kind_out, [point])
    out.notes.append("FRF set: not compared with this rig's FEM")
    return out


def _identified(
    f: np.ndarray,
    est: FRFEstimate,
    responses: list[str],
    kind_out: FRFKind,
    band: tuple[float, float] | None,
    method: str,
    *,
    together: bool,
    coherent: bool,
) -> dict:
    """``{response: ModalIdentification}`` of an FRF set's FRFs: ``together`` (one reference,
    several responses), one LSCF over all of them (common poles, the shapes checked between orders; each response keeps its own
    residues), else one identification per FRF."""
    modes = {}
    if together:
        both = identify(
            f,
            est.h1,
            kind=kind_out,
            coherence=est.coherence if coherent else None,
            f_min=band[0] if band else None,
            f_max=band[1] if band else None,
            method=method,
        )
        for i, r in enumerate(responses):
            modes[r] = replace(both, modes=[replace(m, residue=m.shape[i]) for m in both.modes])
    else:
        for i, r in enumerate(responses):
            modes[r] = identify(
                f,
                est.h1[i],
                kind=kind_out,
                coherence=est.coherence[i] if coherent else None,
                f_min=band[0] if band else None,
                f_max=band[1] if band else None,
                method=method,
            )
    return modes
