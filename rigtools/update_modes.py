"""The modes ``rig update`` fits to: natural frequencies and damping ratios identified in each
test recording (:func:`identify_recording`: the very FRF and modes ``rig analyze`` reports),
paired with the model's flexural modes (:func:`mode_targets`), and the linear fit
(:func:`fit_linear`: :func:`rigtools.sim.parameter_fit.update_model` with the user's errors as one
line).

Blades: a response channel whose name holds ``passive`` is the passive blade's, one holding
``active`` the active blade's. Modes come only from points that carry a broadband test: a
``frame_samples`` (one frame or burst period), the averaged window (``record_start`` in s,
``record_samples``) and a force channel; a sine dwell has none.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from rigtools.config import MAX_ROOT_ROTATIONAL_STIFFNESS as KR_MAX
from rigtools.config import MAX_ROOT_TRANSLATIONAL_STIFFNESS as KT_MAX
from rigtools.errors import UserError
from rigtools.recording import open_recording
from rigtools.recording_analysis.broadband import analyze_broadband
from rigtools.recording_analysis.frf_estimate import FRFOptions
from rigtools.recording_analysis.tap_test import analyze_tap_test, is_hit_per_point_tap_test
from rigtools.sim.parameter_fit import (
    CLAMPED_START_ROTATIONAL,
    CLAMPED_START_TRANSLATIONAL,
    PARAMETERS,
    Blade,
    ModeTarget,
    pair_modes,
    update_model,
)
from rigtools.sim.params import RootParams

# ------------------------------------------------------------------------- identified modes


@dataclass
class IdentifiedSet:
    """The modes one response of one recording shows.

    Attributes
    ----------
    recording
        File name of the recording.
    point
        Point index.
    blade
        ``"active"`` or ``"passive"``.
    response
        Response channel.
    frequencies_hz, damping_ratios
        Identified modes, ascending.
    notes
        Why fewer or none were identified (from :func:`rigtools.analysis.modal_id.identify`).
    """

    recording: str
    point: int
    blade: Blade
    response: str
    frequencies_hz: list[float]
    damping_ratios: list[float]
    notes: list[str] = field(default_factory=list)


@dataclass
class RecordingModes:
    """What :func:`identify_recording` found in one recording."""

    path: str
    procedure: str
    sets: list[IdentifiedSet]
    band: tuple[float, float] | None

    @property
    def n_modes(self) -> int:
        return sum(len(s.frequencies_hz) for s in self.sets)


def _blade_of(name: str) -> Blade | None:
    low = name.lower()
    if "passive" in low:
        return "passive"
    if "active" in low:
        return "active"
    return None


def open_test_recording(path: str | Path):
    """:func:`rigtools.recording.open_recording` with one line for a missing path or a folder."""
    p = Path(path)
    if not p.exists():
        raise UserError(f"{p}: no such recording")
    if p.is_dir():
        raise UserError(f"{p} is a directory, not a recording")
    return open_recording(p)


def identify_recording(
    path: str | Path, *, f_min: float | None = None, f_max: float | None = None, method: str = "lscf"
) -> RecordingModes:
    """Natural frequencies and damping ratios in every broadband point of a recording.

    Parameters
    ----------
    path
        HDF5 recording (schema v1).
    f_min, f_max
        Band searched, Hz (default: the test's band from the point, else the whole grid).
    method
        :func:`rigtools.analysis.modal_id.identify` method.

    Raises
    ------
    UserError
        Unreadable file, or no point holding a broadband test (a dwell, a sweep).
    """
    name = Path(path).name
    with open_test_recording(path) as rec:
        procedure = str(rec.experiment.get("procedure", "")) if isinstance(rec.experiment, dict) else ""
        status = rec.status
        sets: list[IdentifiedSet] = []
        band = None
        usable = 0
        tap_test = is_hit_per_point_tap_test(procedure, rec.points)
        if tap_test:  # one frame per accepted hit, each its own point
            sets += _tap_test_sets(name, rec, f_min, f_max, method)
            usable = 1
        for point in [] if tap_test else rec.complete_points:
            found = _broadband_point_sets(name, point, procedure, f_min, f_max, method)
            if found is not None:
                point_sets, point_band = found
                sets += point_sets
                band = point_band or band
                usable += 1
    if usable == 0:
        what = f" (a {procedure} recording)" if procedure else ""
        if status != "complete":
            what = f" ({procedure + ', ' if procedure else ''}status {status})"
        raise UserError(
            f"{name}{what} holds no complete broadband test (FRF or tap test) to identify modes "
            "from; record one with 'rig acquire frf'"
        )
    out = RecordingModes(str(path), procedure, sets, band)
    if out.n_modes == 0:
        why = "; ".join(dict.fromkeys(n for s in sets for n in s.notes)) or "no stable poles"
        raise UserError(f"{name}: no usable modes identified ({why})")
    return out


def _identified_set(name: str, index: int, blade: Blade, response: str, ident) -> IdentifiedSet:
    """The modes of one response (an :class:`rigtools.analysis.modal_id.ModalIdentification`),
    ascending."""
    modes = sorted(ident.modes, key=lambda m: m.frequency_hz)
    return IdentifiedSet(
        name,
        index,
        blade,
        response,
        [float(m.frequency_hz) for m in modes],
        [float(m.damping_ratio) for m in modes],
        list(ident.notes),
    )


def _tap_test_sets(
    name: str, rec, f_min: float | None, f_max: float | None, method: str
) -> list[IdentifiedSet]:
    """The modes of a tap test written by ``rig acquire tap`` (its hits averaged)."""
    tap = analyze_tap_test(rec.points, rec.experiment, method=method, band=(f_min, f_max))
    sets = []
    for resp, ident in tap.frf.modes.items():
        # the response's name tells its blade; else the blade the hammer hit
        blade = _blade_of(resp) or _blade_of(str(tap.params.get("blade", "")))
        if blade is None:
            raise UserError(
                f"{name}: tap response {resp!r} names no blade (active/passive) and the "
                "recording does not say which blade was hit"
            )
        sets.append(_identified_set(name, tap.index, blade, resp, ident))
    return sets


def _broadband_point_sets(
    name: str, point, procedure: str, f_min: float | None, f_max: float | None, method: str
) -> tuple[list[IdentifiedSet], tuple[float, float] | None] | None:
    """``(sets, band)`` of the modes of a point holding a broadband test (its frames, averaged
    window and a force; band None when not known), None for any other point."""
    prm = point.params
    if not {"frame_samples", "record_start", "record_samples"} <= set(prm):
        return None
    forces = [n for n, c in point.channels.items() if c.quantity == "force"]
    blade_of = {
        n: blade
        for n, c in point.channels.items()
        if c.quantity == "acceleration" and (blade := _blade_of(n)) is not None
    }
    responses = list(blade_of)
    if not forces or not responses or point.sample_rate is None:
        return None
    rate = float(point.sample_rate)
    start, n = round(float(prm["record_start"]) * rate), int(prm["record_samples"])
    frame = int(prm["frame_samples"])
    if n < frame or frame < 8 or start + n > point.n_samples:
        return None
    lo = f_min if f_min is not None else prm.get("band_low")
    hi = f_max if f_max is not None else prm.get("band_high")
    lo = None if lo is None else float(lo)
    hi = None if hi is None else min(float(hi), 0.45 * rate)
    band: tuple[float, float] | None = (lo, hi) if lo is not None and hi is not None else None
    # the recording's one FRF estimate, as rig analyze reports it
    result = analyze_broadband(
        point,
        procedure,
        method=method,
        responses=responses,
        options=FRFOptions(band=band) if band is not None else None,
    ).frf
    return [_identified_set(name, point.index, blade_of[r], r, result.modes[r]) for r in responses], band


@dataclass
class PairedMode:
    """One target and where it came from."""

    blade: str
    order: int
    frequency_hz: float
    damping_ratio: float | None
    model_hz: float
    sources: list[str]


def mode_targets(
    params,
    recordings: Sequence[RecordingModes],
    *,
    max_modes: int = 3,
    frequency_sigma: float = 1e-3,
    damping_sigma: float = 0.1,
    damping: bool = True,
) -> tuple[list, list[PairedMode], list[str]]:
    """Pair identified modes with the model's flexural modes of each blade.

    Each identified set is paired on its own (:func:`rigtools.sim.parameter_fit.pair_modes`); a (blade, order)
    seen by several sets is their mean. Orders above ``max_modes`` are left out.

    Returns
    -------
    targets, paired, notes
        :class:`rigtools.sim.parameter_fit.ModeTarget` list, the same with their sources, and lines about
        what was left out (unpaired peaks, blades without modes).
    """
    seen: dict[tuple[Blade, int], list] = {}
    model_hz: dict[tuple[Blade, int], float] = {}
    notes: list[str] = []
    for rec in recordings:
        for s in rec.sets:
            if not s.frequencies_hz:
                continue
            pairing = pair_modes(params, s.blade, s.frequencies_hz, s.damping_ratios)
            for t, fm in zip(pairing.targets, pairing.model_hz, strict=True):
                if t.order > max_modes:
                    continue
                seen.setdefault((t.blade, t.order), []).append(
                    (t.frequency_hz, t.damping_ratio, f"{s.recording}:{s.response}")
                )
                model_hz[(t.blade, t.order)] = fm
            for f in pairing.unpaired:
                notes.append(
                    f"{s.recording} {s.response}: {f:.2f} Hz matches no {s.blade} flexural mode "
                    "(within 15 %): left out"
                )
    targets, paired = [], []
    for blade, order in sorted(seen):
        vals = seen[(blade, order)]
        f = float(np.mean([v[0] for v in vals]))
        zs = [v[1] for v in vals if v[1] is not None]
        z = float(np.mean(zs)) if zs and damping else None
        targets.append(ModeTarget(blade, order, f, z, frequency_sigma, damping_sigma))
        paired.append(PairedMode(blade, order, f, z, model_hz[(blade, order)], [v[2] for v in vals]))
    for blade in ("active", "passive"):
        if not any(p.blade == blade for p in paired):
            notes.append(
                f"no {blade}-blade modes in the recordings: "
                + (
                    "the fit sees the active blade only (add a tap test of the passive blade)"
                    if blade == "passive"
                    else "add an FRF test of the active blade"
                )
            )
    return targets, paired, notes


def fit_linear(params, targets, names: Sequence[str], **kwargs):
    """:func:`rigtools.sim.parameter_fit.update_model` within what a rig file can hold; bad names or targets
    become one-line :class:`UserError`.

    Root springs stay at or below the rig file's limits (:data:`rigtools.config.MAX_ROOT_ROTATIONAL_STIFFNESS`,
    ``MAX_ROOT_TRANSLATIONAL_STIFFNESS``): a clamped root whose springs are fitted becomes springs
    at those limits first (the clamped frequencies within 1e-4), so the spring that is not fitted
    can be written, and the fitted rig file loads with exactly the fitted model.
    """
    if not targets:
        raise UserError("no identified mode pairs with a model mode: nothing to fit")
    names = list(names)
    start = dict(kwargs.pop("start", None) or {})
    bounds = dict(kwargs.pop("bounds", None) or {})
    roots = {
        "root.rotational_stiffness": (KR_MAX, CLAMPED_START_ROTATIONAL),
        "root.translational_stiffness": (KT_MAX, CLAMPED_START_TRANSLATIONAL),
    }
    if any(n in roots for n in names):
        if params.root.kind != "springs":
            params = replace(params, root=RootParams("springs", KR_MAX, KT_MAX))
            for n in names:
                if n in roots:
                    start.setdefault(n, roots[n][1])
        for n in names:
            if n in roots:
                lo, hi = bounds.get(n, PARAMETERS[n].default_bounds(start.get(n, PARAMETERS[n].get(params))))
                bounds[n] = (lo, min(hi, roots[n][0]))
    try:
        return update_model(params, targets, names, start=start or None, bounds=bounds or None, **kwargs)
    except ValueError as exc:
        raise UserError(str(exc)) from None
