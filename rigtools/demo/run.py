"""The whole demo: every step in order, the findings, the report (:func:`run_demo`).

Swap points (each a single call below, its data shape documented in :mod:`rigtools.demo.steps`):

* ``steps.recording_points`` (offline reduction of a recording to lab quantities) -> the
  per-point analysis of ``rigtools.recording_analysis`` when it lands;
* the dwell's EM-vs-FEM comparison (``steps.dwell_step`` + ``report.waveform_figure`` /
  ``spectrum_figure``) -> ``rigtools.recording_comparison.compare_recordings(...).add_to_report(section)``;
* ``steps.update_step`` -> the ``rig update`` library call (same targets: the FRF-identified modes);
* ``steps.modal_step``'s EM column -> add the passive blade from the passive-blade tap test.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from rigtools import json_values
from rigtools.analysis.branches import turning_points
from rigtools.branches_figure import branch_curves
from rigtools.config import load_rig
from rigtools.demo import steps
from rigtools.demo.findings import evaluate
from rigtools.demo.report import build_report, gap_trend_figure
from rigtools.demo.settings import DemoSettings
from rigtools.errors import UserError
from rigtools.recording.lock import LockBusy, WriterLock
from rigtools.report import write_report
from rigtools.report.html import figure_png

STUDIES = steps.STUDY_KINDS
MARKER = ".rig-demo"  # written first into a demo's folder: a later demo may replace its files


def n_steps(settings: DemoSettings | None = None) -> int:
    """Steps :func:`run_demo` reports through ``progress`` (for a progress bar)."""
    return 5 + 2 + 2 * len(STUDIES) + 1 + (2 if settings is None or settings.branches else 0)


def run_demo(
    out_dir: str | Path, settings: DemoSettings, progress: Callable[[str], None] | None = None, cfg=None
) -> dict:
    """Run the demo into ``out_dir``: recordings, ``report.html``; returns its data, the findings
    and the report's path. ``progress(text)`` is called as each step starts.

    One demo writes a folder at a time: the writer lock of the folder's marker (the recordings'
    lock, :mod:`rigtools.recording.lock`) is held for the whole run; a second demo into the same
    folder is refused in one line (:class:`rigtools.UserError`) before it touches anything.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    lock = WriterLock(out / MARKER)
    try:
        lock.acquire()
    except LockBusy as busy:
        raise UserError(
            f"--out {out}: being written by another demo ({busy.holder}); give another folder"
        ) from None
    try:
        return _run_demo(out, settings, progress, cfg)
    finally:
        lock.release()


def _run_demo(out: Path, settings: DemoSettings, progress: Callable[[str], None] | None, cfg) -> dict:
    say = progress or (lambda text: None)
    (out / MARKER).write_text(f"written by rig demo ({settings.name})\n", encoding="utf-8")
    cfg = cfg if cfg is not None else load_rig(None)
    say("operating points")
    paper, eq, info = steps.operating_points(cfg)
    points = {"paper": paper, "equivalent": eq}
    say("modal check: FEM, AM and an FRF test on the simulated rig")
    modal = steps.modal_step(cfg, out, settings)
    say("harmonic response, FEM vs AM")
    harmonic = steps.harmonic_step(cfg, settings)
    say("model updating on the identified modes")
    update = steps.update_step(cfg, [m["frequency_hz"] for m in modal["em"]["active"]])
    files = [modal["file"]]
    dwell = {}
    for key, pt in points.items():
        say(f"dwell at the {key} point ({pt.fe:.4g} Hz, {pt.force:.4g} N): rig, FEM, AM")
        dwell[key] = steps.dwell_step(cfg, out, settings, pt)
        files += dwell[key]["files"]
    studies = {}
    for key, pt in points.items():
        for kind in STUDIES:
            say(f"{kind} study at the {key} point: rig and FEM")
            rig = steps.rig_study_step(cfg, out, settings, kind, pt)
            fem = steps.model_study_step(cfg, out, settings, kind, pt)
            studies[(kind, key)] = {"rig": rig, "fem": fem}
            files += [rig["file"], fem["file"]]
    branches = {}
    sweep = None
    if settings.branches:
        say("stepped sine up and down on the simulated rig at the paper's point")
        sweep = steps.sweep_step(cfg, out, settings, paper)
        files.append(sweep["file"])
        say("the FEM's branches at the paper's point: frequency (fold) and gap (period doubling)")
        branches = steps.branches_step(cfg, out, settings, paper)
    say("findings and report")
    data = {
        "settings": settings.name,
        "info": info,
        "points": points,
        "modal": modal,
        "harmonic": harmonic,
        "dwell": dwell,
        "studies": studies,
        "update": update,
        "files": files,
        "branches": branches,
        "sweep": sweep,
        "safety_note": (
            f"At the equivalent point the simulated rig runs with its [safety] limits and max "
            f"drive scaled by F0/15 N (max drive at most {steps.MAX_DRIVE:g} V, inside the "
            "DAQ's ±10 V); the rig's physics is the calibrated default rig's."
        ),
    }
    findings = evaluate(data)
    report = write_report(build_report(data, findings, out), out / "report.html")
    (out / "findings.json").write_text(
        json_values.dumps(
            findings_doc(findings, report, files, relative_to=out, branches=branches), indent=1
        ),
        encoding="utf-8",
    )
    save_png(gap_trend_figure(data), out / "gap-trend.png")
    return {"data": data, "findings": findings, "report": report}


def findings_doc(
    findings, report: Path, files: list[str], relative_to: Path | None = None, branches: dict | None = None
) -> dict:
    """The ``--json`` document (also written as ``findings.json``, with the file names relative to
    the demo's folder, so two demos into two folders write the same document). ``branches``:
    the branch files (``rig continuation``'s kind) of :func:`rigtools.demo.steps.branches_step`
    and their turning points and period doublings."""

    def name(path: str | Path) -> str:
        return str(Path(path).relative_to(relative_to)) if relative_to is not None else str(path)

    def marks(stored) -> dict:
        curves = branch_curves(stored)
        return {
            "turning_points": [
                {"label": t.label, "value": t.value, "upper": t.upper, "branch": t.branch}
                for c in curves
                for t in turning_points(c)
            ],
            "period_doublings": [
                float(v)
                for b in stored
                if b.periods == 1
                for v, labs in zip(b.value, b.labels, strict=True)
                if "period-doubling" in labs
            ],
            "status": [b.status for b in stored],
            # every labelled bifurcation and event with its critical multiplier and its location
            # at a converged time step (rigtools.sim.bifurcations.Bifurcation.as_dict)
            "located": [{**r, "periods": b.periods} for b in stored for r in b.bifurcations],
        }

    return {
        "report": name(report),
        "files": [name(f) for f in files],
        "branches": {
            k: {"file": name(b["file"]), **marks(b["branches"])} for k, b in (branches or {}).items()
        },
        "findings": [f.to_dict() for f in findings],
    }


def save_png(fig, path: Path) -> Path:
    """Write a figure as PNG (closed afterwards)."""
    data, _, _ = figure_png(fig)
    path.write_bytes(data)
    return path
