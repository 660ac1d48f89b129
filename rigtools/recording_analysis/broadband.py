"""A broadband point (an FRF test, a tap or impact record, a free decay, a random test written
elsewhere): H1, H2, Hv and coherence of every response over the force through the one FRF estimate
(:mod:`rigtools.recording_analysis.frf_estimate`), and the modes the data support."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rigtools.analysis.point import analyze_frf_test
from rigtools.errors import UserError
from rigtools.recording_analysis.frf_estimate import FRFOptions, point_frf
from rigtools.recording_analysis.results import PointAnalysis, frf_kind
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL, PASSIVE_SHROUD_ACCEL
from rigtools.sim.channel_names import BLADE_OF as _BLADE_OF

PROCEDURE_FRF = ("frf test",)
PASSIVE_NOT_EXCITED = (
    "the passive blade was not excited: the shaker drives the active blade, and with the gap open "
    "no force reaches the passive one, so it shows no modes here (identify them with a tap test: "
    "rig acquire tap --blade passive)"
)
BLADE_OF = {c: _BLADE_OF[c] for c in (ACTIVE_SHROUD_ACCEL, PASSIVE_SHROUD_ACCEL)}


def analyze_broadband(
    point,
    procedure: str,
    *,
    kind: str = "accelerance",
    method: str = "lscf",
    responses: Sequence[str] | None = None,
    options: FRFOptions | None = None,
) -> PointAnalysis:
    """H1/H2/Hv, coherence and modes of a broadband point (FRF test, tap test, free decay,
    impact test or random test written elsewhere)."""
    options = options or FRFOptions()
    rate = float(point.sample_rate)
    force, resp, measured, frf_method, (start, n), blocks = point_frf(
        point, responses=responses, options=options
    )
    units = {c: point.channels[c].units for c in [force, *resp]}
    notes = [f"FRF: {frf_method.describe(rate)}"]
    if frf_method.excitation == "impact" and len(frf_method.frame_starts) < 2:
        notes.append("one hit: no coherence (it needs two or more averages)")
    lo, hi = options.band if options.band else (point.params.get("band_low"), point.params.get("band_high"))
    try:
        res = analyze_frf_test(
            blocks,
            rate,
            frf_method=frf_method,
            responses=resp,
            force=force,
            measured=measured,
            kind=frf_kind(kind),
            f_min=lo,
            f_max=hi,
            method=method,
        )
    except ValueError as exc:
        raise UserError(f"point {point.index}: {exc}") from None
    params = dict(point.params)
    first = next(iter(res.modes.values()), None)
    if first is not None and first.band is not None:
        params["band_low"], params["band_high"] = first.band
        if options.band is None and point.params.get("band_low") is None:
            notes.append(
                f"band {first.band[0]:.4g}-{first.band[1]:.4g} Hz: where the force spectrum has energy"
            )
    band = (res.estimate.frequency_hz >= params.get("band_low", 0.0)) & (
        res.estimate.frequency_hz <= params.get("band_high", np.inf)
    )
    for i, (r, m) in enumerate(res.modes.items()):
        coh = float(np.mean(res.estimate.coherence[i][band]))
        if coh < 0.5 and BLADE_OF.get(r) == "passive":
            notes.append(f"{r}: {PASSIVE_NOT_EXCITED} (mean coherence with the force {coh:.2f} in the band)")
        elif coh < 0.5:
            notes.append(
                f"{r}: mean coherence {coh:.2f} in the band: this response hardly follows the "
                "force (a blade the force does not reach needs its own tap/hammer test)"
            )
        notes.extend(f"{r}: {t}" for t in m.notes)
    out = PointAnalysis(
        point.index,
        "broadband",
        params,
        units,
        rate,
        (start, n),
        frf=res,
        excitation=frf_method.excitation,
        notes=notes,
    )
    return out
