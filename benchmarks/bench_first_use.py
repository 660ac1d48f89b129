"""First use of a front-door name: ``import rigtools; rigtools.NAME`` in a fresh process.

The front door (``rigtools/__init__.py``) imports each name's module on first use; this prints
what that costs, so a change that moves imports into or out of those modules can be checked:

- the wall time (median of ``--repeats`` whole processes, interleaved with a bare
  ``python -c pass`` and a bare ``import rigtools`` in the same loop, so a busy machine slows
  all alike) and its ratio to ``python -c pass``;
- the modules loaded (``sys.modules`` at exit, a count that does not depend on the load of the
  machine), how many are ``rigtools.*``, and which of the heavy ones (:data:`MARKERS`).

    python benchmarks/bench_first_use.py                       # the offline steps' names, ~1 min
    python benchmarks/bench_first_use.py --names spectrum,dwell --repeats 9 --json
    python benchmarks/bench_first_use.py --names all           # every front-door name
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

from bench_cli_latency import interleaved_medians

#: The offline steps of a lab script (issue 32 split their module by name).
DEFAULT_NAMES = (
    "spectrum",
    "Spectrum",
    "simulate_point",
    "SimulatedPoint",
    "simulate_study",
    "compare_with_model",
    "update_model",
)
#: Packages whose loading is worth naming (they dominate the first-use cost).
MARKERS = ("numpy", "scipy.signal", "pandas", "h5py", "pydantic", "numba", "matplotlib", "dask")
REPORT = (
    "import sys, json; m = set(sys.modules); "
    f"print(json.dumps([len(m), sum(x.split('.')[0] == 'rigtools' for x in m), "
    f"[k for k in {MARKERS!r} if k in m]]))"
)


def loaded(code: str) -> tuple[int, int, list[str]]:
    """(modules, rigtools modules, markers loaded) once ``code`` has run."""
    out = subprocess.run(
        [sys.executable, "-c", f"{code}\n{REPORT}"], capture_output=True, text=True, check=True
    ).stdout
    total, own, markers = json.loads(out.strip().splitlines()[-1])
    return total, own, markers


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="runs per case (median)")
    parser.add_argument("--names", default=",".join(DEFAULT_NAMES), help="comma-separated, or 'all'")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args()
    if args.names == "all":
        import rigtools

        names = list(rigtools.__all__)
    else:
        names = [n.strip() for n in args.names.split(",") if n.strip()]
    codes = {"python -c pass": "pass", "import rigtools": "import rigtools"}
    codes |= {f"rigtools.{n}": f"import rigtools; rigtools.{n}" for n in names}
    argv = {case: [sys.executable, "-c", code] for case, code in codes.items()}
    try:
        medians = interleaved_medians(argv, args.repeats)
    except RuntimeError as exc:
        print(exc, file=sys.stderr)
        return 1
    base = medians["python -c pass"]
    rows = []
    for case, code in codes.items():
        total, own, markers = loaded(code)
        rows.append(
            {
                "case": case,
                "median_s": medians[case],
                "ratio_to_python": medians[case] / base,
                "modules": total,
                "rigtools_modules": own,
                "heavy_loaded": markers,
            }
        )
    if args.json:
        print(json.dumps({"repeats": args.repeats, "results": rows}, indent=1))
        return 0
    print(f"first use of front-door names: median of {args.repeats} runs each, interleaved")
    for r in rows:
        print(
            f"  {r['case']:<28} {r['median_s']:6.3f} s  {r['ratio_to_python']:6.1f}x python -c pass"
            f"  {r['modules']:5d} modules ({r['rigtools_modules']:3d} rigtools.*)  "
            f"{' '.join(r['heavy_loaded'])}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
