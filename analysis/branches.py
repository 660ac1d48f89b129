"""Continued branches beside measured sweeps: the figure (a response measure against the continued
parameter, stable parts solid, unstable dashed, bifurcations labelled, measured sweeps on the same
axes), the branches' turning points (:func:`turning_points`) and how each measured jump comes
about (:func:`explain_jumps`: where the stable run the sweep followed ends, by which mechanism,
:mod:`rigtools.analysis.branch_exits`). Arrays in, a matplotlib figure or small dataclasses out; no file
I/O."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from matplotlib.figure import Figure

from rigtools.analysis.branch_exits import BranchExit, branch_exits, run_measure_at

SHORT = {
    "fold": "LP",
    "period-doubling": "PD",
    "neimark-sacker": "NS",
    "grazing": "G",
    "contact-split": "CS",
    "sticking": "ST",
}
# labels nearer than this (fraction of the axes) are stacked, not printed over each other
LABEL_SPACING = (0.04, 0.045)
TURNING_LABELS = ("fold", "grazing")  # a branch turns back at a fold, or at a grazing corner


@dataclass
class BranchCurve:
    """One branch as arrays: ``value`` (n,), ``measure`` (n,), ``stable`` (n,) bool, ``labels``
    (n,) tuples of label names, ``name`` for the legend."""

    value: np.ndarray
    measure: np.ndarray
    stable: np.ndarray
    labels: Sequence[Sequence[str]]
    name: str = "period 1"
    contact: np.ndarray | None = None  # impacts per period at each point (None: not known)


@dataclass
class MeasuredSweep:
    """A measured (or simulated) sweep: points in run order, ``direction`` "up" or "down"."""

    value: np.ndarray
    measure: np.ndarray
    direction: str = "up"
    name: str = "measured"
    jumps: list[tuple[float, float]] = field(default_factory=list)
    contact: Sequence[bool | None] | None = None  # the shrouds touch at each point (None: unknown)


def branch_figure(
    curves: Sequence[BranchCurve],
    xlabel: str,
    ylabel: str,
    measured: Sequence[MeasuredSweep] = (),
    x_scale: float = 1.0,
    title: str = "",
) -> Figure:
    """The branches (stable solid, unstable dashed, bifurcations marked and named: LP fold, PD
    period doubling, NS Neimark-Sacker, G grazing, CS contact split, ST sticking; names that would
    print over each other stacked) and the measured sweeps (up ``^``, down ``v``, their jumps
    shaded). ``x_scale`` multiplies the parameter for display (1e3: m -> mm)."""
    fig = Figure(figsize=(9.5, 5))
    ax = fig.add_subplot(1, 1, 1)
    colours = ["C0", "C3", "C2", "C4", "C5"]
    colour_of: dict[str, str] = {}  # one colour and one legend entry per name (period 1, period 2)
    in_legend: set[tuple[str, bool]] = set()
    marks: list[tuple[float, float, str]] = []
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
                marks.append((float(xi), float(yi), "/".join(names)))
    shaded = False
    others = ["C1", "C6", "C8", "C9", "C7"]  # measured sweeps in colours no branch takes
    for i, m in enumerate(measured):
        marker = "^" if m.direction == "up" else "v"
        ax.plot(
            np.asarray(m.value) * x_scale,
            m.measure,
            marker + ":",
            color=others[i % len(others)],
            lw=0.8,
            ms=5,
            mfc="none",
            label=m.name,
        )
        for lo, hi in m.jumps:
            label = "_nolegend_" if shaded else "measured jump"
            ax.axvspan(lo * x_scale, hi * x_scale, color="0.8", alpha=0.5, lw=0, label=label)
            shaded = True
    _annotate(ax, marks)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.grid(True, alpha=0.3)
    # beside the axes: "best" placed it over the unstable (dashed) branch of the demo's figure
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    fig.tight_layout()
    return fig


def label_offsets(
    positions: Sequence[tuple[float, float]], spacing: tuple[float, float] = LABEL_SPACING
) -> list[int]:
    """The line of each label at ``positions`` (axes fractions), left to right: its text is drawn
    ``level`` lines (``spacing[1]`` each; negative: below) from its point, at the nearest line
    (0, -1, 1, -2, 2, ...) whose text lies no nearer than ``spacing`` (x, y) to a text placed
    before it."""
    placed: list[tuple[float, float]] = []
    levels = [0] * len(positions)
    tried = [0] + [k * sign for k in range(1, len(positions) + 1) for sign in (-1, 1)]
    for i in sorted(range(len(positions)), key=lambda k: positions[k]):
        x, y = positions[i]
        level = next(
            lev
            for lev in tried
            if not any(
                abs(px - x) < spacing[0] and abs(py - (y + lev * spacing[1])) < spacing[1] * (1 - 1e-9)
                for px, py in placed
            )
        )
        levels[i] = level
        placed.append((x, y + level * spacing[1]))
    return levels


def _annotate(ax, marks: list[tuple[float, float, str]]) -> None:
    """The labels at their points, stacked where they would print over each other."""
    if not marks:
        return
    ax.autoscale_view()
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    pos = [((x - x0) / ((x1 - x0) or 1.0), (y - y0) / ((y1 - y0) or 1.0)) for x, y, _ in marks]
    for (x, y, text), level in zip(marks, label_offsets(pos), strict=True):
        ax.annotate(
            text,
            (x, y),
            textcoords="offset points",
            xytext=(
                4,
                4 + 13 * level if level >= 0 else -4 + 13 * (level + 1),
            ),  # 13 points: about LABEL_SPACING[1] of the axes
            fontsize=8,
            va="bottom" if level >= 0 else "top",
            arrowprops=None if level == 0 else {"arrowstyle": "-", "color": "0.5", "lw": 0.5},
        )


@dataclass(frozen=True)
class TurningPoint:
    """Where a branch turns back in its parameter: ``upper`` (the parameter has a local maximum
    there: a sweep up following the branch has nowhere to go and jumps) or lower (a sweep down
    jumps); ``label`` is the point's bifurcation (``"fold"`` or ``"grazing"``: a grazing corner,
    where impacts begin or end)."""

    value: float
    label: str
    upper: bool
    branch: str


def turning_points(curve: BranchCurve) -> list[TurningPoint]:
    """The fold and grazing points of ``curve`` at which its parameter reverses: the nearest
    points before and after it that differ from it by more than a thousandth of the branch's
    range lie on one side (a grazing corner is labelled where the orbit grazes, and may turn a
    few short steps further); in branch order."""
    v = np.asarray(curve.value, float)
    tiny = 1e-3 * float(np.ptp(v)) if v.size else 0.0
    out = []
    for i, labs in enumerate(curve.labels):
        # a grazing hairpin is labelled fold and grazing: it is named for its grazing
        label = next((lab for lab in reversed(TURNING_LABELS) if lab in labs), None)
        if label is None:
            continue
        before = next((v[j] for j in range(i - 1, -1, -1) if abs(v[j] - v[i]) > tiny), None)
        after = next((v[j] for j in range(i + 1, v.size) if abs(v[j] - v[i]) > tiny), None)
        if before is None or after is None or (v[i] - before) * (after - v[i]) >= 0:
            continue
        out.append(TurningPoint(float(v[i]), label, bool(v[i] > before), curve.name))
    return out


MATCH = 0.1  # a measured point lies on a stable run if its measure is within 10 % of the run's there
LOOK_BACK = 6  # measured points before a jump searched for the stable run the sweep followed


@dataclass(frozen=True)
class JumpExplanation:
    """A measured jump, the mechanism by which the branches say the sweep leaves there, and the
    branches' turning point nearest to it.

    ``start``, ``stop``: the jump's interval (the two steps between which it happens, ordered);
    ``turning``: the nearest turning point of the kind a sweep in that direction meets (upper for
    up, lower for down; any kind if the branches have none of it), ``None`` without any;
    ``offset``: 0 inside the interval, else the turning point's distance from its nearer end
    (positive above the interval); ``exit``: where the stable run the sweep followed ends in its
    direction and by which mechanism (:class:`rigtools.analysis.branch_exits.BranchExit`), ``None``
    if the branches have no such end; ``distance``: the exit's offset from the interval, as
    ``offset``; ``followed``: the sweep's own points were found on that run (else the exit is
    the one nearest to the jump); ``contact``: ``"leaves contact"``, ``"makes contact"`` or
    ``""`` (the measured contact across the jump).
    """

    sweep: str
    direction: str
    start: float
    stop: float
    turning: TurningPoint | None
    offset: float
    exit: BranchExit | None = None
    distance: float = float("nan")
    followed: bool = False
    contact: str = ""

    @property
    def inside(self) -> bool:
        return self.turning is not None and self.offset == 0.0

    @property
    def exit_inside(self) -> bool:
        return self.exit is not None and self.distance == 0.0


def _offset(value: float, lo: float, hi: float) -> float:
    return 0.0 if lo <= value <= hi else (value - hi if value > hi else value - lo)


def _followed_exit(curves: Sequence[BranchCurve], m: MeasuredSweep, first: int, direction: str):
    """The exit of the stable run the sweep's points before the jump (``first``: the index of
    the jump's first point) lie on, the nearest such point first; ``None`` if none does."""
    by_curve = [(c, branch_exits(c, direction)) for c in curves]
    for i in range(first, max(-1, first - LOOK_BACK), -1):
        x, y = float(m.value[i]), float(m.measure[i])
        best, err = None, MATCH
        for c, exits in by_curve:
            for e in exits:
                at = run_measure_at(c, e.span, x)
                if at is None:
                    continue
                rel = abs(at - y) / max(abs(at), abs(y), 1e-300)
                if rel <= err:
                    best, err = e, rel
        if best is not None:
            return best
    return None


def _contact_change(m: MeasuredSweep, i: int) -> str:
    if m.contact is None or i + 1 >= len(m.contact):
        return ""
    a, b = m.contact[i], m.contact[i + 1]
    if a is None or b is None or a == b:
        return ""
    return "leaves contact" if a else "makes contact"


def _cascade(curves: Sequence[BranchCurve], ex: BranchExit, lo: float, hi: float) -> BranchExit:
    """A period doubling past which another branch (the doubled one) doubles again before the
    jump is named a period-doubling cascade."""
    if ex.mechanism != "period-doubling":
        return ex
    a, b = sorted((ex.value, hi if ex.direction == "up" else lo))
    again = any(
        "period-doubling" in labs and a <= v <= b
        for c in curves
        if c.name != ex.branch
        for v, labs in zip(c.value, c.labels, strict=True)
    )
    if not again:
        return ex
    return replace(
        ex,
        mechanism="period-doubling cascade",
        words="period doubling (PD) and cascade (the doubled orbit doubles again)",
    )


def explain_jumps(curves: Sequence[BranchCurve], measured: Sequence[MeasuredSweep]) -> list[JumpExplanation]:
    """For every jump of every measured sweep, how the branches say the sweep leaves there
    (:class:`JumpExplanation`): the end, in the sweep's direction, of the stable run its points
    lie on (a fold, a grazing hairpin, a Neimark-Sacker point, a period doubling, another labelled
    event: :func:`rigtools.analysis.branch_exits.branch_exits`), else the end nearest to the jump,
    with its distance from the jump; and the nearest turning point of the direction's kind (a
    sweep up leaves a branch that turns back at an upper turning point, a sweep down at a lower
    one).

    Examples
    --------
    A branch that folds back at 64 Hz (stable, unstable back to 62.5 Hz, stable again) and a sweep up
    that jumps between 64 and 65 Hz: it leaves the branch at the fold.

    >>> import numpy as np
    >>> from rigtools.analysis.branches import BranchCurve, MeasuredSweep, explain_jumps
    >>> value = np.array([60.0, 61.0, 62.0, 63.0, 64.0, 63.5, 63.0, 62.5, 63.0, 64.0, 65.0])
    >>> measure = np.array([1.0, 1.3, 1.7, 2.2, 3.0, 2.6, 2.0, 1.2, 0.8, 0.6, 0.5])
    >>> stable = np.array([1, 1, 1, 1, 1, 0, 0, 0, 1, 1, 1], dtype=bool)
    >>> labels = [(), (), (), (), ("fold",), (), (), ("fold",), (), (), ()]
    >>> curve = BranchCurve(value, measure, stable, labels)
    >>> sweep = MeasuredSweep(value[[0, 1, 2, 3, 4, 10]], measure[[0, 1, 2, 3, 4, 10]], "up", jumps=[(64.0, 65.0)])
    >>> (jump,) = explain_jumps([curve], [sweep])
    >>> jump.exit.mechanism, jump.exit.value, jump.followed
    ('fold', 64.0, True)
    """
    points = [t for c in curves for t in turning_points(c)]
    out = []
    for m in measured:
        direction = "down" if m.direction == "down" else "up"
        values = [float(v) for v in m.value]
        for a, b in m.jumps:
            lo, hi = min(a, b), max(a, b)
            want = [t for t in points if t.upper == (direction == "up")] or points
            best = min(want, key=lambda t: abs(_offset(t.value, lo, hi)), default=None)
            first = next((i for i in range(len(values) - 1) if values[i] == a and values[i + 1] == b), None)
            ex = None if first is None else _followed_exit(curves, m, first, direction)
            followed = ex is not None
            if ex is None:
                exits = [e for c in curves for e in branch_exits(c, direction)]
                ex = min(exits, key=lambda e: abs(_offset(e.value, lo, hi)), default=None)
            if ex is not None:
                ex = _cascade(curves, ex, lo, hi)
            out.append(
                JumpExplanation(
                    m.name,
                    m.direction,
                    lo,
                    hi,
                    best,
                    _offset(best.value, lo, hi) if best is not None else float("nan"),
                    ex,
                    _offset(ex.value, lo, hi) if ex is not None else float("nan"),
                    followed,
                    "" if first is None else _contact_change(m, first),
                )
            )
    return out
