"""Turning points of a branch and the measured jumps they explain (rigtools.analysis.branches), on
a branch built point by point: an S-curve in fe that rises to a fold at 71.64 Hz, comes back
(unstable) to a grazing corner at 64.41 Hz labelled two short steps before it turns, then rises
to 76 Hz; period doublings on the way that are no turning points."""

from __future__ import annotations

import numpy as np
import pytest

from rigtools.analysis.branches import BranchCurve, MeasuredSweep, explain_jumps, turning_points


def s_curve() -> BranchCurve:
    up = np.linspace(60.0, 71.64, 60)
    back = np.linspace(71.64, 64.4068, 40)[1:]
    corner = [64.40594, 64.40579]  # the corner past the grazing label: the branch still comes down
    on = np.linspace(64.4074, 76.0, 30)
    value = np.concatenate([up, back, corner, on])
    labels: list[tuple[str, ...]] = [()] * value.size
    labels[0], labels[-1] = ("start",), ("end",)
    labels[20] = ("period-doubling",)  # 63.9 Hz, on the rising part: no turning point
    labels[59] = ("fold",)
    labels[98] = ("grazing",)
    labels[110] = ("grazing",)  # a second grazing label where the branch passes monotonically
    stable = np.ones(value.size, bool)
    stable[60:99] = False
    return BranchCurve(value, np.arange(value.size, dtype=float), stable, labels)


def test_turning_points_are_the_fold_and_the_grazing_corner():
    turns = turning_points(s_curve())
    assert [(t.label, t.upper) for t in turns] == [("fold", True), ("grazing", False)]
    assert turns[0].value == 71.64 and turns[1].value == pytest.approx(64.4068, abs=1e-12)
    assert all(t.branch == "period 1" for t in turns)


def test_each_jump_is_explained_by_the_turning_point_its_direction_meets():
    sweeps = [
        MeasuredSweep(np.arange(62.0, 73.0), np.zeros(11), "up", "rig (up)", [(70.0, 71.0)]),
        MeasuredSweep(np.arange(72.0, 61.0, -1.0), np.zeros(11), "down", "rig (down)", [(64.0, 63.0)]),
        MeasuredSweep(np.arange(62.0, 73.0, 2.0), np.zeros(6), "up", "fem (up)", [(70.0, 72.0)]),
    ]
    up, down, inside = explain_jumps([s_curve()], sweeps)
    # the up sweep meets the fold: 0.64 Hz above the interval (70, 71)
    assert up.turning is not None and up.turning.label == "fold" and not up.inside
    assert (up.start, up.stop) == (70.0, 71.0) and up.offset == pytest.approx(0.64, abs=1e-12)
    # the down sweep meets the grazing corner (not the nearer-sounding fold): 0.4068 Hz above (63, 64)
    assert down.turning is not None and down.turning.label == "grazing" and not down.inside
    assert (down.start, down.stop) == (63.0, 64.0) and down.offset == pytest.approx(0.4068, abs=1e-9)
    assert inside.inside and inside.offset == 0.0 and inside.turning is not None
    assert inside.turning.value == 71.64


def test_a_branch_without_turning_points_explains_nothing():
    v = np.linspace(55.0, 58.0, 10)
    flat = BranchCurve(v, v, np.ones(10, bool), [("start",)] + [()] * 8 + [("end",)])
    assert turning_points(flat) == []
    (e,) = explain_jumps([flat], [MeasuredSweep(v, v, "up", "x", [(56.0, 57.0)])])
    assert e.turning is None and not e.inside and np.isnan(e.offset)


def torus_branch(ns_label: str = "neimark-sacker") -> BranchCurve:
    """The shape of the FEM's period-1 branch at gap 0.5 mm, 15 N (rig continuation, 55-80 Hz):
    impacting and stable up to a Neimark-Sacker point at 72.61 Hz, unstable (a torus) to a
    second one at 74.55 Hz, stable to the fold at 77.14 Hz, back unstable to the grazing
    hairpin at 68.44 Hz (fold and grazing), then without impacts and stable to 80 Hz."""
    a = np.linspace(66.0, 72.6, 40)
    b = np.linspace(72.61, 74.55, 20)  # 72.61 Hz: the first unstable point, labelled
    c = np.linspace(74.55, 77.14, 20)[1:]
    d = np.linspace(77.14, 68.44, 40)[1:]
    e = np.linspace(68.44, 80.0, 30)[1:]
    value = np.concatenate([a, b, c, d, e])
    n = value.size
    measure = np.concatenate(
        [
            np.linspace(80.0, 55.0, 40),
            np.full(20, 60.0),
            np.linspace(88.0, 74.0, 19),
            np.linspace(74.0, 1.0, 39),
        ]
    )
    measure = np.concatenate([measure, np.zeros(29)])
    stable = np.ones(n, bool)
    stable[40:59] = False  # the torus band: 72.61 Hz to 74.55 Hz (stable again)
    stable[79:117] = False  # fold to hairpin
    labels: list[tuple[str, ...]] = [()] * n
    labels[0], labels[-1] = ("start",), ("end",)
    labels[40] = (ns_label,) if ns_label else ()
    labels[59] = ("neimark-sacker",)
    labels[78] = ("fold",)
    labels[117] = ("fold", "grazing")
    contact = np.where(np.arange(n) < 117, 1.0, 0.0)
    return BranchCurve(value, measure, stable, labels, "period 1", contact)


def fem_up_sweep() -> MeasuredSweep:
    """The FEM study's up sweep (tests/analysis/test_jumps.py): on the branch to 72.6 Hz,
    quasi-periodic to 73.0 Hz, out of contact from 73.1 Hz."""
    x = np.array([70.0, 71.0, 72.0, 72.4, 72.6, 72.8, 72.9, 73.0, 73.1, 73.4])
    branch = torus_branch()
    y = np.interp(x, branch.value[:40], branch.measure[:40])
    y[5:8], y[8:] = 92.0, 0.0
    contact = [True] * 8 + [False] * 2
    return MeasuredSweep(x, y, "up", "fem (up)", [(73.0, 73.1)], contact)


def test_a_jump_past_a_neimark_sacker_point_is_explained_by_it():
    """The issue's case: the up sweep leaves contact between 73.0 and 73.1 Hz, 0.39 Hz after the
    Neimark-Sacker point at 72.61 Hz on the branch its points lie on; the fold, 4.04 Hz above
    the jump, is named as the nearest turning point, not as the mechanism."""
    from rigtools.report.branches import jump_sentences

    (e,) = explain_jumps([torus_branch()], [fem_up_sweep()])
    assert e.exit is not None and e.exit.mechanism == "neimark-sacker" and e.followed
    assert e.exit.value == 72.61 and e.distance == pytest.approx(72.61 - 73.0, abs=1e-12)
    assert e.exit.stable_again == 74.55 and e.contact == "leaves contact"
    assert e.turning is not None and e.turning.label == "fold" and e.offset == pytest.approx(4.04, abs=1e-12)
    first, second = jump_sentences([e], "fe")
    assert first.startswith("fem (up) leaves contact in a jump between 73 Hz and 73.1 Hz, 0.39 Hz after")
    assert "Neimark-Sacker point (NS) at 72.61 Hz" in first and "torus" in first
    assert "unstable up to 74.55 Hz" in first
    assert (
        second == "The model's nearest upper turning point, its fold (LP) at 77.14 Hz, lies 4.04 Hz above it."
    )


def test_a_down_jump_at_the_grazing_hairpin_and_labels_the_matcher_does_not_know():
    """Down from 80 Hz without impacts the sweep makes contact between 69 and 68 Hz: the grazing
    hairpin (labelled fold and grazing) at 68.44 Hz inside the jump. A loss of stability with
    a label of another vocabulary is named as spelt ("contact-split"), a grazing one as grazing,
    none as an unlabelled loss."""
    x = np.arange(80.0, 66.5, -1.0)
    y = np.where(x > 68.5, 0.0, 70.0)
    down = MeasuredSweep(x, y, "down", "fem (down)", [(69.0, 68.0)], list(x < 68.5))
    (e,) = explain_jumps([torus_branch()], [down])
    assert e.exit is not None and e.exit.mechanism == "grazing hairpin" and e.exit.turning
    assert e.exit.value == pytest.approx(68.44, abs=1e-12) and e.distance == 0.0 and e.exit_inside
    assert e.contact == "makes contact" and e.followed
    for label, mechanism, words in [
        ("contact-split", "contact-split", "contact split event"),
        ("grazing-sliding", "grazing", "grazing sliding (a non-smooth event: impacts begin or end there)"),
        ("", "loss of stability", "loss of stability (no bifurcation labelled there)"),
    ]:
        (e,) = explain_jumps([torus_branch(label)], [fem_up_sweep()])
        assert e.exit is not None and (e.exit.mechanism, e.exit.words) == (mechanism, words)
        # at the labelled point, or without a label at the run's last stable point
        assert e.exit.value == (72.61 if label else 72.6)


def test_a_period_doubling_followed_by_another_is_a_cascade():
    """The exit labelled period-doubling, and the period-2 branch born there doubling again
    before the jump: a period-doubling cascade."""
    p1 = torus_branch("period-doubling")
    v2 = np.linspace(72.61, 73.5, 10)
    labels2: list[tuple[str, ...]] = [("branch-switch",)] + [()] * 9
    labels2[4] = ("period-doubling",)  # 73.01 Hz
    p2 = BranchCurve(v2, np.full(10, 90.0), np.ones(10, bool), labels2, "period 2")
    (e,) = explain_jumps([p1, p2], [fem_up_sweep()])
    assert e.exit is not None and e.exit.mechanism == "period-doubling cascade"
    assert e.exit.value == 72.61


def test_a_fold_labelled_on_its_first_unstable_point_is_a_turning_point():
    """The continuation labels a fold where the multiplier has crossed +1: often the first
    unstable point, past the run's last stable one. The exit is still the fold, a turning
    point, at the labelled 71.64 Hz (the 0.7 mm branch of the demo does this)."""
    from rigtools.analysis.branch_exits import branch_exits

    c = s_curve()
    stable = np.asarray(c.stable).copy()
    stable[59] = False  # the labelled fold itself unstable
    c = BranchCurve(c.value, c.measure, stable, c.labels)
    (fold,) = [e for e in branch_exits(c, "up") if e.mechanism == "fold"]
    assert fold.turning and fold.value == 71.64 and fold.span == (0, 58)


def test_labels_near_each_other_are_stacked_not_printed_over_each_other():
    """Issue 29: three PD labels at 60.6 Hz printed over each other. Labels within the spacing
    (axes fractions) of one placed before go a line below or above; labels apart stay put."""
    from rigtools.analysis.branches import LABEL_SPACING, label_offsets

    dx = LABEL_SPACING[0]
    assert label_offsets([(0.5, 0.5), (0.5, 0.5), (0.501, 0.5)]) == [0, -1, 1]
    assert label_offsets([(0.1, 0.5), (0.1 + 2 * dx, 0.5), (0.9, 0.1)]) == [0, 0, 0]


def test_branch_figure_legend_is_beside_the_axes_never_over_a_branch():
    """#31: the legend was placed by matplotlib's "best" over the unstable (dashed) part of the
    demo's branch figure. It now sits outside the axes: its drawn box and the axes' box must not
    overlap at all (pixel extents after a draw; no tolerance needed, disjoint or not)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from rigtools.analysis.branches import BranchCurve, MeasuredSweep, branch_figure

    f = np.linspace(60.0, 70.0, 41)
    a = 1.0 / np.abs(65.0 - f + 0.5j)  # a resonance-like hump filling the axes
    curve = BranchCurve(f, a, f < 65.0, [() for _ in f])
    sweep = MeasuredSweep(f[::4], a[::4], jumps=[(64.0, 65.0)])
    fig = branch_figure([curve], "fe (Hz)", "A (mm)", measured=[sweep])
    FigureCanvasAgg(fig).draw()
    ax = fig.axes[0]
    legend_box = ax.get_legend().get_window_extent()
    axes_box = ax.get_window_extent()
    assert legend_box.x0 >= axes_box.x1  # entirely to the right of the plotting area
    assert fig.bbox.contains(legend_box.x1 - 1, legend_box.y0 + 1)  # and still inside the figure
