"""The layering, walked in the source (ast): a command module parses, calls the library and
prints, so no command imports another command and no library module imports a command;
``rigtools.sim`` and ``rigtools.analysis`` never import the orchestration, the drivers or h5py;
the drivers import nothing of ``rigtools`` outside ``rigtools.drivers`` and ``rigtools.sim``.

Every import counts, at the top of a module or inside a function (a lazy import is still an arrow):
no circle of files, and a ``rigtools`` module is imported inside a function only at the doors (the
front door ``rigtools/__init__.py``, ``rigtools/cli.py``, the command modules and what they import
at their heads: ``import_graph.doors``), where the lazy import buys start-up time
(``benchmarks/bench_startup.py`` measures it). Heavy optional packages (matplotlib, dask, ...) and
the rigtools modules that hold one at their head may be imported lazily anywhere.

The tree is read by ``import_graph.py`` (beside this file), which ``benchmarks/house_figures.py``
also uses to print the counts.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from import_graph import ROOT, circles, cycle_path, file_graph, find_modules, imports, lazy_findings

COMMANDS = "rigtools.commands"

MODULES = find_modules()


def imports_of(name: str, path: Path) -> set[str]:
    """Dotted names a module imports (relative imports resolved; ``from a import b`` gives
    ``a.b`` when that is a module of the tree, else ``a``)."""
    return {i.target for i in imports(name, path, MODULES)}


def _in(name: str, package: str) -> bool:
    return name == package or name.startswith(package + ".")


def violations() -> list[str]:
    bad = []
    for name, path in MODULES.items():
        for target in sorted(imports_of(name, path)):
            where = f"{path.relative_to(ROOT) if path.is_relative_to(ROOT) else name} imports {target}"
            command_target = _in(target, COMMANDS) and target != COMMANDS
            if _in(name, COMMANDS) and command_target:
                bad.append(f"{where}: a command imports a command")
            elif not _in(name, COMMANDS) and command_target and name != "rigtools.cli":
                bad.append(f"{where}: a library module imports a command (only rigtools.cli may)")
            if _in(name, "rigtools.sim") or _in(name, "rigtools.analysis"):
                own = "rigtools.sim" if _in(name, "rigtools.sim") else "rigtools.analysis"
                allowed = (
                    ("rigtools.sim", "rigtools.analysis") if own == "rigtools.analysis" else ("rigtools.sim",)
                )
                if _in(target, "h5py"):
                    bad.append(f"{where}: sim and analysis do no file I/O (no h5py)")
                elif _in(target, "rigtools") and not any(_in(target, a) for a in allowed):
                    bad.append(f"{where}: {own} imports the orchestration or the drivers")
    return bad


def test_the_tree_is_walked():
    assert "rigtools.commands.acquire" in MODULES and "rigtools.sim.vibro_impact" in MODULES
    assert len(MODULES) > 80
    assert "rigtools.commands.simulate" not in imports_of(
        "rigtools.commands.study", MODULES["rigtools.commands.study"]
    )


def test_no_import_crosses_a_layer():
    assert violations() == []


@pytest.mark.parametrize(
    "name, source, message",
    [
        (
            "rigtools.commands.x",
            "from rigtools.commands.study import parse_values",
            "a command imports a command",
        ),
        ("rigtools.commands.x", "from . import simulate", "a command imports a command"),
        (
            "rigtools.demo.x",
            "def f():\n    from rigtools.commands.modal import f",
            "a library module imports a command",
        ),
        ("rigtools.sim.x", "import h5py", "no h5py"),
        ("rigtools.sim.x", "from rigtools.config import load_rig", "imports the orchestration"),
        ("rigtools.analysis.x", "from rigtools.drivers.simulated import Fault", "imports the orchestration"),
    ],
)
def test_each_rule_catches_its_violation(tmp_path, monkeypatch, name, source, message):
    """The rules fail on a planted violation (a test that cannot fail proves nothing)."""
    planted = tmp_path / "x.py"
    planted.write_text(source, encoding="utf-8")
    monkeypatch.setitem(MODULES, name, planted)
    found = violations()
    assert any(message in v for v in found), found


def test_commands_stay_thin():
    """Each command module is a shell: under 150 lines."""
    long = {
        p.name: n
        for p in (ROOT / "rigtools" / "commands").glob("*.py")
        if (n := len(p.read_text().splitlines())) >= 150
    }
    assert long == {}


# -- circles, the drivers' rule, imports at the head ------------------------------------------
# Issue 32 moves every in-function import of a rigtools module to its module's head; these files
# still have some (other helpers were splitting or rewriting them at the same time). The lists
# must only shrink: an entry whose finding is gone fails test_allow_lists_only_shrink, so remove it.
NOT_YET_AT_HEAD: set[str] = set()  # none left (issue 32); lazy on purpose: import_graph.LAZY_ON_PURPOSE
# circles (as sets of modules) still being broken by the helper named
KNOWN_CIRCLES: set[frozenset[str]] = set()  # none left (issue 32); a circle being broken goes here


def circle_findings(modules: dict[str, Path]) -> dict[frozenset[str], str]:
    """Each circle of files (in-function imports counted), as its members and one closed path."""
    graph = file_graph(modules)
    return {
        frozenset(group): "circle of files: " + " -> ".join(cycle_path(group, graph))
        for group in circles(graph)
    }


def driver_findings(modules: dict[str, Path]) -> dict[str, list[str]]:
    """Driver module -> what it imports of rigtools outside rigtools.drivers / rigtools.sim."""
    found: dict[str, list[str]] = {}
    for name, path in modules.items():
        if not _in(name, "rigtools.drivers"):
            continue
        for imp in imports(name, path, modules):
            t = imp.target
            if _in(t, "rigtools") and not (_in(t, "rigtools.drivers") or _in(t, "rigtools.sim")):
                found.setdefault(name, []).append(
                    f"{path.name}:{imp.line} imports {t}: a driver imports the orchestration"
                )
    return found


def test_no_circle_of_files():
    found = circle_findings(MODULES)
    assert sorted(v for k, v in found.items() if k not in KNOWN_CIRCLES) == []


def test_drivers_import_no_orchestration():
    found = driver_findings(MODULES)
    assert [line for lines in found.values() for line in lines] == []


def test_rigtools_imports_sit_at_the_module_head():
    found = lazy_findings(MODULES)
    assert [line for name, lines in found.items() if name not in NOT_YET_AT_HEAD for line in lines] == []


def test_allow_lists_only_shrink():
    """An allow-listed file or circle that no longer has its finding must leave the list."""
    stale = sorted(NOT_YET_AT_HEAD - set(lazy_findings(MODULES)))
    stale += sorted(" ".join(sorted(c)) for c in KNOWN_CIRCLES - set(circle_findings(MODULES)))
    assert stale == [], "fixed: remove from the allow-list in test_import_rules.py"


def _plant(root: Path, files: dict[str, str]) -> dict[str, Path]:
    """A throw-away source tree (rigtools/, drivers/, ... as in the repository) and its modules."""
    for rel, source in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(source, encoding="utf-8")
    return find_modules(root)


def test_a_planted_circle_is_found_and_named(tmp_path):
    """One arrow at a module's head, the way back inside a function: still a circle."""
    modules = _plant(
        tmp_path,
        {
            "rigtools/__init__.py": "",
            "rigtools/a.py": "from rigtools.b import g\n",
            "rigtools/b.py": "def g():\n    from rigtools import c\n",
            "rigtools/c.py": "from . import a\n",
            "rigtools/d.py": "from rigtools import a\n",  # leads into the circle, not part of it
        },
    )
    found = circle_findings(modules)
    print(*found.values(), sep="\n")
    assert list(found.values()) == ["circle of files: rigtools.a -> rigtools.b -> rigtools.c -> rigtools.a"]


def test_a_planted_driver_import_is_found(tmp_path):
    modules = _plant(
        tmp_path,
        {
            "rigtools/__init__.py": "",
            "rigtools/errors.py": "",
            "drivers/__init__.py": "",
            "drivers/ok.py": "from rigtools.sim import model\nfrom . import bad\n",
            "drivers/bad.py": "def f():\n    from rigtools.errors import UserError\n",
            "sim/__init__.py": "",
            "sim/model.py": "",
        },
    )
    found = driver_findings(modules)
    print(*[line for lines in found.values() for line in lines], sep="\n")
    assert found == {
        "rigtools.drivers.bad": ["bad.py:2 imports rigtools.errors: a driver imports the orchestration"]
    }


def test_a_planted_lazy_import_is_found_outside_the_doors(tmp_path):
    modules = _plant(
        tmp_path,
        {
            "rigtools/__init__.py": "def __getattr__(n):\n    from rigtools import lib\n",
            "rigtools/commands/__init__.py": "",
            "rigtools/commands/run.py": "def run():\n    from rigtools import lib\n",
            "rigtools/lib.py": "def plot():\n    import matplotlib\n    from rigtools import other, plots\n",
            "rigtools/other.py": "",
            "rigtools/plots.py": "from matplotlib.figure import Figure\n",  # holds matplotlib
        },
    )
    found = lazy_findings(modules)
    print(*[line for lines in found.values() for line in lines], sep="\n")
    assert list(found) == ["rigtools.lib"] and len(found["rigtools.lib"]) == 1
    assert "(lib.py:3) imports rigtools.other" in found["rigtools.lib"][0]
