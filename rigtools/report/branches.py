"""The model's continued branches in the HTML report, where they explain measured jumps.

:func:`add_branches` puts into a report section what a branch file says about a measured sweep:
one or two sentences per measured jump (the mechanism by which the sweep leaves the branch it
followed and how far from the jump; the nearest turning point), the figure (:func:`rigtools.branches_figure.branches_figure`: stable solid, unstable dashed,
bifurcations labelled, the measured up/down steps on the same axes, their jumps shaded), and two
tables (the branches' bifurcations; the jumps against the turning points) holding the numbers
the sentences quote. ``rig report --branches`` (:func:`load_branch_files`,
:func:`add_recording_branches`, :func:`add_unmatched_branches`) and ``rig demo`` use it.

A branch file is drawn over a recording only if the recording describes the rig the branches
were continued for: not an imported recording (``rig import``), the same model from its rig
description, the same fixed quantities (within :data:`FIXED_TOLERANCE`); otherwise a note says
why (``rig continuation --measured`` overlays any recording when asked to).
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from rigtools.analysis.branches import SHORT, explain_jumps, turning_points
from rigtools.branches_figure import branch_curves, branches_figure
from rigtools.branches_file import POINT_PARAM, X_LABELS, X_UNITS, StoredBranch, read_branches
from rigtools.config import parse_rig
from rigtools.errors import UserError
from rigtools.measured_sweeps import measured_sweeps
from rigtools.recording import open_recording
from rigtools.recording_analysis.dispatch import is_foreign
from rigtools.recording_analysis.results import RecordingAnalysis
from rigtools.vocabulary import FEM

FIXED_TOLERANCE = 0.02  # relative: a recording's fixed fe / force / gap against the branches'
KIND_PARAM = {"frequency": "fe", "gap": "gap", "force": "force"}  # study_axis kind -> branch param
FIXED_NAMES = {"fe": "fe", "force": "F0", "gap": "gap"}
LABEL_WORDS = {"fold": "fold (LP)", "grazing": "grazing corner (G: impacts begin or end there)"}


def study_axis(analysis: RecordingAnalysis) -> tuple[str, np.ndarray] | None:
    """``(kind, values)`` of the swept parameter of a study or stepped sine, SI."""
    pts = analysis.periodic
    if len(pts) < 2:
        return None
    proc = analysis.procedure
    for kind in ("gap", "force", "frequency"):
        if proc.startswith(kind) and all("study_value" in p.params for p in pts):
            return kind, np.array([float(p.params["study_value"]) for p in pts])
    for kind, key in (("frequency", "fe"), ("gap", "gap"), ("force", "force_amplitude")):
        vals = [float(v) for p in pts if (v := p.params.get(key)) is not None]
        if len(vals) == len(pts) and len({round(v, 12) for v in vals}) > 1:
            return kind, np.array(vals)
    return None


@dataclass
class BranchFile:
    """A branch file as read: its path, experiment (JSON attribute), branches and rig text."""

    path: Path
    experiment: dict
    branches: list[StoredBranch]
    rig: str
    used: bool = field(default=False)

    @property
    def param(self) -> str:
        return str(self.experiment.get("param", self.branches[0].param if self.branches else ""))


def _fmt(value: float, param: str) -> str:
    """A parameter value as the figure shows it (mm for a gap), four significant digits."""
    return f"{value * X_LABELS[param][1]:.4g} {X_UNITS[param]}"


def fixed_text(experiment: dict) -> str:
    """``"F0 = 15 N, gap 0.7 mm"``: the quantities held fixed along the branches."""
    parts = []
    for q in ("fe", "force", "gap"):
        if q != experiment.get("param") and q in experiment:
            parts.append(f"{FIXED_NAMES[q]} {_fmt(float(experiment[q]), q)}")
    return ", ".join(parts)


LOSS_WORDS = {  # mechanism -> what the branch the sweep followed does there
    "neimark-sacker": "loses stability to a torus (quasi-periodic motion)",
    "period-doubling": "loses stability to a period-2 orbit",
    "period-doubling cascade": "loses stability to a period-2 orbit",
}


def _exit_sentence(e, param: str) -> str:
    """The mechanism by which the sweep of ``e`` leaves the branch, and how far from the jump."""
    x = e.exit
    jump = f"between {_fmt(e.start, param)} and {_fmt(e.stop, param)}"
    where = f"{e.sweep} {e.contact} in a jump {jump}" if e.contact else f"{e.sweep} jumps {jump}"
    branch = (
        f"the {x.branch.replace(' ', '-')} branch the sweep followed"
        if e.followed
        else f"the {x.branch} branch"
    )
    does = "turns back" if x.turning else LOSS_WORDS.get(x.mechanism, "loses stability")
    if x.mechanism == "neimark-sacker" and x.stable_again is not None:
        does += (
            f", unstable up to {_fmt(x.stable_again, param)}"
            if x.direction == "up"
            else (f", unstable down to {_fmt(x.stable_again, param)}")
        )
    if e.distance == 0.0:
        return (
            f"{where}: the model's {x.words} at {_fmt(x.value, param)} lies inside it; there {branch} {does}."
        )
    how = "after" if (e.distance < 0) == (x.direction == "up") else "before"  # along the sweep
    return (
        f"{where}, {_fmt(abs(e.distance), param)} {how} the model's {x.words} at {_fmt(x.value, param)}, "
        f"where {branch} {does}."
    )


def jump_sentences(explanations: list, param: str) -> list[str]:
    """One or two sentences per measured jump: the mechanism by which the sweep leaves the branch
    it followed (:attr:`rigtools.analysis.branches.JumpExplanation.exit`) and how far from the
    jump; the nearest turning point and how far, if that is not it."""
    out = []
    for e in explanations:
        where = f"{e.sweep} jumps between {_fmt(e.start, param)} and {_fmt(e.stop, param)}"
        t = e.turning
        x = e.exit
        if x is not None:
            out.append(_exit_sentence(e, param))
            if t is not None and not (x.turning and abs(x.value - t.value) < 1e-12 * max(1.0, abs(t.value))):
                side = (
                    "inside the jump"
                    if e.inside
                    else f"{_fmt(abs(e.offset), param)} {'above' if e.offset > 0 else 'below'} it"
                )
                kind = "upper" if t.upper else "lower"
                out.append(
                    f"The model's nearest {kind} turning point, its {LABEL_WORDS[t.label]} at "
                    f"{_fmt(t.value, param)}, lies {side}."
                )
        elif t is None:
            out.append(where + "; the model's branches have no turning point to explain it.")
        elif e.inside:
            out.append(
                f"{where}: the jump is the model's {LABEL_WORDS[t.label]} at {_fmt(t.value, param)}, "
                f"where the {t.branch.replace(' ', '-')} branch the sweep followed turns back."
            )
        else:
            side = "above" if e.offset > 0 else "below"
            kind = "upper" if t.upper else "lower"
            out.append(
                f"{where}; the model's nearest {kind} turning point, its {LABEL_WORDS[t.label]} at "
                f"{_fmt(t.value, param)}, lies {_fmt(abs(e.offset), param)} {side} that interval."
            )
    return out


def measured_jump_sentences(branches: list[StoredBranch], measured: list, measure: str) -> list[str]:
    """:func:`jump_sentences` of ``measured`` (:func:`rigtools.measured_sweeps.measured_sweeps`) against
    stored branches in ``measure``, or one line saying the sweeps show no jump."""
    if not branches or not measured:
        return []
    sentences = jump_sentences(explain_jumps(branch_curves(branches, measure), measured), branches[0].param)
    return sentences or [f"{', '.join(m.name for m in measured)}: no jump."]


def period_two_sentence(branches: list[StoredBranch]) -> str:
    """Where the period-2 branches born at the period doublings are stable, or ``""``."""
    p1 = next((b for b in branches if b.periods == 1 and b.value.size), None)
    if p1 is None:
        return ""
    param = p1.param
    pds = [v for v, labs in zip(p1.value, p1.labels, strict=True) if "period-doubling" in labs]
    stable = [b for b in branches if b.periods == 2 and b.value.size and b.stable.any()]
    if not pds:
        return ""
    text = "The period-1 orbit period-doubles (PD) at " + ", ".join(_fmt(v, param) for v in pds)
    if not any(b.periods == 2 for b in branches):
        return text + " (the period-2 branches were not continued)."
    if not stable:
        return text + "; no stable period-2 orbit was found on the branches born there."
    spans = [
        f"{_fmt(float(b.value[b.stable].min()), param)} to {_fmt(float(b.value[b.stable].max()), param)}"
        for b in stable
    ]
    return (
        text
        + "; a stable period-2 orbit (two impacts of different strength) exists from "
        + (" and from ".join(spans) + ".")
    )


def bifurcation_rows(branches: list[StoredBranch]) -> list[dict[str, Any]]:
    """The table of the branches' bifurcations (turning points marked upper / lower)."""
    if not branches:
        return []
    param = branches[0].param
    unit = f"{param} ({X_UNITS[param]})"
    scale = X_LABELS[param][1]
    curves = iter(branch_curves(branches))
    rows = []
    for b in branches:
        if not b.value.size:
            continue
        turning = {t.value: t for t in turning_points(next(curves))}
        mod = np.abs(b.multipliers)
        located = {(r["index"], r["label"]): r for r in b.bifurcations}
        for i, labs in enumerate(b.labels):
            for lab in labs:
                if lab not in SHORT:
                    continue
                t = turning.get(float(b.value[i]))
                r = located.get((i, lab), {})
                mu = r.get("multiplier") or [None, None]
                rows.append(
                    {
                        "branch": f"period {b.periods}",
                        "bifurcation": f"{lab} ({SHORT[lab]})",
                        unit: float(b.value[i]) * scale,
                        # at a converged time step (rigtools.sim.bifurcation_refine), NaN if not refined
                        f"converged ({X_UNITS[param]})": float("nan")
                        if r.get("converged") is None
                        else r["converged"] * scale,
                        "stable": bool(b.stable[i]),
                        "turning point": ""
                        if t is None or t.label != lab
                        else ("upper" if t.upper else "lower"),
                        "critical multiplier": "" if mu[0] is None else f"{complex(mu[0], mu[1] or 0.0):.4f}",
                        "largest |multiplier|": float(np.nanmax(mod[i])) if mod.shape[1] else float("nan"),
                    }
                )
    return rows


def jump_rows(explanations: list, param: str) -> list[dict[str, Any]]:
    """The table of measured jumps against the branches' turning points."""
    unit, scale = X_UNITS[param], X_LABELS[param][1]
    rows = []
    for e in explanations:
        t = e.turning
        rows.append(
            {
                "sweep": e.sweep,
                "direction": e.direction,
                f"jump from ({unit})": e.start * scale,
                f"jump to ({unit})": e.stop * scale,
                "turning point": "" if t is None else f"{t.label} ({'upper' if t.upper else 'lower'})",
                f"at ({unit})": float("nan") if t is None else t.value * scale,
                "inside the jump": e.inside,
                f"offset ({unit})": e.offset * scale,
                "mechanism": "" if e.exit is None else e.exit.mechanism,
                f"mechanism at ({unit})": float("nan") if e.exit is None else e.exit.value * scale,
                f"mechanism offset ({unit})": e.distance * scale,
                "contact": e.contact,
            }
        )
    return rows


def add_branches(
    section,
    branches: list[StoredBranch],
    measured: list,
    *,
    measure: str,
    what: str,
    lead: str = "",
    tail: str = "",
) -> list:
    """Add to ``section``: ``lead``, the sentences explaining each measured jump by the
    branches' turning points (:func:`rigtools.analysis.branches.explain_jumps`) and ``tail``, the
    figure of the branches with ``measured`` (:class:`rigtools.analysis.branches.MeasuredSweep`)
    overlaid, the bifurcation table and the jump table. ``what`` names the branches in the
    caption (model, fixed quantities). Returns the jump explanations."""
    if not any(b.value.size for b in branches):
        section.note(f"{what}: no branch point to draw ({'; '.join(b.message for b in branches)})")
        return []
    param = branches[0].param
    explanations = explain_jumps(branch_curves(branches, measure), measured)
    sentences = [lead] if lead else []
    sentences += jump_sentences(explanations, param)
    if measured and not explanations:
        sentences.append("The sweeps drawn show no jump.")
    sentences += [tail, period_two_sentence(branches)]
    section.text(" ".join(s for s in sentences if s))
    for b in branches:
        if b.status not in ("complete", "merged", "closed"):
            section.note(f"{what}, period-{b.periods} branch: {b.status}: {b.message}")
    names = ", ".join(m.name for m in measured)
    section.figure(
        branches_figure(branches, measure, what, measured),
        f"{what}: the model's periodic orbits continued in {param}, stable solid, unstable dashed, "
        "bifurcations labelled (LP fold, PD period doubling, NS Neimark-Sacker, G grazing)"
        + (f"; on the same axes {names} (up ^, down v), their jumps shaded." if measured else "."),
    )
    rows = bifurcation_rows(branches)
    if rows:
        section.table(rows, caption=f"{what}: bifurcations of the branches")
    else:
        section.note(f"{what}: no bifurcation along the branches")
    if explanations:
        section.table(
            jump_rows(explanations, param),
            caption="Measured jumps and the model's turning points (offset 0: inside the jump)",
        )
    return explanations


def load_branch_files(paths) -> list[BranchFile]:
    """Read every branch file (:func:`rigtools.branches_file.read_branches`; one-line
    :class:`rigtools.errors.UserError` on a file that is not one)."""
    out = []
    for p in paths:
        experiment, branches = read_branches(p)
        with h5py.File(p, "r") as f:
            rig = str(f.attrs.get("rig", ""))
        out.append(BranchFile(Path(p), experiment, branches, rig))
    return out


def _same_model(rig_a: str, rig_b: str) -> bool:
    """The two rig descriptions (JSON or TOML text) give the same model (``to_params``)."""

    def params(text: str):
        try:
            data = json.loads(text)
        except ValueError:
            data = tomllib.loads(text)
        return parse_rig(data, source="rig").to_params()

    try:
        return bool(params(rig_a) == params(rig_b))
    except (ValueError, UserError):  # unreadable or invalid (TOMLDecodeError is a ValueError)
        return False


def why_not(bf: BranchFile, analysis, rig: str) -> str:
    """Why the branches of ``bf`` are not drawn over the recording of ``analysis``, or ``""``."""
    name = bf.path.name
    if is_foreign({"procedure": analysis.procedure}):
        return (
            f"{name}: imported recording, it does not describe this rig: not drawn over the model's "
            "branches (rig continuation --measured draws it when asked)"
        )
    if not _same_model(rig, bf.rig):
        return f"{name}: continued for another rig description than this recording's: not drawn over it"
    for q in ("fe", "force", "gap"):
        if q == bf.param or q not in bf.experiment:
            continue
        values = [float(v) for p in analysis.periodic if (v := p.params.get(POINT_PARAM[q])) is not None]
        want = float(bf.experiment[q])
        if values and abs(float(np.median(values)) / want - 1.0) > FIXED_TOLERANCE:
            return (
                f"{name}: continued at {FIXED_NAMES[q]} {_fmt(want, q)}, this recording runs at "
                f"{FIXED_NAMES[q]} {_fmt(float(np.median(values)), q)}: not drawn over it"
            )
    return ""


def add_recording_branches(section, analysis, files: list[BranchFile]) -> None:
    """Draw every branch file continued in the recording's swept parameter over the recording's
    sweeps (model recordings in peak contact force, rig recordings in the active shroud's
    fundamental acceleration, what a lab measures), or say why not."""
    axis = study_axis(analysis)
    if axis is None:
        return
    param = KIND_PARAM[axis[0]]
    matching = [bf for bf in files if bf.param == param]
    if not matching:
        return
    with open_recording(analysis.path) as rec:
        rig = rec.rig
    measure = "contact" if analysis.source == FEM else "accel1"
    for bf in matching:
        reason = why_not(bf, analysis, rig)
        if reason:
            section.note(reason)
            continue
        bf.used = True
        add_branches(
            section,
            bf.branches,
            measured_sweeps([analysis.path], param, measure),
            measure=measure,
            what=f"{bf.path.name} ({str(bf.experiment.get('model', 'fem')).upper()}, {fixed_text(bf.experiment)})",
        )


def add_unmatched_branches(report, files: list[BranchFile]) -> None:
    """A section for each branch file drawn over no recording: its branches alone."""
    for bf in files:
        if bf.used:
            continue
        sec = report.section(f"{bf.path.name}: model branches")
        sec.text(
            f"Continued in {bf.param} ({fixed_text(bf.experiment)}); drawn over no recording of this "
            f"report (none sweeps {bf.param} on the branches' rig at these quantities)."
        )
        add_branches(
            sec,
            bf.branches,
            [],
            measure="contact",
            what=f"{bf.path.name} ({str(bf.experiment.get('model', 'fem')).upper()}, {fixed_text(bf.experiment)})",
        )
