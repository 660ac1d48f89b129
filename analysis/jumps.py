"""Jumps of a stepped sine: steps the response leaves a branch at, told from a linear response.

A step between neighbouring points of one sweep direction is a jump when the response changes by
more than a threshold there (relative to the smaller of the two) AND something independent of
that change says the rig is not responding linearly across it (:func:`find_jumps`):

* ``"contact vanishes"`` / ``"contact appears"``: the shrouds touch on one side of the step and not
  on the other (the contact of each point: the model's impacts per period, or, on the rig,
  :func:`contact_seen` from the harmonics of the shroud accelerations);
* ``"hysteresis"``: the sweep in the other direction differs from this one by more than the
  threshold where the step leaves and agrees with it where the step lands (the jump takes the
  sweep onto the branch the other direction followed; a steep step that stays on its own branch
  inside the hysteresis loop is none);
* ``"discontinuity in contact"``: the shrouds touch on both sides and the step's change of
  log-response is :data:`CONTRAST` times that of each neighbouring step (a discontinuity between
  two impacting regimes, not the steep flank of a resonance).

The rig's only nonlinearity is the contact: a step with no contact on either side is linear,
whatever its change (a resonance passing between two coarse steps), and is never a jump. Without
the contact of the steps and with a sweep in one direction only, a step cannot be told from a
linear response: a lightly damped mode between two steps, or a mode beside an antiresonance,
gives any change and any neighbouring slopes. Such a step is no jump here.

Arrays in, small dataclasses out; no file I/O.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

CONTACT_RATIO = 0.05  # contact seen: shroud harmonics beyond this fraction of the active fundamental
CONTRAST = 2.0  # a step in contact is a discontinuity if its log-change is this times its neighbours'


@dataclass(frozen=True)
class Jump:
    """A jump between two neighbouring steps of one sweep direction.

    Attributes
    ----------
    start, stop
        The two steps' values in run order (the sweep leaves ``start`` and lands at ``stop``).
    change
        ``|y_stop - y_start| / min(y_start, y_stop)``.
    kind
        ``"up"`` (the response rises) or ``"down"``.
    evidence
        Why this is not a linear response: ``"contact vanishes"``, ``"contact appears"``,
        ``"hysteresis"`` or ``"discontinuity in contact"`` (the first that holds).
    """

    start: float
    stop: float
    change: float
    kind: str
    evidence: str

    def as_dict(self) -> dict:
        """``{"from_hz", "to_hz", "frequency_hz", "change", "kind", "evidence"}`` (the sweep's
        summary; the values are the swept parameter's, Hz for a frequency sweep)."""
        d = asdict(self)
        return {
            "from_hz": d.pop("start"),
            "to_hz": d.pop("stop"),
            "frequency_hz": 0.5 * (self.start + self.stop),
            **d,
        }


def contact_seen(active: Sequence[float], passive: Sequence[float] | None = None) -> bool:
    """Whether the shrouds touch at a step, from the harmonic amplitudes (k = 1, 2, ...) of the
    shroud accelerations: the active shroud's harmonics k >= 2 together, or the passive shroud's
    response (driven only through the contact), above :data:`CONTACT_RATIO` of the active
    fundamental. Without contact both stay at the noise (about 1e-5 of it on the simulated rig);
    with impacts they are a fifth of it and more."""
    a = np.abs(np.asarray(active, float))
    if a.size == 0 or not a[0] > 0:
        return False
    level = float(np.sqrt(np.sum(a[1:] ** 2)))
    if passive is not None:
        level = max(level, float(np.sqrt(np.sum(np.asarray(passive, float) ** 2))))
    return level > CONTACT_RATIO * float(a[0])


def _other_at(other: tuple[Sequence[float], Sequence[float]] | None, x: float) -> float | None:
    """The other direction's response at ``x``: its point there, else interpolated in log
    between its neighbours; ``None`` outside its range."""
    if other is None or len(other[0]) == 0:
        return None
    ox, oy = np.asarray(other[0], float), np.asarray(other[1], float)
    order = np.argsort(ox)
    ox, oy = ox[order], oy[order]
    if not ox[0] <= x <= ox[-1] or np.any(oy <= 0):
        return None
    return float(np.exp(np.interp(x, ox, np.log(oy))))


def _differ(a: float, b: float, threshold: float) -> bool:
    return abs(a - b) / max(min(a, b), 1e-300) > threshold


def find_jumps(
    values: Sequence[float],
    measure: Sequence[float],
    threshold: float,
    *,
    contact: Sequence[bool | None] | None = None,
    other: tuple[Sequence[float], Sequence[float]] | None = None,
) -> list[Jump]:
    """The jumps of one sweep direction (see the module's text for the criteria).

    Parameters
    ----------
    values, measure
        The steps in run order: swept value and response (> 0).
    threshold
        Relative change of the response between neighbouring steps called a jump when the
        evidence holds (0.3: 30 %).
    contact
        Per step: the shrouds touch (``True``), do not (``False``), unknown (``None``); ``None``:
        unknown everywhere.
    other
        The sweep in the other direction, ``(values, measure)``, for the hysteresis test.

    Examples
    --------
    A sweep up whose response falls by 73 % between 62 and 63 Hz as the shrouds stop touching:

    >>> from rigtools.analysis.jumps import find_jumps
    >>> fe = [60.0, 61.0, 62.0, 63.0, 64.0]
    >>> amplitude = [1.0, 1.2, 1.5, 0.4, 0.35]
    >>> find_jumps(fe, amplitude, 0.3, contact=[True, True, True, False, False])
    [Jump(start=62.0, stop=63.0, change=2.75, kind='down', evidence='contact vanishes')]
    """
    x = [float(v) for v in values]
    y = [float(v) for v in measure]
    touch = list(contact) if contact is not None else [None] * len(x)
    if not len(x) == len(y) == len(touch):
        raise ValueError("values, measure and contact must have one entry per step")
    d = np.abs(np.diff(np.log(np.maximum(np.asarray(y, float), 1e-300))))
    out = []
    for i in range(1, len(x)):
        a0, a1 = y[i - 1], y[i]
        change = abs(a1 - a0) / max(min(a0, a1), 1e-300)
        if not change > threshold:
            continue
        c0, c1 = touch[i - 1], touch[i]
        if c0 is False and c1 is False:
            continue  # linear on both sides: a resonance between the steps, never a jump
        evidence = ""
        if c0 is not None and c1 is not None and c0 != c1:
            evidence = "contact vanishes" if c0 else "contact appears"
        if not evidence:
            o0, o1 = _other_at(other, x[i - 1]), _other_at(other, x[i])
            if (
                o0 is not None
                and o1 is not None
                and _differ(o0, a0, threshold)
                and not _differ(o1, a1, threshold)
            ):
                evidence = "hysteresis"
        stands_out = all(d[i - 1] > CONTRAST * d[j] for j in (i - 2, i) if 0 <= j < d.size)
        if not evidence and c0 and c1 and stands_out:
            evidence = "discontinuity in contact"
        if evidence:
            out.append(Jump(x[i - 1], x[i], change, "up" if a1 > a0 else "down", evidence))
    return out
