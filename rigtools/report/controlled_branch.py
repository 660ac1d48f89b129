"""Measured points of a controlled test (phase-locked loop or control-based continuation) over the
model's branches: the figure a lab shows.

Each point of such a recording carries the shared :class:`ControlledPoint` fields as attributes
(``fe_hz``, ``amplitude_m``, ...). :func:`controlled_branch_figure` draws them (converged filled,
not converged hollow) in the plane frequency / amplitude of the active shroud's displacement
fundamental, over the model's orbits continued in frequency (``rig continuation --param fe --model
rig``, given to ``rig report --branches``): stable solid, unstable dashed, the amplitude of each
orbit its acceleration fundamental over ``(2 pi fe)^2``, the quantity the points hold.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rigtools.branches_file import StoredBranch
from rigtools.controlled_point import ControlledPoint
from rigtools.recording import open_recording

_FIELDS = tuple(ControlledPoint.__dataclass_fields__)


def controlled_points(path: str | Path) -> list[ControlledPoint]:
    """The controlled points of a recording (its complete points that carry every field as a
    number; ``rig check`` names the others)."""
    out = []
    with open_recording(path) as rec:
        for p in rec.points:
            params = dict(p.params)
            if not (p.complete and all(name in params for name in _FIELDS)):
                continue
            try:
                point = ControlledPoint(
                    fe_hz=float(params["fe_hz"]),
                    amplitude_m=float(params["amplitude_m"]),
                    force_fundamental_n=float(params["force_fundamental_n"]),
                    phase_deg=float(params["phase_deg"]),
                    converged=_flag(params["converged"]),
                    iterations=int(params["iterations"]),
                    drive_harmonics_ratio=float(params["drive_harmonics_ratio"]),
                )
            except (TypeError, ValueError):  # a field a script overwrote with text
                continue
            out.append(point)
    return out


def _flag(value: Any) -> bool:
    """A stored bool (numpy's or 0/1); text is not one (``bool("no")`` would be True)."""
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{value!r} is not a bool")
    return bool(value)


def branch_amplitude(branch: StoredBranch) -> np.ndarray:
    """Amplitude of the active shroud's displacement fundamental of each orbit of a frequency
    branch, m (its acceleration fundamental over ``(2 pi fe)^2``)."""
    accel = np.asarray(branch.measures["accel_harmonics_active"], float)
    first = accel[:, 0] if accel.ndim == 2 else accel
    return first / (2 * math.pi * np.asarray(branch.value, float)) ** 2


def draw_branch(
    ax: Any, x: np.ndarray, y: np.ndarray, stable: np.ndarray, labelled: bool = True, color: str = "0.3"
) -> None:
    """One branch on ``ax``: its stable stretches solid, its unstable ones dashed (neighbouring
    stretches share their end point, so the curve is unbroken); ``labelled``: legend entries
    "model, stable" and "model, unstable"."""
    x, y, stable = np.asarray(x, float), np.asarray(y, float), np.asarray(stable, bool)
    start = 0
    for j in range(1, x.size + 1):
        if j == x.size or stable[j] != stable[start]:
            seg = slice(start, min(j + 1, x.size))
            ax.plot(
                x[seg],
                y[seg],
                color=color,
                linestyle="-" if stable[start] else "--",
                linewidth=1.2,
                label=("model, stable" if stable[start] else "model, unstable") if labelled else None,
            )
            start = j


def controlled_branch_figure(
    points: list[ControlledPoint], branches: Sequence[StoredBranch] = (), title: str = ""
) -> Any:
    """The figure: ``points`` over the frequency ``branches`` (stable solid, unstable dashed)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 4.5))
    ax = fig.add_subplot()
    for i, b in enumerate(br for br in branches if br.param == "fe" and br.value.size):
        draw_branch(ax, b.value, branch_amplitude(b) * 1e3, b.stable, labelled=i == 0)
    for conv in (True, False):
        sel = [p for p in points if p.converged == conv]
        if sel:
            ax.plot(
                [p.fe_hz for p in sel],
                [p.amplitude_m * 1e3 for p in sel],
                "o",
                color="C3",
                markerfacecolor="C3" if conv else "none",
                label="measured" + ("" if conv else ", not converged"),
            )
    for p in points:
        ax.annotate(
            f"{p.phase_deg:.0f}°",
            (p.fe_hz, p.amplitude_m * 1e3),
            fontsize=7,
            xytext=(4, 4),
            textcoords="offset points",
        )
    handles, labels = ax.get_legend_handles_labels()
    seen = dict(zip(labels, handles, strict=True))
    if seen:
        ax.legend(seen.values(), seen.keys(), fontsize=8)
    ax.set_xlabel("excitation frequency (Hz)")
    ax.set_ylabel("active shroud displacement, fundamental (mm)")
    ax.set_title(title, fontsize=9)
    ax.grid(True, alpha=0.3)
    return fig


def add_controlled_points(section: Any, path: str | Path, branch_files: Sequence[Any] = ()) -> None:
    """Into a report section: the table of a recording's controlled points and the figure over
    the frequency branches among ``branch_files`` (:class:`rigtools.report.branches.BranchFile`)."""
    points = controlled_points(path)
    if not points:
        section.note("no controlled point in this recording (none complete with its fields)")
        return
    section.table(
        [
            {
                "fe (Hz)": f"{p.fe_hz:.4f}",
                "A (mm)": f"{p.amplitude_m * 1e3:.4f}",
                "F1 (N)": f"{p.force_fundamental_n:.4g}",
                "phase (deg)": f"{p.phase_deg:.2f}",
                "converged": "yes" if p.converged else "NO",
                "iterations": p.iterations,
                "drive harmonics": f"{p.drive_harmonics_ratio:.2g}",
            }
            for p in points
        ],
        caption="Controlled points (the shared record: fe, A the active shroud's displacement fundamental, "
        "F1 the force fundamental, phase of A to F1, iterations: PLL periods to lock / CBC outer iterations)",
    )
    branches = [b for bf in branch_files for b in bf.branches if b.param == "fe"]
    for bf in branch_files:
        if any(b.param == "fe" for b in bf.branches):
            bf.used = True
    what = ", ".join(str(bf.path.name) for bf in branch_files if any(b.param == "fe" for b in bf.branches))
    section.figure(
        controlled_branch_figure(points, branches, Path(path).name + (f" over {what}" if what else "")),
        "Measured controlled points (filled: converged; hollow: not converged; labelled by phase)"
        + (
            " over the model's orbits continued in frequency, stable solid, unstable dashed."
            if branches
            else "; give rig report --branches a frequency branch file (rig continuation --param fe --model rig) "
            "to draw the model's stable and unstable orbits beside them."
        ),
    )
