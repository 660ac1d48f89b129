"""The Examples sections of the docstrings run as doctests.

Every module of the four packages (``rigtools``, ``rigtools.drivers``, ``rigtools.sim``,
``rigtools.analysis``) whose source holds a ``>>>`` example is collected, imported and run with
:mod:`doctest`, one test per module, in a fresh temporary folder (examples that write a file write
it there). A new Examples section is picked up without editing this file. An example that needs
hardware carries ``# doctest: +SKIP`` and says why in the text before it.
"""

from __future__ import annotations

import doctest
import importlib
import importlib.util
import pkgutil
from pathlib import Path

import pytest

PACKAGES = ("rigtools", "rigtools.drivers", "rigtools.sim", "rigtools.analysis")
OPTIONS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def all_modules() -> list[str]:
    """Every module of the four packages, packages included (names as installed: rigtools.x)."""
    names: set[str] = set()
    for package in PACKAGES:
        names.add(package)
        path = importlib.import_module(package).__path__
        names.update(info.name for info in pkgutil.walk_packages(path, prefix=package + "."))
    return sorted(names)


def has_examples(name: str) -> bool:
    spec = importlib.util.find_spec(name)
    assert spec is not None and spec.origin is not None, name
    return ">>>" in Path(spec.origin).read_text(encoding="utf-8")


MODULES = all_modules()
WITH_EXAMPLES = [name for name in MODULES if has_examples(name)]


def test_every_package_and_the_known_examples_are_collected():
    """The walk reaches all four packages' modules (in a checkout the three sibling folders too)
    and finds the modules known to hold examples."""
    for name in ("rigtools.recording.writer", "rigtools.drivers.nidaq", "rigtools.sim.harmonic"):
        assert name in MODULES
    known = {
        "rigtools.runtime",
        "rigtools.acquisition",
        "rigtools.recording.writer",
        "rigtools.drivers.drive_signals",
        "rigtools.drivers.nidaq",
        "rigtools.workflows",  # the front door's functions and results
        "rigtools.experiments",
        "rigtools.quantity_fields",
        "rigtools.procedures.reference",
    }
    assert known <= set(WITH_EXAMPLES)


@pytest.mark.parametrize("name", WITH_EXAMPLES)
def test_docstring_examples(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    module = importlib.import_module(name)
    tests = doctest.DocTestFinder(exclude_empty=True).find(module, name)
    assert tests, f"{name}: '>>>' in the source but no doctest found in its docstrings"
    runner = doctest.DocTestRunner(optionflags=OPTIONS)
    report: list[str] = []
    for test in sorted(tests, key=lambda t: t.name):
        runner.run(test, out=report.append)
    assert runner.failures == 0, "".join(report)
