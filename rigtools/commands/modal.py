"""``rig modal``: natural frequencies of both blades, FEM versus the analytical model (AM)."""

from __future__ import annotations

import argparse

from rigtools import json_values
from rigtools.errors import UserError, exit_status_help

HELP = "natural frequencies of both blades: FEM vs analytical model (AM), differences in %%"
EPILOG = (
    """\
The FEM lists the lowest N modes of each blade with their kind: flexural (bending in the thin,
impact direction y), edgewise (bending in the chord direction z), torsional or axial. The AM is
the exact Euler-Bernoulli solution of the blade with its shroud (and, on the active blade, the
force sensor); it has flexural modes only, and the table sets the k-th AM mode beside the k-th
FEM flexural mode: diff % = (FEM - AM) / AM * 100.

"""
    + exit_status_help(0, 2, notes={0: "listed", 2: "bad input (options, rig file)"})
    + """

examples:
  rig modal                        # the calibrated default rig
  rig modal --rig lab.toml --modes 10
  rig modal --json > modes.json    # {"fem": {"active": [...], "passive": [...]}, "am": {...}}
"""
)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "modal",
        help=HELP,
        description=HELP.replace("%%", "%") + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--rig", metavar="FILE", help="rig file (TOML); default: the calibrated default rig")
    p.add_argument(
        "--modes",
        metavar="N",
        type=int,
        default=8,
        help="FEM modes listed per blade, lowest first (default 8); the AM lists its N lowest flexural modes",
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=run)


def _print_table(results: dict, rig_name: str) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console()
    for name in ("active", "passive"):
        table = Table(
            title=f"{rig_name}: {name} blade" + (" (with force sensor)" if name == "active" else "")
        )
        for col in ("mode", "kind", "FEM (Hz)", "flexural #", "AM (Hz)", "diff %"):
            table.add_column(col, justify="left" if col == "kind" else "right")
        am = results["am"][name]
        k = 0
        for entry in results["fem"][name]:
            cells = [str(entry["mode"]), entry["kind"], f"{entry['frequency_hz']:.2f}"]
            if entry["kind"] == "flexural" and k < len(am):
                f_am = am[k]["frequency_hz"]
                k += 1
                diff = (entry["frequency_hz"] - f_am) / f_am * 100.0
                cells += [str(k), f"{f_am:.2f}", f"{diff:+.3f}"]
            else:
                cells += ["", "", ""]
            table.add_row(*cells)
        console.print(table)


def run(args: argparse.Namespace) -> int:
    if args.modes < 1 or args.modes > 200:
        raise UserError(f"--modes = {args.modes}: must be between 1 and 200")
    from rigtools.config import load_rig
    from rigtools.model_options import announce_model
    from rigtools.progress import working
    from rigtools.sim.natural_frequencies import blade_mode_table

    rig_config = load_rig(args.rig)
    elements = announce_model(rig_config.to_params(), quiet=args.json)
    with working(f"FE and AM modes of both blades ({elements})", args.json):
        results = blade_mode_table(rig_config.to_params(), args.modes)
    if args.json:
        print(json_values.dumps(results, indent=1))
    else:
        _print_table(results, rig_config.name)
    return 0
