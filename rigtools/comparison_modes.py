"""Natural frequencies in a comparison: the EM modes identified in an FRF recording, paired with
the model's modes, the natural-frequency table (FEM, AM, EM) and the sentence that explains a
large harmonic difference by a natural-frequency offset."""

from __future__ import annotations

import numpy as np
import pandas as pd

from rigtools.comparison_points import is_frf_point
from rigtools.recording_analysis.broadband import analyze_broadband
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL as ACTIVE

MAX_MODE_DAMPING = 0.1  # identified "modes" more damped than this are fit artefacts
MODE_MATCH = 0.15  # an EM mode pairs with the nearest model mode within 15 %


def em_modes_from_frf(recording) -> tuple[dict, dict, list[str], dict | None]:
    """``({"active": fn}, {"active": zeta}, notes, frf)`` from the first FRF point of a recording
    with modes: the very analysis ``rig analyze`` reports of it
    (:func:`rigtools.recording_analysis.broadband.analyze_broadband`: the recording's one FRF estimate, LSCF with a
    stabilisation check); ``frf`` is that point's ``"frf"`` summary
    (:meth:`rigtools.recording_analysis.results.PointAnalysis.frf_dict`, with ``file`` and ``point``), None without
    one. The passive blade is not excited by the shaker, so only the active blade's modes are
    measured."""
    notes = []
    fns: list[float] = []
    zetas: list[float] = []
    summary = None
    procedure = str((recording.experiment or {}).get("procedure", ""))
    for point in recording.points:
        if not is_frf_point(point) or not point.complete or ACTIVE not in point.channels:
            continue
        analysed = analyze_broadband(point, procedure, responses=[ACTIVE])
        ident = analysed.frf.modes[ACTIVE]
        notes.extend(ident.notes)
        for m in ident.modes:
            if m.damping_ratio <= MAX_MODE_DAMPING:
                fns.append(m.frequency_hz)
                zetas.append(m.damping_ratio)
            else:
                notes.append(
                    f"FRF point {point.index}: a fitted pole at {m.frequency_hz:.1f} Hz with damping "
                    f"ratio {m.damping_ratio:.3f} is not taken as a mode (band edge or fit artefact)"
                )
        if fns:
            summary = {"file": str(recording.path), "point": point.index, **analysed.frf_dict()}
            break
    order = np.argsort(fns)
    return (
        {"active": np.asarray(fns)[order]} if fns else {},
        {"active": np.asarray(zetas)[order]} if fns else {},
        notes,
        summary,
    )


def _align(em: np.ndarray, model: np.ndarray) -> np.ndarray:
    """EM frequencies placed at the index of the nearest model mode (within MODE_MATCH), NaN else."""
    out = np.full(model.size, np.nan)
    for f in em:
        j = int(np.argmin(np.abs(model - f)))
        if abs(model[j] - f) <= MODE_MATCH * model[j] and not np.isfinite(out[j]):
            out[j] = f
    return out


def matched_modes(em: dict, zeta: dict, model: dict) -> tuple[dict, dict, dict]:
    """Per blade, the EM modes that pair with a model mode (nearest within MODE_MATCH) with their
    damping ratios and the paired model frequencies, ascending."""
    fn_e, z, fn_m = {}, {}, {}
    for blade, fs in em.items():
        m = np.sort(np.asarray(model.get(blade, []), dtype=float))
        if m.size == 0:
            continue
        pairs = {}
        for f, zz in zip(np.asarray(fs, dtype=float), np.asarray(zeta[blade], dtype=float), strict=True):
            j = int(np.argmin(np.abs(m - f)))
            if abs(m[j] - f) <= MODE_MATCH * m[j] and j not in pairs:
                pairs[j] = (f, zz)
        js = sorted(pairs)
        fn_e[blade] = np.array([pairs[j][0] for j in js])
        z[blade] = np.array([pairs[j][1] for j in js])
        fn_m[blade] = m[js]
    return fn_e, z, fn_m


def model_mode(fn_em: float, fn_e: dict, fn_m: dict, fn_model: dict) -> tuple[str, int, float] | None:
    """(blade, mode number, model frequency) paired with an EM natural frequency."""
    for blade, fs in fn_e.items():
        hit = np.flatnonzero(np.isclose(fs, fn_em, rtol=0, atol=1e-9))
        if hit.size:
            fm = float(fn_m[blade][hit[0]])
            n = int(np.argmin(np.abs(np.sort(fn_model[blade]) - fm))) + 1
            return blade, n, fm
    return None


def explanation_text(channel: str, e, mode: tuple[str, int, float] | None, model_label: str) -> str:
    """One line: the harmonic's model/EM ratio and the natural-frequency offset that explains it."""
    short = channel.replace("_accel", "").replace("_", " ")
    text = f"{short} {e.k}·fe = {e.frequency_hz:.1f} Hz: {model_label}/EM = x{e.observed_ratio:.2f}. "
    if mode is not None:
        blade, n, fm = mode
        text += (
            f"It lies {100 * (e.frequency_hz / e.natural_hz - 1):+.1f} % from the EM {blade} mode {n} at "
            f"{e.natural_hz:.1f} Hz, which the {model_label} puts at {fm:.1f} Hz "
            f"({100 * (fm / e.natural_hz - 1):+.2f} %): that offset alone changes this harmonic by "
            f"x{e.ratio_from_model_frequency:.2f}"
        )
    else:
        text += (
            f"It lies {100 * (e.frequency_hz / e.natural_hz - 1):+.1f} % from the model's mode at "
            f"{e.natural_hz:.1f} Hz (no EM modes measured)"
        )
    text += f"; a 1 % higher/lower natural frequency changes it by x{e.ratio_per_percent[0]:.2f}/x{e.ratio_per_percent[1]:.2f}"
    if np.isfinite(e.offset_pct_needed):
        text += f"; x{e.observed_ratio:.2f} needs a {e.offset_pct_needed:+.2f} % offset"
    else:
        text += (
            "; no single-mode offset gives the whole ratio: the rest comes from the forcing at this "
            "harmonic (compare the force rows) and the impacts"
        )
    return text


def natural_table(fem: dict, am: dict | None, em: dict, n_modes: int = 3):
    """Natural-frequency table: FEM, AM and EM per blade and mode with differences in % (EM the
    reference where measured, as the paper's Tables 2 and 3; else AM vs FEM)."""
    rows = []
    for blade in ("active", "passive"):
        f = np.sort(np.asarray(fem.get(blade, []), dtype=float))
        a = np.sort(np.asarray((am or {}).get(blade, []), dtype=float))
        e = _align(np.asarray(em.get(blade, []), dtype=float), f) if blade in em else np.full(f.size, np.nan)
        for i in range(min(n_modes, f.size)):
            fa = float(a[i]) if i < a.size else float("nan")
            row = {
                "blade": blade,
                "mode": i + 1,
                "fem_hz": float(f[i]),
                "am_hz": fa,
                "em_hz": float(e[i]),
                "fem_vs_em_pct": 100 * (f[i] - e[i]) / e[i],
                "am_vs_em_pct": 100 * (fa - e[i]) / e[i],
                "am_vs_fem_pct": 100 * (fa - f[i]) / f[i],
            }
            rows.append(row)
    return pd.DataFrame(rows)
