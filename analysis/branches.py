"""Figure of continued branches: a response measure against the continued parameter, stable parts
solid, unstable dashed, bifurcations labelled, measured sweeps on the same axes (arrays in, a
matplotlib figure out; no file I/O)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from matplotlib.figure import Figure

SHORT = {"fold": "LP", "period-doubling": "PD", "neimark-sacker": "NS", "grazing": "G"}


@dataclass
class BranchCurve:
    """One branch as arrays: ``value`` (n,), ``measure`` (n,), ``stable`` (n,) bool, ``labels``
    (n,) tuples of label names, ``name`` for the legend."""

    value: np.ndarray
    measure: np.ndarray
    stable: np.ndarray
    labels: Sequence[Sequence[str]]
    name: str = "period 1"


@dataclass
class MeasuredSweep:
    """A measured (or simulated) sweep: points in run order, ``direction`` "up" or "down"."""

    value: np.ndarray
    measure: np.ndarray
    direction: str = "up"
    name: str = "measured"
    jumps: list[tuple[float, float]] = field(default_factory=list)


def branch_figure(
    curves: Sequence[BranchCurve],
    xlabel: str,
    ylabel: str,
    measured: Sequence[MeasuredSweep] = (),
    x_scale: float = 1.0,
    title: str = "",
) -> Figure:
    """The branches (stable solid, unstable dashed, bifurcations marked and named: LP fold, PD
    period doubling, NS Neimark-Sacker, G grazing) and the measured sweeps (up ``^``, down ``v``,
    their jumps shaded). ``x_scale`` multiplies the parameter for display (1e3: m -> mm)."""
    fig = Figure(figsize=(8, 5))
    ax = fig.add_subplot(1, 1, 1)
    colours = ["C0", "C3", "C2", "C4", "C5"]
    colour_of: dict[str, str] = {}  # one colour and one legend entry per name (period 1, period 2)
    in_legend: set[tuple[str, bool]] = set()
    for c in curves:
        x = np.asarray(c.value, float) * x_scale
        y = np.asarray(c.measure, float)
        st = np.asarray(c.stable, bool)
        col = colour_of.setdefault(c.name, colours[len(colour_of) % len(colours)])
        for stable, style in ((True, "-"), (False, "--")):
            if not np.any(st == stable):
                continue
            yy = np.where(st == stable, y, np.nan)
            # join each run of one kind to its neighbours so the curve has no holes
            edge = np.flatnonzero(np.diff(st.astype(int)) != 0)
            for e in edge:
                yy[e if st[e] != stable else e + 1] = y[e if st[e] != stable else e + 1]
            label = f"{c.name} ({'stable' if stable else 'unstable'})"
            first = (c.name, stable) not in in_legend
            in_legend.add((c.name, stable))
            ax.plot(x, yy, style, color=col, lw=1.6, label=label if first else "_nolegend_")
        for xi, yi, labs in zip(x, y, c.labels, strict=True):
            names = [SHORT[lab] for lab in labs if lab in SHORT]
            if names:
                ax.plot(xi, yi, "o", color="k", ms=4)
                ax.annotate("/".join(names), (xi, yi), textcoords="offset points", xytext=(4, 4), fontsize=8)
    shaded = False
    for m in measured:
        marker = "^" if m.direction == "up" else "v"
        ax.plot(
            np.asarray(m.value) * x_scale, m.measure, marker + ":", lw=0.8, ms=5, mfc="none", label=m.name
        )
        for lo, hi in m.jumps:
            label = "_nolegend_" if shaded else "measured jump"
            ax.axvspan(lo * x_scale, hi * x_scale, color="0.8", alpha=0.5, lw=0, label=label)
            shaded = True
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    return fig
