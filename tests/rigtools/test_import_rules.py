"""The layering, walked in the source (ast): a command module parses, calls the library and
prints, so no command imports another command and no library module imports a command;
``rigtools.sim`` and ``rigtools.analysis`` never import the orchestration, the drivers or h5py.

Every import counts, at the top of a module or inside a function (a lazy import is still an arrow).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
# source folder -> the dotted package it installs as (pyproject.toml package-dir)
PACKAGES = {
    "rigtools": "rigtools",
    "drivers": "rigtools.drivers",
    "sim": "rigtools.sim",
    "analysis": "rigtools.analysis",
}
COMMANDS = "rigtools.commands"


def _modules() -> dict[str, Path]:
    out = {}
    for folder, package in PACKAGES.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            rel = path.relative_to(ROOT / folder).with_suffix("")
            parts = [p for p in rel.parts if p != "__init__"]
            out[".".join([package, *parts])] = path
    return out


MODULES = _modules()


def imports_of(name: str, path: Path) -> set[str]:
    """Dotted names a module imports (relative imports resolved; ``from a import b`` gives
    ``a.b`` when that is a module of the tree, else ``a``)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            for alias in node.names:
                full = f"{base}.{alias.name}"
                found.add(full if full in MODULES else base)
    return found


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
