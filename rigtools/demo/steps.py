"""The demo's steps, each a small function returning plain data (dicts of floats and arrays).

Every step is replaceable on its own (the coordinator swaps in ``rigtools.recording_comparison`` /
``rigtools.recording_analysis`` when they land): the modal check (:func:`modal_step`), the linear harmonic
response (:func:`harmonic_step`), the dwell (:func:`dwell_step`), the studies on the simulated rig
(:func:`rig_study_step`) and on the FEM (:func:`model_study_step`), model updating
(:func:`update_step`). Lab-measurable quantities of one record come from :func:`lab_quantities`
(force sensor, shroud accelerations, impacts per period from the accelerations).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from rigtools.analysis.harmonics import harmonic_amplitudes
from rigtools.analysis.impacts import detect_impacts
from rigtools.analysis.plots import force_zero_crossing_time
from rigtools.branches_file import read_branches, write_branches
from rigtools.config import ChannelLimitConfig
from rigtools.demo.settings import (
    BRANCH_GAP_MAX,
    DWELL_GAP,
    EQUIVALENT_RATIO,
    PAPER_FE,
    PAPER_FORCE,
    SEED_OFFSETS,
    STUDY_GAP,
    DemoSettings,
    OperatingPoint,
)
from rigtools.procedures import RigStudy, SineDwell, SteppedSine
from rigtools.procedures.frf import FrfTest
from rigtools.recording import RecordingWriter, open_recording
from rigtools.recording_analysis.broadband import analyze_broadband
from rigtools.recording_analysis.frf_estimate import FRFOptions
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL as ACTIVE
from rigtools.sim.channel_names import FORCE
from rigtools.sim.channel_names import PASSIVE_SHROUD_ACCEL as PASSIVE
from rigtools.sim.continuation import ContinuationSettings, trace
from rigtools.sim.harmonic import fem_harmonic_response, harmonic_curves
from rigtools.sim.modal import flexural_frequencies
from rigtools.sim.natural_frequencies import blade_mode_table
from rigtools.sim.parameter_fit import pair_modes, update_model
from rigtools.sim.reduction import reduced_system
from rigtools.sim.rig_model import build_rig_model
from rigtools.sim.studies import StudyPlan
from rigtools.simulation import RunSettings, iter_study_points, simulate_point, write_point

K_MAX = 30
STUDY_KINDS = ("gap", "force", "frequency")
MAX_DRIVE = 9.5  # V


# ------------------------------------------------------------------------------ the two points


def first_flexural(cfg) -> float:
    """FEM first flexural frequency of the active blade, Hz."""
    return float(flexural_frequencies(build_rig_model(cfg.to_params()).blade("active"), 1)[0])


def coupled_active_f2(cfg) -> float:
    """FEM 2nd flexural frequency of the active blade with the shaker's armature mass rigidly on
    its force sensor (as on the rig, where the stinger carries the armature), Hz."""
    from dataclasses import replace

    p = cfg.to_params()
    p = replace(p, force_sensor=replace(p.force_sensor, mass=p.force_sensor.mass + cfg.shaker.armature_mass))
    return float(flexural_frequencies(build_rig_model(p).blade("active"), 2)[1])


def free_amplitude(cfg, fe: float, force: float) -> float:
    """Linear (open-gap) displacement amplitude of the active shroud at ``fe``, ``force``, m."""
    res = fem_harmonic_response(build_rig_model(cfg.to_params()), np.array([fe]), force)
    return float(res.displacement_amplitude("active_shroud")[0])


def operating_points(cfg) -> tuple[OperatingPoint, OperatingPoint, dict]:
    """The paper's point and the equivalent impact-oscillator point (fe = 1.8 f1, F0 scaled to
    keep the free amplitude), with what defines them."""
    f1 = first_flexural(cfg)
    fe_eq = EQUIVALENT_RATIO * f1
    x_paper = free_amplitude(cfg, PAPER_FE, PAPER_FORCE)
    force_eq = PAPER_FORCE * x_paper / free_amplitude(cfg, fe_eq, PAPER_FORCE)
    paper = OperatingPoint(
        "paper", f"paper's point ({PAPER_FE:g} Hz = {PAPER_FE / f1:.2f} f1)", PAPER_FE, PAPER_FORCE
    )
    eq = OperatingPoint(
        "equivalent", f"equivalent point ({fe_eq:.1f} Hz = {EQUIVALENT_RATIO:g} f1)", fe_eq, force_eq
    )
    return (
        paper,
        eq,
        {
            "f1_hz": f1,
            "free_amplitude_m": x_paper,
            "paper_ratio": PAPER_FE / f1,
            "coupled_f2_hz": coupled_active_f2(cfg),
        },
    )


def lab_config(cfg, force: float):
    """The rig file with its [safety] limits and max drive scaled for a point driven at ``force``
    (above the paper's 15 N only). Only the safety settings change, never the rig's physics."""
    s = max(1.0, force / PAPER_FORCE)
    if s == 1.0:
        return cfg
    limits = {
        k: ChannelLimitConfig(warning=v.warning * s, abort=v.abort * s) for k, v in cfg.safety.limits.items()
    }
    # the DAQ's output range is +-10 V: stay below it
    safety = cfg.safety.model_copy(
        update={"limits": limits, "max_drive": min(MAX_DRIVE, cfg.safety.max_drive * s)}
    )
    return cfg.model_copy(update={"safety": safety})


# ------------------------------------------------------------------------------ lab quantities


def lab_quantities(
    force: np.ndarray, active: np.ndarray, passive: np.ndarray, rate: float, fe: float
) -> dict:
    """What a lab measures on one steady record: peaks of the force sensor and the shroud
    accelerometers, impacts per period (from the accelerations, :func:`rigtools.analysis.impacts.detect_impacts`)
    and the acceleration harmonics k = 1..30 (peak, m/s²)."""
    imp = detect_impacts(active, rate, fe, passive_acceleration=passive, force=force)
    k_max = int(min(K_MAX, np.floor(0.45 * rate / fe)))
    harm = {
        name: harmonic_amplitudes(x, rate, fe, k_max).amplitude.tolist()
        for name, x in ((ACTIVE, active), (PASSIVE, passive), (FORCE, force))
    }
    return {
        "force_peak_n": float(np.max(np.abs(force))),
        "active_accel_peak": float(np.max(np.abs(active))),
        "passive_accel_peak": float(np.max(np.abs(passive))),
        "impacts_per_period": float(imp.impacts_per_period),
        "impulse_level": float(imp.impulse_levels.get("passive_acceleration", 0.0)),
        "harmonics": harm,
    }


def _record_window(point) -> tuple[dict, float]:
    """The recorded steady window of a procedure point: ``({channel: samples}, rate)``."""
    rate = float(point.sample_rate)
    start = round(float(point.params.get("record_start", 0.0)) * rate)
    n = int(point.params.get("record_samples", point.n_samples - start))
    return {name: np.asarray(ch[start : start + n], dtype=float) for name, ch in point.channels.items()}, rate


def recording_points(path: str | Path) -> list[dict]:
    """Lab quantities of every complete point of a procedure recording, with its parameters."""
    out = []
    with open_recording(path) as rec:
        for point in rec.points:
            if not point.complete:
                continue
            x, rate = _record_window(point)
            fe = float(point.params["fe"])
            q = lab_quantities(x[FORCE], x[ACTIVE], x[PASSIVE], rate, fe)
            q.update(
                fe=fe,
                force=float(point.params.get("force_amplitude", np.nan)),
                gap=float(point.params.get("gap", np.nan)),
                value=float(point.params.get("study_value", np.nan)),
                force_measured=float(point.params.get("force_amplitude_measured", np.nan)),
            )
            out.append(q)
    return out


def run_quantities(run) -> dict:
    """:func:`lab_quantities` of a model run, with the model's contact force beside them."""
    o = run.outputs
    q = lab_quantities(
        o["excitation_force"],
        o["active_tip_acceleration"],
        o["passive_tip_acceleration"],
        run.sample_rate,
        run.fe,
    )
    q.update(
        fe=run.fe,
        force=run.force_amplitude,
        gap=run.gap,
        peak_contact_force_n=float(run.peak_contact_force),
        model_impacts_per_period=float(run.impacts_per_period),
        settled=bool(run.steady_state),
    )
    return q


# ------------------------------------------------------------------------------ steps


def modal_step(cfg, out_dir: Path, settings: DemoSettings) -> dict:
    """FEM and AM natural frequencies (``rig modal``) and the simulated rig's, identified from an
    FRF test (periodic chirp, gap wide open) on the active shroud: the paper's Tables 2-3, Fig 6."""
    res = blade_mode_table(cfg.to_params(), 6)
    path = out_dir / "frf_test.h5"
    FrfTest(
        cfg,
        {
            "signal": "chirp",
            "band": settings.frf_band,
            "level": 0.3,
            "frame": settings.frf_frame,
            "averages": settings.frf_averages,
            "gap": 5e-3,
            "seed": settings.seed + SEED_OFFSETS["frf"],
        },
        path,
        backend="sim",
        overwrite=True,
        seed=settings.seed + SEED_OFFSETS["frf"],
    ).run()
    with open_recording(path) as rec:  # the recording's one FRF estimate, as rig analyze reports it
        ana = analyze_broadband(
            rec.points[0],
            "frf test",
            responses=[ACTIVE],
            method="peak",
            options=FRFOptions(band=settings.frf_band),
        ).frf
    modes = ana.modes[ACTIVE].modes
    return {
        "fem": res["fem"],
        "am": res["am"],
        "em": {
            "active": [
                {"frequency_hz": float(m.frequency_hz), "damping_ratio": float(m.damping_ratio)}
                for m in modes
            ]
        },
        "frf": {
            "band": tuple(settings.frf_band),
            "frequency_hz": ana.estimate.frequency_hz,
            "h": np.abs(ana.estimate.h1[0]),
            "coherence": ana.estimate.coherence[0],
        },
        "file": str(path),
    }


def flexural(entries: list[dict]) -> list[float]:
    """Frequencies of the flexural modes of a ``rig modal`` list."""
    return [e["frequency_hz"] for e in entries if e.get("kind", "flexural") == "flexural"]


def harmonic_step(cfg, settings: DemoSettings, force: float = PAPER_FORCE) -> dict:
    """FEM and AM linear amplitude-frequency curves (the paper's Figure 7)."""
    f = np.linspace(10.0, 1500.0, settings.harmonic_points)
    fem, am = harmonic_curves(build_rig_model(cfg.to_params()), f, force)
    return {
        "frequency_hz": f,
        "fem": {loc: fem.acceleration_amplitude(loc) for loc in ("active_shroud", "passive_shroud")},
        "am": {loc: am.acceleration_amplitude(loc) for loc in ("active_shroud", "passive_shroud")},
    }


def dwell_step(
    cfg, out_dir: Path, settings: DemoSettings, point: OperatingPoint, gap: float = DWELL_GAP
) -> dict:
    """A force-controlled dwell on the simulated rig and the FEM and AM runs at the same point;
    the waveforms (last periods) and lab quantities of each (Figures 8-9)."""
    path = out_dir / f"dwell_{point.key}.h5"
    SineDwell(
        lab_config(cfg, point.force),
        {"fe": point.fe, "force": point.force, "gap": gap, "record_periods": settings.dwell_periods},
        path,
        backend="sim",
        overwrite=True,
        seed=settings.seed + SEED_OFFSETS["dwell"] + (0 if point.key == "paper" else 1),
    ).run()
    em = recording_points(path)[0]
    with open_recording(path) as rec:
        x, rate = _record_window(rec.points[0])
    out: dict[str, Any] = {
        "point": point.key,
        "fe": point.fe,
        "force": point.force,
        "gap": gap,
        "files": [str(path)],
        "em": em,
        "em_wave": _last_periods(x[FORCE], x[ACTIVE], x[PASSIVE], rate, point.fe),
    }
    run_settings = RunSettings(
        duration=settings.dwell_periods / point.fe, max_settle_time=settings.model_settle_time
    )
    model_path = out_dir / f"dwell_{point.key}_model.h5"
    with RecordingWriter(
        model_path,
        backend="model",
        rig=cfg.to_json(),
        experiment={"procedure": "demo dwell, model", "fe": point.fe, "force": point.force, "gap": gap},
        overwrite=True,
    ) as rec:
        for model in ("fem", "am"):
            _, system = load_system_cached(cfg, model)
            run = simulate_point(system.with_contact(gap=gap), point.fe, point.force, run_settings)
            write_point(rec, run, model)
            out[model] = run_quantities(run)
            o = run.outputs
            out[f"{model}_wave"] = _last_periods(
                o["excitation_force"],
                o["active_tip_acceleration"],
                o["passive_tip_acceleration"],
                run.sample_rate,
                run.fe,
                contact=o["contact_force"],
            )
    out["files"].append(str(model_path))
    return out


_SYSTEMS: dict = {}


def load_system_cached(cfg, model: str):
    """``(cfg, reduced system)`` of a rig config for ``model`` ("fem" or "am"), built once per
    process and rig (the demo runs many points on the same two systems)."""
    key = (cfg.to_json(), model)
    if key not in _SYSTEMS:
        _SYSTEMS[key] = (cfg, reduced_system(cfg.to_params(), model))
    return _SYSTEMS[key]


def _last_periods(force, active, passive, rate, fe, contact=None, periods: int = 3) -> dict:
    """The last ``periods`` whole periods, starting at an upward zero crossing of the force's
    fundamental (the common time origin of EM and model waveforms)."""
    n = round(periods * rate / fe)
    m = min(len(force), n + int(np.ceil(rate / fe)) + 1)  # one period more to find the origin
    lead = round(force_zero_crossing_time(np.asarray(force[-m:]), rate, fe) * rate)
    lead = min(lead, m - n)
    sl = slice(len(force) - m + lead, len(force) - m + lead + n)
    wave = {
        "time_s": np.arange(n) / rate,
        FORCE: np.asarray(force[sl]),
        ACTIVE: np.asarray(active[sl]),
        PASSIVE: np.asarray(passive[sl]),
    }
    if contact is not None:
        wave["contact_force"] = np.asarray(contact[sl])
    return wave


def study_plan_values(kind: str, point: OperatingPoint, settings: DemoSettings) -> dict:
    """The study of ``kind`` centred on ``point``: values and fixed parameters (SI)."""
    if kind == "gap":
        return {"values": tuple(settings.gap_values), "fe": point.fe, "force": point.force}
    if kind == "force":
        ratios = settings.force_ratios if point.key == "paper" else settings.equivalent_force_ratios
        return {"values": tuple(round(r * point.force, 6) for r in ratios), "fe": point.fe, "gap": STUDY_GAP}
    # the same relative sweep (60..76 Hz is 1..1.27 fe) at both points
    ratios = settings.frequency_ratios
    return {"values": tuple(round(r * point.fe, 4) for r in ratios), "force": point.force, "gap": STUDY_GAP}


def rig_study_step(
    cfg,
    out_dir: Path,
    settings: DemoSettings,
    kind: str,
    point: OperatingPoint,
    progress: Callable[[str], None] | None = None,
) -> dict:
    """A gap, force or frequency study measured on the simulated rig (force-controlled
    :class:`rigtools.procedures.RigStudy`), each point reduced to lab quantities."""
    plan = study_plan_values(kind, point, settings)
    path = out_dir / f"study_{kind}_{point.key}_rig.h5"
    top_force = max(plan["values"]) if kind == "force" else point.force

    def on_event(ev) -> None:
        if progress is not None and ev.kind == "point":
            progress(f"rig {kind} study, {point.key} point: {ev.point}/{ev.n_points}")

    RigStudy(
        lab_config(cfg, top_force),
        {"kind": kind, "record_periods": settings.study_periods, **plan},
        path,
        backend="sim",
        overwrite=True,
        progress=on_event,
        seed=settings.seed
        + SEED_OFFSETS["study"]
        + 10 * STUDY_KINDS.index(kind)
        + (0 if point.key == "paper" else 1),
    ).run()
    return {"kind": kind, "point": point.key, "file": str(path), "points": recording_points(path)}


def model_study_step(cfg, out_dir: Path, settings: DemoSettings, kind: str, point: OperatingPoint) -> dict:
    """The same study on the FEM (:func:`rigtools.simulation.iter_study_points`), each point
    written to a recording and reduced to the same lab quantities, with the contact force."""
    prm = study_plan_values(kind, point, settings)
    plan = StudyPlan(kind, prm.pop("values"), "up", **prm)
    _, system = load_system_cached(cfg, "fem")
    fe_min = min(p.fe for p in plan.points())
    rs = RunSettings(duration=settings.study_periods / fe_min, max_settle_time=settings.model_settle_time)
    path = out_dir / f"study_{kind}_{point.key}_fem.h5"
    pts = []
    with RecordingWriter(
        path,
        backend="model",
        rig=cfg.to_json(),
        experiment={"procedure": "demo model study", "plan": plan.to_dict()},
        overwrite=True,
    ) as rec:
        for planned, run in iter_study_points(system, plan, rs):
            write_point(rec, run, "fem", direction=planned.direction, study_value=planned.value)
            q = run_quantities(run)
            q["value"] = planned.value
            pts.append(q)
    return {"kind": kind, "point": point.key, "file": str(path), "points": pts}


def sweep_step(cfg, out_dir: Path, settings: DemoSettings, point: OperatingPoint) -> dict:
    """The simulated rig's force-controlled stepped sine up and down (``rig acquire sweep``,
    :class:`rigtools.procedures.SteppedSine`) over the frequency study's range at its gap, in
    ``settings.sweep_step`` steps: the measured jumps the FEM's frequency branch explains."""
    values = study_plan_values("frequency", point, settings)["values"]
    lo, hi = min(values), max(values)
    n = round((hi - lo) / settings.sweep_step)
    path = out_dir / f"sweep_{point.key}_rig.h5"
    SteppedSine(
        lab_config(cfg, point.force),
        {
            "frequencies": tuple(round(lo + i * (hi - lo) / n, 4) for i in range(n + 1)),
            "force": point.force,
            "gap": STUDY_GAP,
            "direction": "both",
            "record_periods": settings.study_periods,
        },
        path,
        backend="sim",
        overwrite=True,
        seed=settings.seed + SEED_OFFSETS["sweep"],
    ).run()
    return {"file": str(path)}


# the gap branch's steps: a 25th of the range from the start (the default, a fiftieth reached
# from a fifth of it, switches at the doubling at 2.39 mm onto period-2 branches that merge back
# after a few points, missing the stable period-2 orbit that runs down to 0.3 mm)
GAP_BRANCH_STEP = 0.04


def branches_step(cfg, out_dir: Path, settings: DemoSettings, point: OperatingPoint) -> dict:
    """The FEM's branches at ``point`` (:func:`rigtools.sim.continuation.trace`), each written as
    a branch file (:func:`rigtools.branches_file.write_branches`, what ``rig continuation`` writes)
    and read back: ``{"frequency": ..., "gap": ...}``, each ``{"file", "experiment",
    "branches"}``. In frequency over the frequency study's range at its gap (period 1: the fold
    where the impacting orbit ends, the grazing corner where it begins); in gap from the gap
    study's first gap to :data:`BRANCH_GAP_MAX` with the period-2 branches of its doublings."""
    _, system = load_system_cached(cfg, "fem")
    fe_values = study_plan_values("frequency", point, settings)["values"]
    gap0 = min(settings.gap_values)
    runs = {  # kind: (param, from, to, fixed gap, period-2 branches, step settings)
        "frequency": ("fe", min(fe_values), max(fe_values), STUDY_GAP, False, None),
        "gap": (
            "gap",
            gap0,
            BRANCH_GAP_MAX,
            gap0,
            True,
            ContinuationSettings(initial_step=GAP_BRANCH_STEP, max_step=GAP_BRANCH_STEP),
        ),
    }
    out = {}
    for kind, (param, start, stop, gap, switch, steps) in runs.items():
        branches = trace(
            system, param, start, stop, fe=point.fe, force=point.force, gap=gap, switch=switch, settings=steps
        )
        experiment = {
            "procedure": "continuation",
            "param": param,
            "from": start,
            "to": stop,
            "fe": point.fe,
            "force": point.force,
            "gap": gap,
            "model": "fem",
            "measured": [],
        }
        path = write_branches(
            out_dir / f"branches_{kind}_{point.key}.h5", branches, cfg.to_json(), experiment
        )
        experiment, stored = read_branches(path)
        out[kind] = {"file": str(path), "experiment": experiment, "branches": stored}
    return out


def update_step(cfg, em_active: list[float]) -> dict:
    """Model updating on the FRF-identified modes of the active blade: the root's rotational
    stiffness (the simulated rig's root is bolted, the model's clamped) fitted to them;
    frequencies before and after."""
    params = cfg.to_params()
    pairing = pair_modes(params, "active", em_active, frequency_sigma=5e-3)
    if not pairing.targets:
        return {"names": [], "modes": [], "note": "no identified mode paired with the model"}
    res = update_model(params, pairing.targets, ["root.rotational_stiffness"])
    return {
        "names": res.names,
        "fitted": res.fitted,
        "initial": res.initial,
        "modes": [
            {
                "mode": f"{m.target.blade} f{m.target.order}",
                "measured_hz": m.target.frequency_hz,
                "before_hz": m.before_hz,
                "after_hz": m.after_hz,
            }
            for m in res.modes
        ],
    }
