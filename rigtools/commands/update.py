"""``rig update``: fit the rig file's model to recordings (FRF/tap tests, dwells with impacts).

Parse, call :func:`rigtools.model_update.update_rig_file`, print.
"""

from __future__ import annotations

import argparse

from rigtools import json_values
from rigtools.errors import exit_status_help
from rigtools.model_update import CONTACT_LAWS, PARAMETER_NAMES
from rigtools.model_update import DEFAULT_PARAMETERS as DEFAULT_PARAMS
from rigtools.options import add_skip_damaged

HELP = "fit the rig file's model to FRF/tap tests (and contact to dwells); write an updated rig file"
EPILOG = (
    f"""\
Steps:
  1. identify natural frequencies and damping ratios in each recording's broadband test (LSCF on
     H1 = acceleration / force; an FRF test 'rig acquire frf' gives the active blade, a tap test
     of the passive blade gives the passive one);
  2. pair them with the model's flexural modes (blade, order; the first --modes of each blade);
  3. fit --params by weighted least squares (relative frequency errors over 0.1 %, damping
     ratios over 10 %; bounds; scipy least_squares) and report identifiability: Jacobian rank,
     correlations, 95 % intervals, and the parameter pairs the data cannot separate (named, not
     fitted silently: such values are kept but flagged);
  4. --contact DWELL.h5: fit the contact stiffness and damping to the shroud acceleration
     harmonics (k = 1..10) of force-controlled dwells with impacts ('rig acquire dwell'), the
     vibro-impact integrator in the loop, and print the EM-versus-FEM agreement score
     (rigtools.analysis.correlation.point_agreement, force and shroud harmonics, model driven at the measured
     force) before updating, after the linear update and after the contact fit;
  5. write --out: the rig file's text with the fitted keys replaced (old line kept as '# was:')
     or added, each commented with the recordings, modes and residual it came from.

Parameters (rig-file keys, SI): {", ".join(PARAMETER_NAMES)}.
damping.ratio (modal) or damping.alpha + damping.beta (Rayleigh), not both. Fitting a root spring
turns a clamped root into springs (the other spring stays stiff unless fitted too).

"""
    + exit_status_help(
        0,
        2,
        notes={
            0: "written",
            2: "bad input (unknown parameter, unreadable recording, a recording without usable modes such as a dwell given as a test, --out existing or a recording)",
        },
    )
    + """

examples:
  rig acquire frf --backend sim --band "20 Hz:2 kHz" --level "0.3 V" --out frf.h5
  rig update frf.h5 --out updated.toml
  rig update frf.h5 tap.h5 --params root.rotational_stiffness,shroud.mass,damping.ratio --out u.toml
  rig update frf.h5 --contact dwell.h5 --out contact.toml --json
  rig modal --rig updated.toml
"""
)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "update",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    help_recordings = "FRF test / tap test recordings (modes are identified in each)"
    p.add_argument("recordings", nargs="+", metavar="TEST.h5", help=help_recordings)
    add_skip_damaged(p)
    p.add_argument(
        "--rig", metavar="FILE", help="rig file (TOML) to update; default: the calibrated default rig"
    )
    p.add_argument(
        "--params",
        default=DEFAULT_PARAMS,
        metavar="NAME,...",
        help=f"rig-file parameters to fit (default {DEFAULT_PARAMS})",
    )
    p.add_argument("--out", required=True, metavar="FILE.toml", help="updated rig file to write")
    p.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    p.add_argument(
        "--modes",
        type=int,
        default=3,
        metavar="N",
        help="flexural modes per blade used as targets, lowest first (default 3)",
    )
    p.add_argument(
        "--band",
        default=None,
        metavar="LOW:HIGH",
        help='band searched for modes, e.g. "20 Hz:2 kHz" (default: each test\'s band)',
    )
    p.add_argument(
        "--no-damping", action="store_true", help="fit frequencies only (ignore identified damping)"
    )
    p.add_argument(
        "--contact",
        nargs="+",
        default=[],
        metavar="DWELL.h5",
        help="force-controlled dwells with impacts: fit contact stiffness and damping",
    )
    p.add_argument(
        "--law",
        choices=tuple(CONTACT_LAWS),
        default="rig",
        help="contact law to fit (default: the rig file's); compare: fit linear and Hertz, keep the better",
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of tables")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.model_update import update_rig_file
    from rigtools.progress import status

    outcome = update_rig_file(
        args.recordings,
        args.out,
        rig=args.rig,
        parameters=args.params,
        modes=args.modes,
        band=args.band,
        damping=not args.no_damping,
        contact=args.contact,
        law=args.law,
        overwrite=args.overwrite,
        status=status(quiet=args.json),
    )
    if args.json:
        print(json_values.dumps(outcome.to_dict(), indent=1))
        return 0
    from rich.console import Console

    from rigtools.tables import update_tables

    console = Console()
    for item in update_tables(outcome):
        text = not hasattr(item, "columns")
        console.print(
            item, markup=isinstance(item, str) and item.startswith("["), highlight=False, soft_wrap=text
        )
    return 0
