"""The one memory check: refuse up front, in one line with the estimate, work that would not fit
in the memory this machine has available. Standard library only (command modules import it)."""

from __future__ import annotations

import math
import os

from rigtools.errors import UserError

USABLE_FRACTION = 0.8  # of the available memory a run may take (the rest: the OS, other programs)


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (Linux ``MemAvailable``, else
    ``os.sysconf``), ``None`` if unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def check_memory(needed: float, what: str, hint: str, *, available: int | None = None) -> None:
    """Refuse work that needs more than :data:`USABLE_FRACTION` of the available memory.

    Parameters
    ----------
    needed
        Estimated peak bytes of the work.
    what
        What is estimated, for the message, e.g. ``"the FE model (800 + 800 elements)"``.
    hint
        What the user can change, e.g. ``"shorten --duration"``.
    available
        Bytes available; default :func:`available_memory` (no check when it is unknown).

    Raises
    ------
    UserError
        ``"{what} needs about X GB of memory, Y GB are available: {hint}"``.
    """
    if not math.isfinite(float(needed)):
        raise UserError(f"{what}: too large to hold in memory: {hint}")
    avail = available_memory() if available is None else available
    if avail is not None and needed > USABLE_FRACTION * avail:
        raise UserError(
            f"{what} needs about {needed / 1e9:.3g} GB of memory, {avail / 1e9:.3g} GB are available: {hint}"
        )
