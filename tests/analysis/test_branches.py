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


def test_labels_near_each_other_are_stacked_not_printed_over_each_other():
    """Issue 29: three PD labels at 60.6 Hz printed over each other. Labels within the spacing
    (axes fractions) of one placed before go a line below or above; labels apart stay put."""
    from rigtools.analysis.branches import LABEL_SPACING, label_offsets

    dx = LABEL_SPACING[0]
    assert label_offsets([(0.5, 0.5), (0.5, 0.5), (0.501, 0.5)]) == [0, -1, 1]
    assert label_offsets([(0.1, 0.5), (0.1 + 2 * dx, 0.5), (0.9, 0.1)]) == [0, 0, 0]
