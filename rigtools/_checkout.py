"""Import ``rigtools.drivers``, ``rigtools.sim`` and ``rigtools.analysis`` from a source checkout.

Installed (wheel or editable), the three folders sit inside the ``rigtools`` package. When Python
finds the repository's own ``rigtools/`` first (the current directory is the repository's root),
they are its siblings; this finder maps exactly those three names to the sibling folders.
"""

import importlib.abc
import importlib.machinery
import importlib.util
import sys
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType

SIBLINGS = ("drivers", "sim", "analysis")


class _SiblingFinder(importlib.abc.MetaPathFinder):
    def __init__(self, root: Path) -> None:
        self.root = root

    def find_spec(
        self,
        fullname: str,
        path: Sequence[str] | None,
        target: ModuleType | None = None,
    ) -> importlib.machinery.ModuleSpec | None:
        head, _, name = fullname.partition(".")
        if head != "rigtools" or name not in SIBLINGS:
            return None
        folder = self.root / name
        return importlib.util.spec_from_file_location(
            fullname, folder / "__init__.py", submodule_search_locations=[str(folder)]
        )


def install_sibling_finder(root: Path) -> None:
    """Map ``rigtools.drivers``/``.sim``/``.analysis`` to the folders beside ``rigtools/`` in ``root``."""
    if not any(isinstance(f, _SiblingFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, _SiblingFinder(root))
