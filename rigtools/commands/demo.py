"""``rig demo``: the paper's whole study on the simulated rig, its findings judged from the data."""

from __future__ import annotations

import argparse

from rigtools import json_values
from rigtools.errors import FaultError, exit_status_help
from rigtools.options import output_folder, seed

HELP = "the paper's study end to end on the simulated rig: recordings, one HTML report, findings C1-C7"
EPILOG = (
    """\
Runs, on the built-in simulated rig (no hardware): the modal check (FEM, AM and an FRF test on the
rig), the linear harmonic response, a force-controlled dwell (60 Hz, 15 N, gap 0.5 mm), the gap,
force and frequency studies measured on the rig and simulated by the FEM, and model updating on the
identified modes; each at the paper's point (60 Hz = 1.13 f1) and at the equivalent
impact-oscillator point (fe = 1.8 f1, F0 scaled to keep the free amplitude). At the paper's point
also the FEM's branches (rig continuation) in fe, with their fold, over the rig's stepped sine up
and down, and in gap, with their period doubling, beside the studies they explain. Writes the
recordings (HDF5), the branch files, report.html, findings.json and gap-trend.png into --out,
prints the findings C1-C7 ticked or crossed from the data, and ends with the report's path.

--out must be new, empty, or a folder a previous demo wrote (its files are then replaced).
Duration, measured on a 2-core machine (numba kernels already compiled; a first run compiles
them, seconds more): --quick (the same steps at reduced resolution) 50 s, the full demo 64 s
(both trace the same FEM branches, most of either's time).
The demo is deterministic: the simulated rig's noise and the FRF excitation come from --seed
(default 0), so two demos write the same findings.json; another seed gives other noise.
--json prints {"report", "files", "branches": {"frequency", "gap": {"file", "turning_points",
"period_doublings", "status"}}, "findings": [{"id", "claim", "verdicts": {point: {"holds",
"why"}}}]}.

"""
    + exit_status_help(
        0, 2, 4, notes={0: "done (whatever the findings)", 2: "bad input (--out)", 4: "a write error"}
    )
    + """

examples:
  rig demo --quick                           # reduced resolution (50 s) into rig-demo/, the findings table
  rig demo --out demo-run --json             # the full demo (64 s) into demo-run/, findings as JSON
"""
)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "demo",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--out", default="rig-demo", metavar="DIR", help='output folder (default "rig-demo")')
    p.add_argument(
        "--quick", action="store_true", help="reduced resolution (measured: 50 s; the full demo 64 s)"
    )
    p.add_argument(
        "--seed",
        type=seed,
        default=0,
        help="the simulated rig's noise and FRF excitation (default 0: every demo gives the same findings)",
    )
    p.add_argument("--json", action="store_true", help="print the findings as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    out = output_folder(args.out, owner=".rig-demo", owner_name="a demo")
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from rigtools.demo import settings as demo_settings
    from rigtools.demo.findings import mark
    from rigtools.demo.run import n_steps, run_demo

    console = Console(stderr=True)
    from dataclasses import replace

    settings = replace(demo_settings.quick() if args.quick else demo_settings.full(), seed=args.seed)
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
        TimeElapsedColumn(),
        console=console,
        disable=args.json,
        transient=True,
    ) as bar:
        task = bar.add_task("rig demo", total=n_steps(settings))

        def progress(text: str) -> None:
            bar.update(task, advance=1, description=text)

        try:
            result = run_demo(out, settings, progress)
        except OSError as exc:
            raise FaultError(f"cannot write into {out}: {exc}") from None
    findings = result["findings"]
    if args.json:
        from rigtools.demo.run import findings_doc

        data = result["data"]
        print(
            json_values.dumps(
                findings_doc(findings, result["report"], data["files"], branches=data["branches"]), indent=1
            )
        )
        return 0
    from rich.table import Table

    pts = result["data"]["points"]
    table = Table(title="findings, judged from the data", show_lines=True)
    table.add_column("finding")
    table.add_column("claim", max_width=34)
    for key in ("paper", "equivalent"):
        table.add_column(pts[key].label, max_width=52)
    for f in findings:
        cells = []
        for key in ("paper", "equivalent"):
            v = f.verdicts.get(key)
            cells.append("" if v is None else f"{mark(v.holds)} {v.why}")
        table.add_row(f.id, f.claim, *cells)
    Console().print(table)
    print(f"report: {result['report']}")
    return 0
