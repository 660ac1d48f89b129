"""Stored continued branches drawn (:func:`branches_figure`), with recorded sweeps
(:mod:`rigtools.measured_sweeps`) on the same axes: the curves of a branches file in one response
measure (:func:`branch_curves`) for :func:`rigtools.analysis.branches.branch_figure`."""

from __future__ import annotations

from rigtools.analysis.branches import BranchCurve, branch_figure
from rigtools.branches_file import MEASURES, X_LABELS, StoredBranch


def branch_curves(branches: list[StoredBranch], measure: str = "contact") -> list:
    """The non-empty stored branches as :class:`rigtools.analysis.branches.BranchCurve` in
    ``measure`` (a key of :data:`MEASURES`), named "period 1", "period 2"."""
    field_name, index, _ = MEASURES[measure]
    curves = []
    for b in branches:
        if not b.value.size:
            continue
        y = b.measures[field_name]
        curves.append(
            BranchCurve(
                b.value,
                y[:, index] if index is not None else y,
                b.stable,
                b.labels,
                f"period {b.periods}",
                b.measures.get("impacts_per_period"),
            )
        )
    return curves


def branches_figure(
    branches: list[StoredBranch], measure: str = "contact", title: str = "", measured=(), drive: bool = False
):
    """:func:`rigtools.analysis.branches.branch_figure` of stored branches, with the
    :func:`rigtools.measured_sweeps.measured_sweeps` given on the same axes (``drive``: a
    ``"force"`` axis is the drive amplitude, V)."""
    xlabel, scale = X_LABELS[branches[0].param] if branches else ("", 1.0)
    if drive and branches and branches[0].param == "force":
        xlabel = "drive amplitude (V)"
    return branch_figure(
        branch_curves(branches, measure),
        xlabel,
        MEASURES[measure][2],
        measured=measured,
        x_scale=scale,
        title=title,
    )
