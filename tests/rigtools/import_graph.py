"""The source tree read with ``ast``: its modules, their imports (at the head and inside functions),
the graph of files those imports draw, its circles, and the sizes of modules and functions.

One home for what ``test_import_rules.py`` holds and ``benchmarks/house_figures.py`` prints. Nothing
is imported: every figure comes from the text of the files, so a broken module is still counted.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# source folder -> the dotted package it installs as (pyproject.toml package-dir)
PACKAGES = {
    "rigtools": "rigtools",
    "drivers": "rigtools.drivers",
    "sim": "rigtools.sim",
    "analysis": "rigtools.analysis",
}


def find_modules(root: Path = ROOT, packages: Mapping[str, str] = PACKAGES) -> dict[str, Path]:
    """Dotted module name -> its file, for every ``.py`` under the source folders of ``root``."""
    out = {}
    for folder, package in packages.items():
        for path in sorted((root / folder).rglob("*.py")):
            rel = path.relative_to(root / folder).with_suffix("")
            parts = [p for p in rel.parts if p != "__init__"]
            out[".".join([package, *parts])] = path
    return out


@dataclass(frozen=True)
class Import:
    """One imported name: the dotted target, its line, and whether it sits inside a function."""

    target: str
    line: int
    in_function: bool


def _walk(node: ast.AST, in_function: bool) -> Iterator[tuple[ast.AST, bool]]:
    for child in ast.iter_child_nodes(node):
        inside = in_function or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
        yield child, inside
        yield from _walk(child, inside)


def _is_type_checking(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)


@lru_cache(maxsize=4096)
def _parsed(path: Path, stamp: tuple[int, int]) -> ast.Module:
    """A file's syntax tree, parsed once per version of the file (``stamp``: mtime and size)."""
    return ast.parse(path.read_text(encoding="utf-8"), str(path))


def _stamp(path: Path) -> tuple[int, int]:
    st = path.stat()
    return st.st_mtime_ns, st.st_size


def parse(path: Path) -> ast.Module:
    """The syntax tree of ``path`` (cached while the file is unchanged; do not modify it)."""
    return _parsed(path, _stamp(path))


# one import statement as written: (module or "" for ``import x``, names, level, line, in function)
_Raw = tuple[str | None, tuple[str, ...], int, int, bool]


@lru_cache(maxsize=4096)
def _raw_imports(path: Path, stamp: tuple[int, int]) -> tuple[_Raw, ...]:
    tree = _parsed(path, stamp)
    skipped: set[int] = set()
    for node in ast.walk(tree):
        if _is_type_checking(node):
            skipped.update(id(n) for child in node.body for n in ast.walk(child))
    found: list[_Raw] = []
    for node, in_function in _walk(tree, False):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.Import):
            found.append((None, tuple(a.name for a in node.names), 0, node.lineno, in_function))
        elif isinstance(node, ast.ImportFrom):
            names = tuple(a.name for a in node.names)
            found.append((node.module or "", names, node.level, node.lineno, in_function))
    return tuple(found)


def imports(name: str, path: Path, modules: Mapping[str, Path]) -> list[Import]:
    """Every import statement of a module, one :class:`Import` a name.

    Relative imports are resolved; ``from a import b`` gives ``a.b`` when that is a module of the
    tree, else ``a``. Imports under ``if TYPE_CHECKING:`` do not run, so they are left out.
    """
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = []
    for module, names, level, line, in_function in _raw_imports(path, _stamp(path)):
        if module is None:
            found.extend(Import(n, line, in_function) for n in names)
            continue
        base = module
        if level:
            parent = package.split(".")[: len(package.split(".")) - level + 1]
            base = ".".join([*parent, base] if base else parent)
        for alias in names:
            full = f"{base}.{alias}"
            found.append(Import(full if full in modules else base, line, in_function))
    return found


def imports_of(name: str, path: Path, modules: Mapping[str, Path]) -> set[str]:
    """The dotted names a module imports, wherever the import stands."""
    return {i.target for i in imports(name, path, modules)}


def _owner(target: str, modules: Mapping[str, Path]) -> str | None:
    """The module of the tree an imported name lives in (``a.b.c`` -> ``a.b`` if ``c`` is a name)."""
    while target:
        if target in modules:
            return target
        target = target.rpartition(".")[0]
    return None


def file_graph(modules: Mapping[str, Path]) -> dict[str, set[str]]:
    """Module -> the modules of the tree it imports (head and in-function imports alike).

    An arrow goes to the file the import names; importing ``a.b`` also runs ``a/__init__.py``, but
    that arrow is not drawn (every module would then reach its package's front door).
    """
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        targets = {_owner(t, modules) for t in imports_of(name, path, modules)}
        graph[name] = {t for t in targets if t is not None and t != name}
    return graph


def circles(graph: Mapping[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one module (Tarjan), each sorted, largest first."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups: list[list[str]] = []
    counter = 0

    def visit(start: str) -> None:
        nonlocal counter
        # iterative depth-first walk: (node, iterator over its successors)
        work = [(start, iter(sorted(graph.get(start, ()))))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, successors = work[-1]
            for nxt in successors:
                if nxt not in index:
                    index[nxt] = low[nxt] = counter
                    counter += 1
                    stack.append(nxt)
                    on_stack.add(nxt)
                    work.append((nxt, iter(sorted(graph.get(nxt, ())))))
                    break
                if nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    group = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        group.append(member)
                        if member == node:
                            break
                    if len(group) > 1:
                        groups.append(sorted(group))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return sorted(groups, key=lambda g: (-len(g), g))


def cycle_path(group: list[str], graph: Mapping[str, set[str]]) -> list[str]:
    """One closed path through a circle, for a message (``a -> b -> a``)."""
    members = set(group)
    start = group[0]
    # breadth-first from start back to start inside the group
    previous: dict[str, str] = {}
    frontier = [start]
    while frontier:
        nxt_frontier = []
        for node in frontier:
            for nxt in sorted(graph[node] & members):
                if nxt == start:
                    path = [node]
                    while path[-1] != start:
                        path.append(previous[path[-1]])
                    return [*reversed(path), start]
                if nxt not in previous:
                    previous[nxt] = node
                    nxt_frontier.append(nxt)
        frontier = nxt_frontier
    return group


def functions(path: Path) -> list[tuple[str, int]]:
    """(qualified name, lines from ``def`` to its last line) of every function of a file."""
    tree = parse(path)
    out = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = f"{prefix}{child.name}"
                out.append((name, (child.end_lineno or child.lineno) - child.lineno + 1))
                visit(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.")
            else:
                visit(child, prefix)

    visit(tree, "")
    return out


#: The doors, where an import inside a function buys start-up time: the front door (``import
#: rigtools`` stays light), ``rig`` itself and the command modules (only the command being run is
#: imported), and what the command modules import at their heads (``rig CMD --help`` loads it).
FRONT_DOORS = ("rigtools", "rigtools.cli", "rigtools.__main__")
COMMANDS = "rigtools.commands"
#: Modules whose lazy imports are the point of the module, each with its reason.
LAZY_ON_PURPOSE = {
    "rigtools.runtime": "rig imports it first to set BLAS threads and the numba cache before numpy "
    "and numba load; what it runs later (kernel warm-up) it imports then",
    "rigtools.monitor.follow": "the live monitor serves its page at once; the analysis it draws "
    "loads in the server's background thread (rigtools.monitor.server)",
    "rigtools.monitor.server": "its background thread loads the analysis modules after the page is "
    "served, not on the first look at a run's first samples",
    "rigtools.procedures.result": "RunResult.analyze (one call: analyze_recording of the run's file) "
    "loads the analysis (pandas, through analysis.correlation) only when called: at the head it "
    "would load with every procedure, 1283 -> 1622 modules for `import rigtools.procedures`",
}


def doors(modules: Mapping[str, Path]) -> set[str]:
    """The door modules of the tree: the front door, ``rig``, the command modules, and every module
    those reach through imports at module heads (with the packages that holds them)."""
    heads = {
        name: {_owner(i.target, modules) for i in imports(name, path, modules) if not i.in_function}
        for name, path in modules.items()
    }
    start = [n for n in modules if n in FRONT_DOORS or n == COMMANDS or n.startswith(COMMANDS + ".")]
    seen: set[str] = set()
    while start:
        name = start.pop()
        if name in seen or name not in modules:
            continue
        seen.add(name)
        parts = name.split(".")
        start += [".".join(parts[:k]) for k in range(1, len(parts))]
        if name not in FRONT_DOORS or name == "rigtools.cli":  # the front door's own head is its finder
            start += [t for t in heads[name] if t is not None]
    return seen


# heavy optional packages: imported inside a function anywhere, as is a rigtools module that
# imports one of them at its head (rigtools.analysis.plots holds matplotlib: importing it lazily
# is importing matplotlib lazily)
# nidaqmx: the NI hardware's driver (~140 modules), needed only with --backend nidaq; a machine
# without it runs the simulated rig (rigtools.procedures.rig.open_device: DriverUnavailable)
HEAVY = (
    "matplotlib",
    "dask",
    "distributed",
    "bokeh",
    "tornado",
    "pyuff",
    "nptdms",
    "pyoma2",
    "sdypy",
    "nidaqmx",
)


def heavy_wrappers(modules: Mapping[str, Path]) -> set[str]:
    """The modules of the tree that import a heavy optional package at their head."""
    return {
        name
        for name, path in modules.items()
        if any(not i.in_function and i.target.split(".")[0] in HEAVY for i in imports(name, path, modules))
    }


def lazy_findings(modules: Mapping[str, Path]) -> dict[str, list[str]]:
    """Module outside the doors (:func:`doors`, :data:`LAZY_ON_PURPOSE`) -> its
    in-function imports of rigtools modules (but of those that hold a heavy optional package,
    :func:`heavy_wrappers`)."""
    heavy = heavy_wrappers(modules)
    door = doors(modules)
    found: dict[str, list[str]] = {}
    for name, path in modules.items():
        if name in door or name in LAZY_ON_PURPOSE:
            continue
        for imp in imports(name, path, modules):
            target = imp.target if imp.target in modules else imp.target.rpartition(".")[0]
            if imp.in_function and imp.target.split(".")[0] == "rigtools" and target not in heavy:
                found.setdefault(name, []).append(
                    f"{name} ({path.name}:{imp.line}) imports {imp.target} inside a function: "
                    "move it to the module's head"
                )
    return found
