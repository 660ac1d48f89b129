"""What a model update moved that its data did not measure.

A fit to the modes one test saw (the active blade's flexural modes in a band) changes parameters
that every mode depends on: the root stiffness moves the passive blade's modes and the edgewise
and torsional modes too, which no target holds. :func:`moved_not_measured` compares the model's
modes before and after the fit (:func:`rigtools.sim.natural_frequencies.blade_mode_table`: the
lowest FE modes of both blades with their kind) and names every mode that moved and was not a
target, with why the data could not see it.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass

from rigtools.sim.natural_frequencies import BLADES, blade_mode_table
from rigtools.sim.params import RigParams

MOVED = 1e-3  # relative change of a frequency called moved: the fit's own frequency uncertainty (0.1 %)
N_MODES = 8  # FE modes of each blade compared (as rig modal lists), more if the targets go higher


@dataclass(frozen=True)
class UnmeasuredMode:
    """A mode the fit moved that no target measured.

    Attributes
    ----------
    blade
        ``"active"`` or ``"passive"``.
    kind, order
        ``"flexural"``, ``"edgewise"``, ``"torsional"`` or ``"axial"``, and its order among the
        blade's modes of that kind (edgewise 1: the lowest edgewise mode).
    before_hz, after_hz
        The model's frequency before and after the fit.
    why
        Why the data did not determine it: the blade has no measured mode, the mode lies outside
        the band fitted, or it lies inside but was not identified (a flexural mode) or cannot be
        (a mode of another kind: the test measures the flexural direction).
    """

    blade: str
    kind: str
    order: int
    before_hz: float
    after_hz: float
    why: str

    @property
    def change(self) -> float:
        """``after / before - 1``."""
        return self.after_hz / self.before_hz - 1.0

    @property
    def label(self) -> str:
        """``"passive flexural 1"``."""
        return f"{self.blade} {self.kind} {self.order}"

    def as_dict(self) -> dict:
        return {**asdict(self), "change": self.change}


def _by_kind(rows: list[dict]) -> dict[tuple[str, int], float]:
    seen: dict[str, int] = {}
    out = {}
    for r in rows:
        seen[r["kind"]] = seen.get(r["kind"], 0) + 1
        out[(r["kind"], seen[r["kind"]])] = float(r["frequency_hz"])
    return out


def moved_not_measured(
    before: RigParams,
    after: RigParams,
    measured: Iterable[tuple[str, int]],
    band: tuple[float, float] | None = None,
) -> list[UnmeasuredMode]:
    """The modes of both blades the fit moved by more than :data:`MOVED` that were no target.

    Parameters
    ----------
    before, after
        The rig before and after the fit.
    measured
        The targets: ``(blade, flexural order)`` pairs.
    band
        The band the modes were identified in, Hz (``None``: not known).

    Returns
    -------
    list of UnmeasuredMode
        By blade, then frequency before the fit.
    """
    targets = {(str(b), int(k)) for b, k in measured}
    n = max([N_MODES] + [3 * k for _, k in targets])
    # a few more modes after the fit: a mode it raised stays in the list
    old, new = blade_mode_table(before, n)["fem"], blade_mode_table(after, n + 4)["fem"]
    out = []
    for blade in BLADES:
        a, b = _by_kind(old[blade]), _by_kind(new[blade])
        seen_blade = any(t[0] == blade for t in targets)
        for (kind, order), f0 in sorted(a.items(), key=lambda kv: kv[1]):
            if (kind, order) not in b or (kind == "flexural" and (blade, order) in targets):
                continue
            f1 = b[(kind, order)]
            if abs(f1 / f0 - 1.0) <= MOVED:
                continue
            if not seen_blade:
                why = f"no mode of the {blade} blade was measured"
            elif band is not None and not (band[0] <= f0 <= band[1] and band[0] <= f1 <= band[1]):
                why = f"outside the band fitted ({band[0]:g}-{band[1]:g} Hz)"
            elif kind == "flexural":
                why = "in the band fitted but not identified in the data"
            else:
                article = "an" if kind[0] in "aeiou" else "a"
                why = f"{article} {kind} mode: the test measures the flexural direction"
            out.append(UnmeasuredMode(blade, kind, order, f0, f1, why))
    return out


def summary_line(modes: Sequence[UnmeasuredMode]) -> str:
    """One line naming the modes a fit moved that its data did not measure."""
    items = ", ".join(f"{m.label} {m.before_hz:.1f} -> {m.after_hz:.1f} Hz" for m in modes)
    return f"moved by the fit, not measured: {items} (the data did not determine them)"


def header_lines(modes: Sequence[UnmeasuredMode]) -> list[str]:
    """The same, one mode a line with why it was not measured (an updated rig file's header)."""
    if not modes:
        return []
    return ["moved by the fit, not measured (the data did not determine them):"] + [
        f"  {m.label}: {m.before_hz:.2f} -> {m.after_hz:.2f} Hz ({m.why})" for m in modes
    ]
