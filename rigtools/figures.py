"""Saving matplotlib figures as PNG next to the files they describe, never over them (the naming
and safe-writing rule of derived files: :mod:`rigtools.derived_files`).

matplotlib is switched to its non-interactive Agg backend on import, before anything could import
pyplot, so figures are written the same way on a desktop and on a headless CI machine.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import matplotlib

import rigtools
from rigtools.derived_files import write_derived
from rigtools.errors import UserError

matplotlib.use("Agg")

DPI = 100


def save_figure(
    fig, path: str | os.PathLike, dpi: int = DPI, source: str | os.PathLike | None = None
) -> Path:
    """Write ``fig`` (a :class:`matplotlib.figure.Figure`) as PNG to ``path`` through
    :func:`write_derived` (marked ``Software: rigtools ...``); returns ``path``."""
    software = f"rigtools {rigtools.__version__} (matplotlib {matplotlib.__version__})"
    return write_derived(
        path,
        lambda tmp: fig.savefig(tmp, dpi=dpi, format="png", metadata={"Software": software}),
        source=source,
    )


def save_figures(
    named: Iterable[tuple[str, Any]],
    folder: str | os.PathLike,
    name: Callable[[str], str],
    *,
    source: str | os.PathLike | None = None,
    option: str = "--out",
) -> list[Path]:
    """Save figures as PNG into ``folder`` (made if missing), each as ``folder / name(key)`` through
    :func:`save_figure` (never over ``source``, a recording or a file rigtools did not make); each
    figure is closed once written.

    Parameters
    ----------
    named
        ``(key, figure)`` pairs.
    folder
        Where to write.
    name
        File name of a key, e.g. ``lambda k: f"run-{k}.png"``.
    source
        The file the figures describe.
    option
        The option that named the folder, for the message.
    """
    import matplotlib.pyplot as plt

    out = Path(folder)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"{option} {out}: cannot make the folder ({exc.strerror})") from None
    written = []
    for key, fig in named:
        try:
            written.append(save_figure(fig, out / name(key), source=source))
        finally:
            plt.close(fig)
    return written
