"""Numbers as a person reads them: the one rule of every table ``rig`` prints (terminal, the HTML
report, ``rig info``) and of the live monitor.

- A number is shown to :data:`DIGITS` significant digits, or with a fixed format a column names
  (``".2f"`` for natural frequencies in Hz, ``"+.1f"`` for a difference in %); never ``-0``.
- A harmonic amplitude at or below :data:`rigtools.analysis.harmonics.ROUND_OFF` (1e-9) times the
  largest harmonic of its channel is the round-off of a zero (the k >= 2 harmonics of a model's
  force ``F0 sin``, of a drive written as a pure sine) and is shown as :data:`ROUND_OFF_TEXT`, never
  as a value such as ``2.67e-15``. The rule is relative to the channel's largest harmonic: a
  measured record's noise lies many decades above it, so only an exact zero's round-off is caught.
- A missing or non-finite value is ``–``; a boolean is ``yes``/``no``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

from rigtools.analysis.harmonics import ROUND_OFF

#: Significant digits of a number shown to a person (terminal, HTML report, rig info, monitor).
DIGITS = 4
#: How a harmonic that is zero but for round-off is shown.
ROUND_OFF_TEXT = "0 (round-off)"
#: Shown for a missing or non-finite value.
MISSING = "–"

#: Fixed formats of columns shown the same way in the terminal and in the HTML report.
NATURAL_HZ = ".2f"  # a natural frequency, Hz (0.01 Hz: the resolution a mode table is read to)
NATURAL_PCT = "+.2f"  # a natural frequency's difference, %
HARMONIC_PCT = "+.1f"  # a harmonic amplitude's difference, %
SCORE = ".3f"  # an agreement score or error in decades
SMALL_PCT = "+.3f"  # a difference in % between two models of one blade (hundredths of a percent)
#: The natural-frequency tables' columns (``rig analyze``, ``rig compare`` and the report alike).
FREQUENCY_TABLE = {
    "fem_hz": NATURAL_HZ,
    "am_hz": NATURAL_HZ,
    "em_hz": NATURAL_HZ,
    "article_hz": NATURAL_HZ,
    "fem_vs_em_pct": NATURAL_PCT,
    "am_vs_em_pct": NATURAL_PCT,
    "am_vs_fem_pct": SMALL_PCT,
    "em_vs_article_pct": SMALL_PCT,
}


class Shown(str):
    """A number already written by these rules: a table sets it as a number (right-aligned)."""

    __slots__ = ()


def shown(value: Any, spec: str | None = None) -> Shown:
    """:func:`number` as a :class:`Shown` (for a table that would format a number itself)."""
    return Shown(number(value, spec))


def _finite(value: Any) -> float | None:
    if value is None or isinstance(value, (bool, str)):
        return None
    try:
        x = float(value)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def number(value: Any, spec: str | None = None, unit: str = "") -> str:
    """A value as a person reads it.

    Parameters
    ----------
    value
        A number, a boolean, ``None`` or text (returned as it is).
    spec
        A format spec (``".2f"``, ``"+.1f"``); default :data:`DIGITS` significant digits. An
        integer is shown whole unless a spec is given.
    unit
        Appended after a space to a number.

    Returns
    -------
    str
        ``–`` for ``None``/NaN/inf, ``yes``/``no`` for a boolean; a zero never carries a minus sign.

    Examples
    --------
    >>> number(14.99132), number(-0.0), number(-0.004, ".1f"), number(float("nan")), number(True)
    ('14.99', '0', '0.0', '–', 'yes')
    >>> number(60.0, unit="Hz"), number(0.331, "+.1f"), number(51200.0), number(123456.0)
    ('60 Hz', '+0.3', '51200', '123500')
    """
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, str):
        return value
    if isinstance(value, int) and spec is None:
        text = str(value)
    else:
        x = _finite(value)
        if x is None:
            return MISSING if value is None or _is_number(value) else str(value)
        if spec is None and 10**DIGITS <= abs(x) < 1e15:
            text = f"{float(f'{x:.{DIGITS}g}'):.0f}"  # 51200, not 5.12e+04
        else:
            text = format(x, spec or f".{DIGITS}g")
        if _all_zero(text):
            text = text.replace("-", "+" if spec and "+" in spec else "")
    return f"{text} {unit}" if unit else text


def _is_number(value: Any) -> bool:
    try:
        float(value)
    except (TypeError, ValueError):
        return False
    return True


def _all_zero(text: str) -> bool:
    mantissa = text.lower().split("e")[0]
    return all(c in "+-0." for c in mantissa)


def largest(values: Iterable[Any]) -> float:
    """The largest finite magnitude of ``values`` (0 when there is none)."""
    finite = [abs(x) for x in (_finite(v) for v in values) if x is not None]
    return max(finite, default=0.0)


def is_round_off(value: Any, channel_largest: float) -> bool:
    """True when ``value`` is at or below :data:`ROUND_OFF` times ``channel_largest`` (> 0)."""
    x = _finite(value)
    return x is not None and channel_largest > 0 and abs(x) <= ROUND_OFF * channel_largest


def harmonic(value: Any, channel_largest: float, spec: str | None = None, unit: str = "") -> str:
    """A harmonic amplitude: :data:`ROUND_OFF_TEXT` when it is the round-off of a zero relative to
    its channel's largest harmonic ``channel_largest``, else :func:`number`.

    Examples
    --------
    >>> harmonic(2.67e-15, 15.0), harmonic(0.9137, 15.0), harmonic(9.2e-17, 1.021, unit="V")
    ('0 (round-off)', '0.9137', '0 (round-off)')
    """
    if is_round_off(value, channel_largest):
        return ROUND_OFF_TEXT
    return number(value, spec, unit)


def harmonics(
    values: Sequence[Any], spec: str | None = None, channel_largest: float | None = None
) -> list[str]:
    """One channel's harmonic amplitudes as :func:`harmonic` shows them, relative to the largest of
    ``values`` (or ``channel_largest`` when only some of the channel's harmonics are given)."""
    top = largest(values) if channel_largest is None else channel_largest
    return [harmonic(v, top, spec) for v in values]
