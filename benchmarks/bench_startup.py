"""Start-up of the library and the command line: ``import rigtools``, ``rig --help``, ``rig CMD --help``.

The front door (``rigtools/__init__.py``) and the command modules import lazily on purpose
(issue 32); this prints what that buys, so a change that moves imports can be checked against it:

- the wall time of each (median of ``--repeats`` whole processes, interleaved with a bare
  ``python -c pass`` run in the same loop, so a busy machine slows all alike) and its ratio to
  that baseline;
- the modules each loads (``sys.modules`` at exit: a count that does not depend on the load of
  the machine), how many of them are ``rigtools.*``, and whether numpy is among them.

    python benchmarks/bench_startup.py               # ~15 s
    python benchmarks/bench_startup.py --repeats 15 --json
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

from bench_cli_latency import RIG, interleaved_medians

# what each case runs after the interpreter has started; the last line reports sys.modules
CASES = {
    "python -c pass": "pass",
    "import rigtools": "import rigtools",
    "rig --help": RIG,
    "rig simulate --help": RIG,
    "rig acquire dwell --help": RIG,
}
ARGS = {"rig --help": ["--help"], "rig simulate --help": ["simulate", "--help"]}
ARGS["rig acquire dwell --help"] = ["acquire", "dwell", "--help"]
REPORT = (
    "import sys, json; m = list(sys.modules); "
    "print(json.dumps([len(m), sum(x.split('.')[0] == 'rigtools' for x in m), 'numpy' in m]))"
)


def loaded(code: str, argv: list[str]) -> tuple[int, int, bool]:
    """(modules, rigtools modules, numpy loaded) once ``code`` has run; ``rig --help`` exits in
    argparse, so its report runs from an exit hook."""
    script = f"import atexit\natexit.register(lambda: exec({REPORT!r}))\n{code}"
    out = subprocess.run(
        [sys.executable, "-c", script, *argv], capture_output=True, text=True, check=False
    ).stdout
    total, own, numpy = json.loads(out.strip().splitlines()[-1])
    return total, own, numpy


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=9, help="runs per case (median)")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args()
    argv = {name: [sys.executable, "-c", code] for name, code in CASES.items()}
    for name, extra in ARGS.items():
        argv[name] += extra
    try:
        medians = interleaved_medians(argv, args.repeats)
    except RuntimeError as exc:
        print(exc, file=sys.stderr)
        return 1
    base = medians["python -c pass"]
    rows = []
    for name, code in CASES.items():
        total, own, numpy = loaded(code, argv[name][3:])
        median = medians[name]
        rows.append(
            {
                "case": name,
                "median_s": median,
                "ratio_to_python": median / base,
                "modules": total,
                "rigtools_modules": own,
                "numpy_loaded": numpy,
            }
        )
    if args.json:
        print(json.dumps({"repeats": args.repeats, "results": rows}, indent=1))
        return 0
    print(f"start-up: median of {args.repeats} runs each, interleaved")
    for r in rows:
        print(
            f"  {r['case']:<26} {r['median_s']:6.3f} s  {r['ratio_to_python']:5.1f}x python -c pass"
            f"  {r['modules']:4d} modules ({r['rigtools_modules']} rigtools.*"
            f"{', numpy' if r['numpy_loaded'] else ''})"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
