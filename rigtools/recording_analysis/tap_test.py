"""A tap (impact-hammer) test written by ``rig acquire tap``: one frame per hit, each its own
point; the accepted hits averaged with the hammer as the force, and the modes they support."""

from __future__ import annotations

import numpy as np

from rigtools.analysis.frf import FRFKind, FRFMethod
from rigtools.analysis.point import analyze_frf_test
from rigtools.errors import UserError
from rigtools.recording_analysis.results import PointAnalysis, frf_kind, frf_kind_of_units

TAP_DEFAULT_PULSE_S = 0.5e-3  # hammer pulse when the recording does not say
TAP_F_MIN_HZ = 5.0


def is_hit_per_point_tap_test(procedure: str, points) -> bool:
    """True for a tap test written by ``rig acquire tap``: one frame per hit, each its own point
    (``frame_samples`` and ``accepted`` per point). A tap record holding several hits in one point
    goes through :func:`rigtools.recording_analysis.broadband.analyze_broadband` instead."""
    return procedure == "tap test" and any(
        "frame_samples" in p.params and "accepted" in p.params for p in points
    )


def analyze_tap_test(
    points,
    experiment: dict,
    *,
    kind: str = "accelerance",
    method: str = "lscf",
    band: tuple[float | None, float | None] | None = None,
    response: str | None = None,
    n_modes: int | None = None,
) -> PointAnalysis:
    """H1/H2/Hv, coherence and modes of a tap (impact-hammer) test: one frame per accepted hit,
    each its own point (``rig acquire tap``), averaged together with the hammer as the force
    (rectangular window; the impact estimate of :class:`rigtools.analysis.frf.FRFMethod`).

    ``band`` is ``(f_min, f_max)`` of the identification, either None for its default: from
    :data:`TAP_F_MIN_HZ` to the hammer pulse's reach ``1 / pulse``. ``response`` defaults to the
    recording's ``response``, else the hit blade's shroud accelerometer.
    """
    hammer = str(experiment.get("hammer_channel") or "hammer")
    accepted = [
        p
        for p in points
        if p.complete
        and p.params.get("accepted", False)
        and hammer in p.channels
        and p.n_samples >= int(p.params.get("frame_samples", 0))
    ]
    if len(accepted) < 2:
        raise UserError(
            f"a tap test needs at least two accepted hits to average; this one has {len(accepted)}"
        )
    first = accepted[0]
    response, measured = _tap_response(first, experiment, response, hammer)
    if first.sample_rate is None:
        raise UserError(f"tap test: point {first.index} has channels at different sample rates")
    rate = float(first.sample_rate)
    frame = int(first.params["frame_samples"])
    units = {hammer: first.channels[hammer].units, response: first.channels[response].units}
    blocks = (
        {
            "force": np.asarray(p.channels[hammer][:frame], dtype=float),
            response: np.asarray(p.channels[response][:frame], dtype=float),
        }
        for p in accepted
    )
    # a hammer pulse of duration T excites up to about 1/T: identify within that band (2 kHz for
    # the 0.5 ms default pulse, the same band `rig acquire tap` uses)
    pulse = float((experiment.get("parameters") or {}).get("pulse") or TAP_DEFAULT_PULSE_S)
    f_min, f_max = band or (None, None)
    f_min = TAP_F_MIN_HZ if f_min is None else f_min
    f_max = min(1.0 / pulse, 0.45 * rate) if f_max is None else f_max
    frf_method = FRFMethod(
        "impact",
        frame,
        tuple(0 for _ in accepted),
        reason="rig acquire tap: one recorded frame per accepted hit",
    )
    try:
        res = analyze_frf_test(
            blocks,
            rate,
            frf_method=frf_method,
            responses=(response,),
            force="force",
            measured=measured,
            kind=frf_kind(kind),
            method=method,
            f_min=f_min,
            f_max=f_max,
            n_modes=n_modes,
        )
    except ValueError as exc:  # a band the FRF cannot be identified over
        raise UserError(f"tap test: {exc}") from None
    notes = [
        (
            f"tap test: {len(accepted)} accepted hits of {len(points)} averaged (H1 of {response} over "
            f"{hammer}, rectangular window of {frame} samples per hit)"
        )
    ]
    for r, m in res.modes.items():
        notes.extend(f"{r}: {t}" for t in m.notes)
    return PointAnalysis(
        first.index,
        "broadband",
        dict(first.params),
        units,
        rate,
        (0, frame),
        frf=res,
        excitation="impact",
        notes=notes,
    )


def _tap_response(first, experiment: dict, response: str | None, hammer: str) -> tuple[str, FRFKind]:
    """The response of a tap test (given, else the recording's ``response``, else the hit blade's
    shroud accelerometer) and the FRF kind it measures; one line when there is none."""
    response = (
        response
        or experiment.get("response")
        or next(
            (
                c
                for c in ("passive_shroud_accel", "active_shroud_accel")
                if c in first.channels and c.startswith(str(first.params.get("blade", "")))
            ),
            None,
        )
    )
    if response is None or response not in first.channels:
        raise UserError(
            f"tap test: no response channel {response or ''} beside {hammer} "
            f"(channels: {', '.join(first.channels)})"
        )
    measured = frf_kind_of_units(first.channels[response].units)
    if measured is None:
        raise UserError(
            f"tap test: the response {response} is not an acceleration, velocity or displacement "
            f"({first.channels[response].units})"
        )
    return response, measured
