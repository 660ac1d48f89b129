"""Saving the analysis layer's figures next to the files they describe.

matplotlib is switched to its non-interactive Agg backend on import, before anything could import
pyplot, so figures are written the same way on a desktop and on a headless CI machine.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

DPI = 100


def plot_path(out: Path) -> Path:
    """The figure written beside an output file: same name, ``.png``."""
    return Path(out).with_suffix(".png")


def save_figure(fig, path: Path, dpi: int = DPI) -> Path:
    """Write ``fig`` (a :class:`matplotlib.figure.Figure`) as PNG to ``path``; returns ``path``."""
    fig.savefig(path, dpi=dpi, format="png")
    return Path(path)
