"""Where a sweep leaves a continued branch, and by which mechanism.

A slow sweep follows a stable part of a branch (a run of stable points) until that run ends in
the sweep's direction: the branch turns back (a fold, a grazing hairpin) or goes on unstable (a
Neimark-Sacker point: a torus, quasi-periodic motion; a period doubling, maybe a cascade; a
non-smooth event). :func:`branch_exits` lists these ends with the mechanism the branch's labels
name there; :data:`MECHANISMS` maps a label to its mechanism, and a label it does not know is named
as the branch spells it, so a new label vocabulary needs no change here to be reported.

Arrays in (:class:`rigtools.analysis.branches.BranchCurve`), small dataclasses out; no file I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: branch label -> (mechanism, the words a sentence names it by)
MECHANISMS = {
    "fold": ("fold", "fold (LP)"),
    "grazing": ("grazing", "grazing corner (G: impacts begin or end there)"),
    "neimark-sacker": ("neimark-sacker", "Neimark-Sacker point (NS)"),
    "period-doubling": ("period-doubling", "period doubling (PD)"),
}
#: labels that mark where a branch starts, ends or was switched, not a change of the orbit
NOT_EVENTS = frozenset({"start", "end", "branch-switch", "switch", "failed", "merged", "closed"})
#: order in which the labels at a loss of stability name it (a label not listed comes after)
PRIORITY = ("neimark-sacker", "period-doubling", "fold", "grazing")
NEAR = 2  # branch points on either side of a run's end whose labels name its mechanism


def mechanism_of(label: str) -> tuple[str, str]:
    """``(mechanism, words)`` of a branch label: :data:`MECHANISMS`, else a label naming a
    grazing (``"grazing-..."``) is a grazing event, and any other is named as spelt
    (``"contact-split"`` -> ``("contact-split", "contact split event")``)."""
    if label in MECHANISMS:
        return MECHANISMS[label]
    plain = label.replace("-", " ").replace("_", " ")
    if "graz" in label:
        return "grazing", f"{plain} (a non-smooth event: impacts begin or end there)"
    return label, f"{plain} event"


@dataclass(frozen=True)
class BranchExit:
    """Where a stable run of a branch ends in a sweep's direction.

    Attributes
    ----------
    value
        The parameter at the labelled point that names the mechanism (the bifurcation as the
        branch locates it), else at the run's last stable point in the sweep direction.
    direction
        ``"up"`` or ``"down"``.
    mechanism, words
        What ends the run (:func:`mechanism_of`; at a turning point ``"fold"`` or ``"grazing
        hairpin"``; an unlabelled loss ``"loss of stability"``) and the words for it.
    labels
        The event labels found at the run's end.
    branch
        The branch's name (``"period 1"``).
    turning
        The branch turns back there (a sweep has nowhere to go on it).
    in_contact
        The orbit impacts at the run's end (``None``: the branch does not say).
    stable_again
        Past a loss of stability, where the branch is stable again (the end of a torus band), or
        ``None``.
    span
        The run's first and last branch index (in branch order).
    """

    value: float
    direction: str
    mechanism: str
    words: str
    labels: tuple[str, ...]
    branch: str
    turning: bool
    in_contact: bool | None
    stable_again: float | None
    span: tuple[int, int]


def _runs(stable: np.ndarray) -> list[tuple[int, int]]:
    """Maximal runs of consecutive stable points, ``(first, last)`` inclusive."""
    out, start = [], None
    for i, s in enumerate(stable):
        if s and start is None:
            start = i
        if not s and start is not None:
            out.append((start, i - 1))
            start = None
    if start is not None:
        out.append((start, len(stable) - 1))
    return out


def _name(labels: list[str], turning: bool) -> tuple[str, str, str]:
    """``(mechanism, words, the label naming it or "")``."""
    if turning:
        grazing = next((lab for lab in labels if "graz" in lab), "")
        if grazing:
            return (
                "grazing hairpin",
                "grazing hairpin (G: the branch turns back where impacts begin or end)",
                grazing,
            )
        if "fold" in labels or not labels:
            return (*MECHANISMS["fold"], "fold" if labels else "")
    if not labels:
        return "loss of stability", "loss of stability (no bifurcation labelled there)", ""
    ranked = sorted(labels, key=lambda lab: PRIORITY.index(lab) if lab in PRIORITY else len(PRIORITY))
    return (*mechanism_of(ranked[0]), ranked[0])


def _extreme(v: np.ndarray, i: int, sign: float) -> bool:
    """Point ``i`` is a turning point of the branch in the sweep's sense (both neighbours behind)."""
    return 0 < i < v.size - 1 and sign * (v[i] - v[i - 1]) >= 0 and sign * (v[i] - v[i + 1]) >= 0


def branch_exits(curve, direction: str) -> list[BranchExit]:
    """The ends of the stable runs of ``curve`` in a sweep's ``direction`` (``"up"``: increasing
    parameter), where the branch continues (turning back or unstable); a run that reaches the
    end of the computed branch has no exit. In branch order."""
    v = np.asarray(curve.value, float)
    stable = np.asarray(curve.stable, bool)
    sign = -1.0 if direction == "down" else 1.0
    contact = None if getattr(curve, "contact", None) is None else np.asarray(curve.contact, float)
    out = []
    for s, e in _runs(stable):
        k = s + int(np.argmax(sign * v[s : e + 1]))
        # the neighbours of k along the branch, and whether the branch goes on past k
        nxt = [j for j in (k - 1, k + 1) if 0 <= j < v.size]
        beyond = [j for j in nxt if sign * (v[j] - v[k]) > 0]
        turning = not beyond and len(nxt) == 2
        if not beyond and not turning:
            continue  # the run reaches the end of the computed branch
        lo, hi = max(0, k - NEAR), min(v.size, k + NEAR + 1)
        labels = list(
            dict.fromkeys(lab for i in range(lo, hi) for lab in curve.labels[i] if lab not in NOT_EVENTS)
        )
        mechanism, words, label = _name(labels, turning)
        # the bifurcation where the branch locates it (the labelled point), else the run's end
        at = min((i for i in range(lo, hi) if label in curve.labels[i]), key=lambda i: abs(i - k), default=k)
        if not turning and label in ("fold", "grazing") and _extreme(v, at, sign):
            # a fold located on the first unstable point past the last stable one: the branch turns there
            turning = True
            mechanism, words, _ = _name(labels, True)
        again = None
        if beyond:
            step = beyond[0] - k
            j = beyond[0]
            while 0 <= j < v.size and not stable[j]:
                j += step
            again = float(v[j]) if 0 <= j < v.size else None
        out.append(
            BranchExit(
                float(v[at]),
                "down" if sign < 0 else "up",
                mechanism,
                words,
                tuple(labels),
                curve.name,
                turning,
                None if contact is None else bool(contact[k] > 0),
                again,
                (s, e),
            )
        )
    return out


def run_measure_at(curve, span: tuple[int, int], x: float) -> float | None:
    """The measure of the stable run ``span`` of ``curve`` at parameter ``x`` (linear between its
    points), ``None`` if ``x`` lies outside the run."""
    s, e = span
    v = np.asarray(curve.value, float)[s : e + 1]
    y = np.asarray(curve.measure, float)[s : e + 1]
    if v.size == 0 or not v.min() <= x <= v.max():
        return None
    order = np.argsort(v, kind="stable")
    return float(np.interp(x, v[order], y[order]))
