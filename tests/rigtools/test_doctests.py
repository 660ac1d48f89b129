"""The Examples sections of the front door run as doctests (short runs on the simulated rig)."""

import doctest
import importlib

import pytest

MODULES = [
    "rigtools.config",
    "rigtools.errors",
    "rigtools.recording.reader",
    "rigtools.analyze",
    "rigtools.quantity_fields",
    "rigtools.procedures.reference",
    "rigtools.experiments",
    "rigtools.workflows",
]


@pytest.mark.parametrize("name", MODULES)
def test_examples_run(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    module = importlib.import_module(name)
    result = doctest.testmod(
        module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False
    )
    assert result.attempted > 0, f"{name} has no examples"
    assert result.failed == 0, (
        f"{result.failed} of {result.attempted} examples of {name} failed (output above)"
    )
