"""Where the tests find what lies outside the repository, and the one rule for when it is absent
(imported by ``tests/conftest.py`` and by test modules; a module of its own, since a test module's
``from conftest import`` meets whichever of the suite's conftest files was imported last)."""

import os
from pathlib import Path
from typing import NoReturn

import pytest

PUBLIC_DATA = Path(
    os.environ.get("RIGTOOLS_PUBLIC_DATA") or Path(__file__).resolve().parents[1].parent / "shared" / "data"
)
"""The public measured data sets: ``../shared/data`` next to the project root (README there), or
the folder ``RIGTOOLS_PUBLIC_DATA`` names (a git worktree elsewhere)."""


def missing(what: str, variable: str) -> NoReturn:
    """Skip the test because ``what`` is missing, or fail it when ``variable`` is set to 1."""
    if os.environ.get(variable) == "1":
        pytest.fail(f"{what} ({variable}=1 asks for it)")
    pytest.skip(f"{what}; set {variable}=1 to make this a failure")
