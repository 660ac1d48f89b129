"""UFF direction codes as text: the one rule that UFF files and FRF sets share (record 6, fields 6
and 9 of a UFF 58 record; an FRF set's ``points`` table)."""

from __future__ import annotations

#: UFF direction codes (record 6, fields 6 and 9): 1..6 are +X, +Y, +Z, +RX, +RY, +RZ, a negative
#: code the opposite sense (-3 is -Z), 0 a scalar (no direction)
DIRECTIONS = ("X", "Y", "Z", "RX", "RY", "RZ")


def direction_text(code: int | None) -> str:
    """A UFF direction code as text (:data:`DIRECTIONS`): ``3`` is ``"+Z"``, ``-4`` is ``"-RX"``;
    0 (scalar), None and codes outside -6..6 are ``""``."""
    if not code or abs(int(code)) > len(DIRECTIONS):
        return ""
    return ("+" if code > 0 else "-") + DIRECTIONS[abs(int(code)) - 1]
