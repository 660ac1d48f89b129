"""Saving matplotlib figures as PNG next to the files they describe, never over them (the naming
and safe-writing rule of derived files: :mod:`rigtools.derived_files`).

matplotlib is switched to its non-interactive Agg backend on import, before anything could import
pyplot, so figures are written the same way on a desktop and on a headless CI machine.
"""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib

from rigtools.derived_files import write_derived

matplotlib.use("Agg")

DPI = 100


def save_figure(
    fig, path: str | os.PathLike, dpi: int = DPI, source: str | os.PathLike | None = None
) -> Path:
    """Write ``fig`` (a :class:`matplotlib.figure.Figure`) as PNG to ``path`` through
    :func:`write_derived` (marked ``Software: rigtools ...``); returns ``path``."""
    import rigtools

    software = f"rigtools {rigtools.__version__} (matplotlib {matplotlib.__version__})"
    return write_derived(
        path,
        lambda tmp: fig.savefig(tmp, dpi=dpi, format="png", metadata={"Software": software}),
        source=source,
    )
