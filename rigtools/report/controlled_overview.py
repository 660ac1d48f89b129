"""The figure a lab shows of a nonlinear test: every measurement of a report in the planes where
the model's branches are drawn.

Given a report's recordings (a phase-locked loop, a control-based continuation, a stepped sine up
and down) and branch files (``rig continuation --model rig``), :func:`overview_figure` draws:

- left, the excitation frequency against A, the amplitude of the active shroud's displacement
  fundamental: the model's orbits continued in frequency (stable solid, unstable dashed), the
  stepped sine up and down, the PLL's points (each labelled by its phase) and the CBC's points,
  all at their own fe (a CBC holds one fe: its points stand on one vertical line, each at its own
  force);
- right (with a CBC recording), the force fundamental F1 against A at the CBC's fe: the S-curve
  the CBC measures, over the model's orbits continued in force at that fe, and a dotted line at
  the force of the left panel's branches, which crosses the S-curve where that branch crosses the
  CBC's fe.

A stepped sine's A is its acceleration fundamental over ``(2 pi fe)^2``, as the model's
(:func:`rigtools.report.controlled_branch.branch_amplitude`): the same quantity the controlled
points hold. :func:`add_controlled_overview` puts the figure into ``rig report`` when a recording
is a PLL or a CBC.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rigtools.controlled_point import ControlledPoint
from rigtools.recording import open_recording
from rigtools.recording.schema import CONTROLLED_PROCEDURES
from rigtools.report.branches import FIXED_TOLERANCE, BranchFile, fixed_text
from rigtools.report.controlled_branch import (
    branch_amplitude,
    controlled_points,
    draw_branch,
)

PLL, CBC = CONTROLLED_PROCEDURES
#: The procedure of a stepped sine (``rig acquire sweep``, :func:`rigtools.stepped_sine`).
SWEEP = "stepped sine"
_ACCEL1 = "active_shroud_accel_harmonic_amplitude"


@dataclass(frozen=True)
class SweepCurve:
    """One direction of a stepped sine: fe (Hz) and A (m) of its measured points in run order."""

    direction: str
    fe_hz: np.ndarray
    amplitude_m: np.ndarray


@dataclass
class Overview:
    """What :func:`overview_figure` draws (SI; the branch files' :class:`BranchFile`)."""

    pll: list[ControlledPoint] = field(default_factory=list)
    cbc: list[ControlledPoint] = field(default_factory=list)
    sweeps: list[SweepCurve] = field(default_factory=list)
    fe_files: list[BranchFile] = field(default_factory=list)
    force_files: list[BranchFile] = field(default_factory=list)

    @property
    def cbc_fe(self) -> float | None:
        """The CBC's fe, Hz (its points' median), or None without CBC points."""
        return float(np.median([p.fe_hz for p in self.cbc])) if self.cbc else None


def sweep_curves(path: str | Path) -> list[SweepCurve]:
    """The up and down curves of a stepped sine recording (its measured points with the active
    shroud's acceleration harmonics), A its acceleration fundamental over ``(2 pi fe)^2``."""
    runs: dict[str, tuple[list[float], list[float]]] = {}
    with open_recording(path) as rec:
        for p in rec.complete_points:
            fe, accel = p.params.get("fe"), p.params.get(_ACCEL1)
            if fe is None or accel is None or p.params.get("point_complete", True) is False:
                continue
            fes, amps = runs.setdefault(str(p.params.get("direction") or "up"), ([], []))
            fes.append(float(fe))
            amps.append(float(np.atleast_1d(accel)[0]) / (2 * math.pi * float(fe)) ** 2)
    return [SweepCurve(d, np.array(f), np.array(a)) for d, (f, a) in runs.items()]


def force_branch_amplitude(branch: Any, fe: float) -> np.ndarray:
    """A (m) of each orbit of a branch continued in force at ``fe`` (Hz): the active shroud's
    acceleration fundamental over ``(2 pi fe)^2``."""
    accel = np.asarray(branch.measures["accel_harmonics_active"], float)
    first = accel[:, 0] if accel.ndim == 2 else accel
    return first / (2 * math.pi * fe) ** 2


def _points(
    ax: Any, points: list[ControlledPoint], x: str, y: str, marker: str, colour: str, what: str
) -> None:
    """Controlled points, converged filled and the others hollow; ``x``/``y`` their fields (m in mm)."""
    scale = {"amplitude_m": 1e3}
    for conv in (True, False):
        sel = [p for p in points if p.converged == conv]
        if sel:
            ax.plot(
                [getattr(p, x) * scale.get(x, 1.0) for p in sel],
                [getattr(p, y) * scale.get(y, 1.0) for p in sel],
                marker,
                color=colour,
                markerfacecolor=colour if conv else "none",
                markersize=6,
                linestyle="none",
                label=what + ("" if conv else ", not converged"),
            )


def _legend(ax: Any) -> None:
    handles, labels = ax.get_legend_handles_labels()
    seen = dict(zip(labels, handles, strict=True))
    if seen:
        ax.legend(seen.values(), seen.keys(), fontsize=7, loc="best")


def overview_figure(ov: Overview, title: str = "") -> Any:
    """The figure (module docstring): the frequency plane, and the force plane with a CBC."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    right = bool(ov.cbc)
    fig = Figure(figsize=(11.0 if right else 7.0, 4.6), layout="constrained")
    ax = fig.add_subplot(1, 2 if right else 1, 1)
    first = True
    for bf in ov.fe_files:
        for b in bf.branches:
            if b.param == "fe" and b.value.size:
                draw_branch(ax, b.value, branch_amplitude(b) * 1e3, b.stable, labelled=first)
                first = False
    for s in ov.sweeps:
        up = s.direction == "up"
        ax.plot(
            s.fe_hz,
            s.amplitude_m * 1e3,
            "^-" if up else "v-",
            color="C0" if up else "C1",
            linewidth=0.8,
            markersize=5,
            label=f"stepped sine, {s.direction}",
        )
    _points(ax, ov.pll, "fe_hz", "amplitude_m", "o", "C3", "PLL")
    for p in ov.pll:
        ax.annotate(
            f"{p.phase_deg:.0f}°",
            (p.fe_hz, p.amplitude_m * 1e3),
            fontsize=7,
            xytext=(4, 4),
            textcoords="offset points",
        )
    _points(ax, ov.cbc, "fe_hz", "amplitude_m", "D", "C2", "CBC")
    ax.set_xlabel("excitation frequency fe (Hz)")
    ax.set_ylabel("A: active shroud displacement, fundamental (mm)")
    forces = sorted(
        {round(float(bf.experiment["force"]), 6) for bf in ov.fe_files if "force" in bf.experiment}
    )
    ax.set_title(
        "frequency plane" + (f": model at F1 {', '.join(f'{f:g}' for f in forces)} N" if forces else ""),
        fontsize=9,
    )
    ax.grid(True, alpha=0.3)
    _legend(ax)
    if right:
        fe = ov.cbc_fe
        assert fe is not None
        ax.axvline(fe, color="C2", linestyle=":", linewidth=0.8)
        bx = fig.add_subplot(1, 2, 2)
        first = True
        for bf in ov.force_files:
            for b in bf.branches:
                if b.param == "force" and b.value.size:
                    amp = force_branch_amplitude(b, float(bf.experiment["fe"])) * 1e3
                    draw_branch(bx, amp, b.value, b.stable, labelled=first)
                    first = False
        _points(bx, ov.cbc, "amplitude_m", "force_fundamental_n", "D", "C2", "CBC")
        for f in forces:
            bx.axhline(
                f, color="0.5", linestyle=":", linewidth=0.8, label="F1 of the frequency plane's model"
            )
        bx.set_xlabel("A: active shroud displacement, fundamental (mm)")
        bx.set_ylabel("F1: force fundamental (N)")
        bx.set_title(f"force plane at fe {fe:.4g} Hz (the CBC's S-curve)", fontsize=9)
        bx.grid(True, alpha=0.3)
        _legend(bx)
    if title:
        fig.suptitle(title, fontsize=9)
    return fig


def overview_caption(ov: Overview) -> str:
    """What is where in :func:`overview_figure`, from what it holds."""
    left = ["Left: A (the active shroud's displacement fundamental) against fe"]
    if ov.fe_files:
        what = "; ".join(f"{bf.path.name}, {fixed_text(bf.experiment)}" for bf in ov.fe_files)
        left.append(f"the model's orbits continued in frequency ({what}), stable solid, unstable dashed")
    if ov.sweeps:
        left.append("the stepped sine up (triangles up) and down (triangles down)")
    if ov.pll:
        left.append("the PLL's points (circles, labelled by their phase of A to F1)")
    if ov.cbc:
        left.append(
            f"the CBC's points (diamonds) on the dotted line at its fe {ov.cbc_fe:.4g} Hz, each at its own F1"
        )
    text = ", ".join(left) + "."
    if ov.cbc:
        text += f" Right: F1 against A at fe {ov.cbc_fe:.4g} Hz, the CBC's S-curve"
        if ov.force_files:
            what = "; ".join(f"{bf.path.name}, {fixed_text(bf.experiment)}" for bf in ov.force_files)
            text += f" over the model's orbits continued in force ({what}), stable solid, unstable dashed"
        else:
            text += (
                " (give rig report --branches a force branch at this fe, rig continuation --param force "
                f'--fe "{ov.cbc_fe:.4g} Hz" --model rig, to draw the model beside it)'
            )
        if ov.fe_files:
            text += "; the dotted line the force of the left panel's model"
        text += "."
    return text + " Filled: converged; hollow: not converged."


def collect_overview(paths: Sequence[tuple[str, str | Path]], files: Sequence[BranchFile]) -> Overview:
    """The :class:`Overview` of recordings ``(procedure, path)`` and branch files: the frequency
    branches, and the force branches at the CBC's fe (within :data:`FIXED_TOLERANCE`)."""
    ov = Overview()
    for procedure, path in paths:
        if procedure == PLL:
            ov.pll += controlled_points(path)
        elif procedure == CBC:
            ov.cbc += controlled_points(path)
        elif procedure == SWEEP:
            ov.sweeps += sweep_curves(path)
    ov.fe_files = [bf for bf in files if bf.param == "fe" and bf.branches]
    fe = ov.cbc_fe
    if fe is not None:
        ov.force_files = [
            bf
            for bf in files
            if bf.param == "force"
            and bf.branches
            and abs(float(bf.experiment.get("fe", 0.0)) / fe - 1) <= FIXED_TOLERANCE
        ]
    return ov


def add_controlled_overview(report: Any, analyses: Sequence[Any], files: Sequence[BranchFile]) -> None:
    """With a PLL or CBC among ``analyses`` (:class:`rigtools.recording_analysis.results.RecordingAnalysis`):
    a section holding :func:`overview_figure` of every recording and branch file it can draw,
    those branch files marked used."""
    paths = [(a.procedure, a.path) for a in analyses]
    if not any(proc in CONTROLLED_PROCEDURES for proc, _ in paths):
        return
    ov = collect_overview(paths, files)
    if not (ov.pll or ov.cbc):
        return
    for bf in ov.fe_files + ov.force_files:
        bf.used = True
    names = [Path(p).name for proc, p in paths if proc in (PLL, CBC, SWEEP)]
    sec = report.section("Controlled points, stepped sine and the model's branches")
    sec.text(
        "The measured branch in the planes where the model's is drawn: "
        + ", ".join(names)
        + (
            " over " + ", ".join(bf.path.name for bf in ov.fe_files + ov.force_files)
            if ov.fe_files or ov.force_files
            else ""
        )
        + "."
    )
    sec.figure(overview_figure(ov, ", ".join(names)), overview_caption(ov))
