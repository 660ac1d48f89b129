"""The two sides of a comparison (:func:`rigtools.recording_comparison.compare_recordings`) read
and paired: the EM recording's periodic points (and its modes, from its FRF points or an FRF
recording), the model (its reduced system and natural frequencies) and the model's points, from a
model recording (paired by fe, gap and force target) or run at the EM points."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rigtools.analysis.correlation import pair_points
from rigtools.comparison_modes import em_modes_from_frf, natural_table
from rigtools.comparison_points import (
    FORCE,
    em_point_analysis,
    is_frf_point,
    model_point_analysis,
    model_run_analysis,
    too_short,
)
from rigtools.comparison_runs import Progress, simulate_em_points
from rigtools.errors import UserError, option
from rigtools.recording import open_recording
from rigtools.recording.schema import RecordingError
from rigtools.sim.natural_frequencies import reduced_natural_frequencies as natural_frequencies
from rigtools.sim.reduction import reduced_system
from rigtools.simulation import force_fundamental, load_system
from rigtools.vocabulary import MODEL_BACKENDS, current_parameters, excitation_frequency

#: a compared point: ``(index, params, DwellAnalysis, {channel: samples}, sample rate)``
Item = tuple[int, dict, Any, dict, float]


@dataclass
class EmSide:
    """What a comparison takes from the EM recording.

    Attributes
    ----------
    items
        The compared periodic points (:data:`Item`), in the recording's order.
    kind
        The swept parameter of the EM study (``"gap"``, ``"force"``, ``"frequency"``) or None.
    carry_state
        Whether the EM study carried the state from point to point (model runs do the same).
    modes, zeta
        ``{"active": natural frequencies Hz}`` and damping ratios identified from FRF points
        (empty without).
    frf
        The FRF point the modes come from, as ``rig analyze --json`` shows it, or None.
    rig
        The rig for the model: the ``--rig`` file's text or the recording's rig description.
    """

    items: list[Item]
    kind: str | None
    carry_state: bool
    modes: dict
    zeta: dict
    frf: dict | None
    rig: Any


def read_em_side(em_path: str, frf: str | None, rig: str | None, k_max: int, notes: list[str]) -> EmSide:
    """The EM recording's compared points and modes (an FRF recording ``frf`` gives the modes when
    given); what is left out is said in ``notes``."""
    with _open(em_path, "EM recording") as rec:
        if rec.backend in MODEL_BACKENDS:
            raise UserError(
                f"{em_path} is a model recording (backend {rec.backend}): give the EM (rig) recording first"
            )
        kind = _study_kind(rec)
        carry = _carry_state(rec)
        items = _em_items(rec, k_max, notes)
        if not items:
            raise UserError(f"{em_path} holds no complete periodic (dwell, sweep, study) point to compare")
        em_modes, em_zeta, mode_notes, em_frf = em_modes_from_frf(rec)
        if not em_modes and frf is None:
            notes.append(
                f"{Path(em_path).name} holds no FRF data: no measured (EM) natural frequencies; "
                f"give {option('frf', 'FRF.h5')} (an FRF test: rig acquire frf, rigtools.frf_test) "
                "for the EM column"
            )
        try:
            rig_cfg_text = rig if rig is not None else rec.rig_config()
        except Exception as exc:  # noqa: BLE001 - a damaged rig attribute
            raise UserError(
                f"{em_path}: its rig description cannot be read ({exc}); give {option('rig', 'FILE')}"
            ) from None
    if frf is not None:
        with _open(frf, "FRF recording") as frec:
            em_modes, em_zeta, mode_notes, em_frf = em_modes_from_frf(frec)
        if not em_modes:
            notes.append(f"{Path(frf).name}: no modes identified from its FRF points")
    notes.extend(mode_notes)
    return EmSide(items, kind, carry, em_modes, em_zeta, em_frf, rig_cfg_text)


def _em_items(rec, k_max: int, notes: list[str]) -> list[Item]:
    """The complete periodic points of an EM recording, analysed over their settled windows."""
    dwell_points = [p for p in rec.points if not is_frf_point(p)]
    skipped = [p.index for p in dwell_points if not p.complete]
    notes.extend(f"EM: {n}" for n in rec.notes)  # what a damaged file read with --skip-damaged left out
    if skipped:
        notes.append(f"EM points {skipped} were cut off (not complete) and are left out")
    items = []
    for p in dwell_points:
        if not p.complete:
            continue
        params = current_parameters(p.params)
        if not excitation_frequency(params):
            notes.append(
                f"EM point {p.index}: "
                + ("fe = 0 (no single excitation frequency)" if "fe" in params else "no fe")
                + ", left out"
            )
            continue
        if (short := too_short(p, k_max, "EM")) is not None:
            notes.append(short)
            continue
        ana, waves, fs = em_point_analysis(p, k_max)
        if FORCE not in ana.harmonics:
            raise UserError(f"EM point {p.index} has no force channel")
        if params.get("settled") is False:
            notes.append(f"EM point {p.index} was not settled when recorded")
        items.append((p.index, params, ana, waves, fs))
    return items


def model_system(rig: Any, model: str, em_modes: dict) -> tuple[Any, dict, Any]:
    """``(reduced system of model, its natural frequencies {blade: Hz}, natural-frequency table)``
    of the rig (a rig file's text or a rig description); the table holds FEM, AM and EM."""
    other_model = "am" if model == "fem" else "fem"
    if isinstance(rig, str):
        _, system = load_system(rig, model)
        _, other = load_system(rig, other_model)
    else:
        system = reduced_system(rig.to_params(), model)
        other = reduced_system(rig.to_params(), other_model)
    fn_model = natural_frequencies(system)
    fn_other = natural_frequencies(other)
    fem_fn, am_fn = (fn_model, fn_other) if model == "fem" else (fn_other, fn_model)
    return system, fn_model, natural_table(fem_fn, am_fn, em_modes)


def simulated_side(
    system,
    em: EmSide,
    excitation: str,
    *,
    k_max: int,
    workers: int | None,
    max_settle_time: float,
    progress: Progress | None,
    notes: list[str],
) -> tuple[list[Item], list[tuple[int, int]]]:
    """``(model items, pairs)`` of model runs at the EM points (``rig compare --simulate``): one
    run per EM point, paired with it."""
    runs = simulate_em_points(
        system,
        [(it[1], it[2]) for it in em.items],
        excitation,
        carry_state=em.carry_state,
        workers=workers,
        max_settle_time=max_settle_time,
        progress=progress,
    )
    items = []
    for i, run in enumerate(runs):
        ana, waves, fs = model_run_analysis(run, k_max)
        params = {
            "fe": run.fe,
            "gap": run.gap,
            "force_amplitude": run.force_amplitude,
            "force_amplitude_measured": force_fundamental(run),
            "settled": bool(run.steady_state),
        }
        if not run.steady_state:
            notes.append(
                f"the model run at EM point {em.items[i][0]} did not settle within "
                f"{max_settle_time:g} s simulated"
            )
        items.append((i, params, ana, waves, fs))
    return items, [(i, i) for i in range(len(em.items))]


def recorded_side(
    fem_path: str, em_items: list[Item], *, k_max: int, notes: list[str]
) -> tuple[list[Item], list[tuple[int, int]]]:
    """``(model items, pairs)`` of a model recording: its periodic points, each EM point paired
    with the model point of the same fe, gap and force target."""
    items = []
    with _open(fem_path, "model recording") as mrec:
        notes.extend(f"model: {n}" for n in mrec.notes)
        if mrec.backend not in MODEL_BACKENDS:
            notes.append(f"{Path(fem_path).name} was written by backend {mrec.backend!r}, not a model run")
        for p in mrec.points:
            if not p.complete or is_frf_point(p):
                continue
            params = current_parameters(p.params)
            if not excitation_frequency(params):
                if "fe" in params:
                    notes.append(f"model point {p.index}: fe = 0 (no single excitation frequency), left out")
                continue
            if (short := too_short(p, k_max, "model")) is not None:
                notes.append(short)
                continue
            ana, waves, fs = model_point_analysis(p, k_max)
            items.append((p.index, params, ana, waves, fs))
    pairs = pair_points([_pair_key(it[1]) for it in em_items], [_pair_key(it[1]) for it in items])
    return items, pairs


def no_pairs_error(em_path: str, model_items: list[Item]) -> UserError:
    """The one line when no EM point has a model point: what the model file holds."""
    have = sorted(
        {
            (
                round(it[1].get("fe", np.nan), 6),
                round(it[1].get("gap", np.nan) * 1e3, 6),
                round(it[1].get("force_amplitude", np.nan), 6),
            )
            for it in model_items
        }
    )
    return UserError(
        f"no EM point of {Path(em_path).name} has a model point with the same fe, gap and "
        f"force target (within 2 %); the model file holds (fe Hz, gap mm, F0 N) = "
        f"{', '.join(str(h) for h in have[:5]) or 'no periodic point'}"
    )


def _open(path: str, what: str):
    try:
        return open_recording(path)
    except RecordingError as exc:
        raise UserError(f"{what}: {exc}") from None
    except OSError as exc:
        raise UserError(f"{what} {path}: {exc.strerror or exc}") from None


def _pair_key(params: dict) -> dict:
    out = {}
    for key, name in (("fe", "fe"), ("gap", "gap"), ("force_amplitude_target", "force_amplitude")):
        if params.get(name) is not None:
            out[key] = float(params[name])
    return out


def _study_kind(recording) -> str | None:
    exp = recording.experiment or {}
    par = exp.get("parameters") or {}
    kind = (par.get("plan") or {}).get("kind") or par.get("kind")
    if kind in ("gap", "force", "frequency"):
        return kind
    # a model study or any multi-point file: the parameter that varies
    pts = [current_parameters(p.params) for p in recording.points if p.complete and not is_frf_point(p)]
    for key, k in (("gap", "gap"), ("force_amplitude", "force"), ("fe", "frequency")):
        vals = {round(float(p[key]), 12) for p in pts if p.get(key) is not None}
        if len(vals) > 1:
            return k
    return None


def _carry_state(recording) -> bool:
    par = (recording.experiment or {}).get("parameters") or {}
    return bool((par.get("plan") or {}).get("carry_state", True))
