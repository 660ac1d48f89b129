"""The Examples sections of the docstrings run as doctests.

Every module of the four packages (``rigtools``, ``rigtools.drivers``, ``rigtools.sim``,
``rigtools.analysis``) whose source holds a ``>>>`` example is collected, imported and run with
:mod:`doctest`, one test per module, in a fresh temporary folder (examples that write a file write
it there). A new Examples section is picked up without editing this file. An example that needs
hardware carries ``# doctest: +SKIP`` and says why in the text before it.

Examples show their output (:func:`test_every_example_shows_what_it_computes`): each docstring
shows at least one result, and nothing an example computes is left unseen.
"""

from __future__ import annotations

import ast
import doctest
import importlib
import importlib.util
import pkgutil
import re
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
        "rigtools.point_spectrum",  # the front door's functions and results
        "rigtools.model_point",
        "rigtools.simulated_study",
        "rigtools.model_comparison",
        "rigtools.model_update",
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


def _bound(tree: ast.AST) -> set[str]:
    """Names an example binds: assignment, ``with``/``for``/``except`` targets, imports, and the
    names of the functions and classes it defines (not what a class body defines)."""
    out: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, (ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            out.add(node.name)
            return
        if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            out.add(node.id)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            out.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, ast.ExceptHandler) and node.name:
            out.add(node.name)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return out


def _read(tree: ast.AST) -> set[str]:
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)}


_SIMPLE = (ast.Assign, ast.AnnAssign, ast.AugAssign, ast.Import, ast.ImportFrom)
_LONG_FLOAT = re.compile(r"\d\.\d{9,}")  # 10+ significant digits: round it or use an ellipsis


def unseen_results(test: doctest.DocTest) -> list[str]:
    """What a docstring's examples compute and never show, one line each.

    - no example of the docstring shows output (a reader learns nothing of what comes out; a
      hardware example marked ``+SKIP`` still shows what it prints, unchecked);
    - an example binds a name (an assignment, an import, a ``with`` target) that no later example
      reads and, for a compound example (``with``, ``for``, ``try``), the example itself does not:
      a result computed and left unseen, or an import not used;
    - a shown float with ten or more significant digits (not stable across platforms and BLAS
      builds: round it, or end it with ``...``).

    A bare call with no shown output is allowed: the doctest itself fails unless its value is
    None (doctest prints any other value, which then differs from the empty expected output).
    """
    examples = test.examples
    if not examples:
        return []
    out = []
    if not any(e.want.strip() for e in examples):
        out.append(f"{test.name}: no example shows its output")
    trees = [ast.parse(e.source) for e in examples]
    for i, (example, tree) in enumerate(zip(examples, trees, strict=True)):
        where = f"{test.name}, line {test.lineno + example.lineno + 1}"
        for number in _LONG_FLOAT.findall(example.want):
            out.append(f"{where}: shows {number} unrounded")
        if example.want.strip():
            continue
        seen = set().union(*(_read(t) for t in trees[i + 1 :]))
        if not isinstance(tree.body[0], _SIMPLE):
            seen |= _read(tree)  # a compound example uses its own names
        unseen = sorted(_bound(tree) - seen)
        if unseen:
            out.append(
                f"{where}: {example.source.strip()[:60]!r} binds {', '.join(unseen)}, never shown or used"
            )
    return out


def test_the_output_rule_flags_what_it_should():
    """The rule on made-up docstrings: a silent assignment, an unused import, a docstring with no
    output and an unrounded float are flagged; a value shown later, a None call, a ``with`` that
    uses its target and a skipped hardware example with its output are not."""
    parser = doctest.DocTestParser()

    def flags(text: str) -> list[str]:
        return unseen_results(parser.get_doctest(text, {}, "t", "t.py", 0))

    assert flags(">>> x = 1 + 1\n>>> x\n2\n") == []
    assert flags(">>> import math\n>>> items = []\n>>> items.append(math.pi)\n>>> len(items)\n1\n") == []
    assert flags(">>> with open('f') as f:  # doctest: +SKIP\n...     f.read()\n'text'\n") == []
    assert flags(">>> x = 1 + 1\n>>> 3\n3\n") == ["t, line 1: 'x = 1 + 1' binds x, never shown or used"]
    assert flags(">>> import os\n>>> 3\n3\n") == ["t, line 1: 'import os' binds os, never shown or used"]
    assert flags(">>> x = 1\n>>> print()\n") == [
        "t: no example shows its output",
        "t, line 1: 'x = 1' binds x, never shown or used",
    ]
    assert flags(">>> 2 / 3\n0.6666666666666666\n") == ["t, line 1: shows 0.6666666666666666 unrounded"]
    assert flags(">>> 2 / 3\n0.666...\n") == []


@pytest.mark.parametrize("name", WITH_EXAMPLES)
def test_every_example_shows_what_it_computes(name):
    """The rule of :func:`unseen_results` on every docstring of the module (read, not run)."""
    module = importlib.import_module(name)
    found = doctest.DocTestFinder(exclude_empty=True).find(module, name)
    problems = [line for test in sorted(found, key=lambda t: t.name) for line in unseen_results(test)]
    assert not problems, "\n".join(problems)
