"""Command-line option helpers shared by every ``rig`` sub-command: quantities with units and
output paths. Light on purpose (no scipy, h5py, numba): command modules import it at the top."""

from __future__ import annotations

import argparse
from pathlib import Path

from rigtools.errors import UserError
from rigtools.units import parse_quantity


def quantity(text: str, dimension: str, option: str) -> float:
    """Parse a CLI quantity (``"0.5 mm"``, ``"15 N"``; a plain number is SI) or raise a one-line
    :class:`UserError` naming the option."""
    try:
        return parse_quantity(text, dimension)
    except ValueError as exc:
        raise UserError(f"{option} = {text!r}: {exc}") from None


def check_out(args: argparse.Namespace) -> Path:
    """``args.out`` as a Path, refused with one line if its folder is missing or it exists without
    ``args.overwrite``."""
    out = Path(args.out)
    if not out.parent.exists():
        raise UserError(f"--out = {args.out!r}: folder {str(out.parent)!r} does not exist")
    if out.exists() and not getattr(args, "overwrite", False):
        raise UserError(f"--out = {args.out!r} exists; give --overwrite to replace it")
    return out
