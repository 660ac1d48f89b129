"""The house's size and import figures (issue 32's "must show"), read from the source with ``ast``.

Prints: modules and lines of the library (``rigtools``, ``drivers``, ``sim``, ``analysis``);
modules over 600 / 1 000 lines; functions over 100 / 150 lines; the circles of files, counting
imports inside functions; import statements inside function bodies (all, ``rigtools.*``, and ``rigtools.*``
outside the doors: front door, ``cli.py``, the command
modules and what they import at their heads); and the pair count of the
``duplicates`` tool when it is on the PATH (run over the whole checkout). Nothing is timed and
nothing is imported, so the figures do not depend on the machine's load.

    python benchmarks/house_figures.py            # ~10 s (most of it ``duplicates``)
    python benchmarks/house_figures.py --json
    python benchmarks/house_figures.py --list     # name every module, function and import counted
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "rigtools"))

from import_graph import (
    circles,
    cycle_path,
    doors,
    file_graph,
    find_modules,
    functions,
    imports,
    lazy_findings,
)


def duplicate_pairs(root: Path) -> int | None:
    """The pair count the ``duplicates`` tool prints first, or None without the tool."""
    if shutil.which("duplicates") is None:
        return None
    out = subprocess.run(
        ["duplicates", "--repo", str(root), "--most", "1", "--seconds", "120"],
        capture_output=True,
        text=True,
        check=False,
    ).stdout
    match = re.search(r"(\d+) pairs?", out)
    return int(match.group(1)) if match else 0


def figures(root: Path = ROOT, with_duplicates: bool = True) -> dict[str, object]:
    """Every figure, with the names behind the counts."""
    modules = find_modules(root)
    sizes = {name: len(path.read_text(encoding="utf-8").splitlines()) for name, path in modules.items()}
    funcs = [(f"{name}:{func}", n) for name, path in modules.items() for func, n in functions(path)]
    graph = file_graph(modules)
    found = circles(graph)
    # one import statement counts once, however many names it brings (``from a import b, c``)
    inner = list(
        {
            (name, imp.line): (name, imp)
            for name, path in modules.items()
            for imp in imports(name, path, modules)
            if imp.in_function
        }.values()
    )
    own = [(name, imp) for name, imp in inner if imp.target.split(".")[0] == "rigtools"]
    door = doors(modules)
    own_inside = [(name, imp) for name, imp in own if name not in door]
    return {
        "modules": len(modules),
        "lines": sum(sizes.values()),
        "modules_over_600": sorted(((n, s) for n, s in sizes.items() if s > 600), key=lambda x: -x[1]),
        "modules_over_1000": sorted(((n, s) for n, s in sizes.items() if s > 1000), key=lambda x: -x[1]),
        "functions_over_100": sorted(((n, s) for n, s in funcs if s > 100), key=lambda x: -x[1]),
        "functions_over_150": sorted(((n, s) for n, s in funcs if s > 150), key=lambda x: -x[1]),
        "circles": [" -> ".join(cycle_path(g, graph)) + f"  ({len(g)} files)" for g in found],
        "imports_in_functions": len(inner),
        "rigtools_imports_in_functions": len(own),
        "rigtools_imports_in_functions_outside_doors": len(own_inside),
        "by_file_outside_doors": Counter(name for name, _ in own_inside).most_common(),
        # what tests/rigtools/test_import_rules.py flags: as above, but for the lazy imports of
        # modules holding a heavy optional package and the modules lazy on purpose
        "import_rule_findings": sum(len(v) for v in lazy_findings(modules).values()),
        "duplicate_pairs": duplicate_pairs(root) if with_duplicates else None,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    parser.add_argument("--list", action="store_true", help="name what each count counts")
    parser.add_argument("--no-duplicates", action="store_true", help="skip the duplicates tool")
    args = parser.parse_args()
    fig = figures(with_duplicates=not args.no_duplicates)
    if args.json:
        print(json.dumps(fig, indent=1))
        return
    print(f"library: {fig['lines']} lines in {fig['modules']} modules")
    for key in ("modules_over_600", "modules_over_1000", "functions_over_100", "functions_over_150"):
        rows = fig[key]
        assert isinstance(rows, list)
        print(f"{key}: {len(rows)}")
        if args.list or key.endswith(("1000", "150")):
            for name, n in rows:
                print(f"    {n:5d}  {name}")
    rows = fig["circles"]
    assert isinstance(rows, list)
    print(f"circles of files (in-function imports counted): {len(rows)}")
    for row in rows:
        print(f"    {row}")
    print(f"import statements inside functions: {fig['imports_in_functions']}")
    print(f"  of rigtools.*: {fig['rigtools_imports_in_functions']}")
    print(f"  of rigtools.* outside the doors: {fig['rigtools_imports_in_functions_outside_doors']}")
    print(
        f"  rigtools names imported in functions that test_import_rules flags (allow-listed or not): {fig['import_rule_findings']}"
    )
    rows = fig["by_file_outside_doors"]
    assert isinstance(rows, list)
    for name, n in rows if args.list else rows[:10]:
        print(f"    {n:4d}  {name}")
    print(f"duplicates pairs: {fig['duplicate_pairs']}")


if __name__ == "__main__":
    main()
