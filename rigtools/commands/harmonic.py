"""``rig harmonic``: linear amplitude-frequency curves, FEM and AM side by side (paper's Figure 7)."""

from __future__ import annotations

import argparse
import sys

from rigtools.errors import exit_status_help
from rigtools.harmonic_curves import MAX_POINTS, MIN_POINTS
from rigtools.options import TABLE_SUFFIXES, check_out

HELP = "linear amplitude-frequency curves (no contact), FEM and AM, written as CSV or JSON plus a PNG plot"
EPILOG = (
    """\
A force F0 sin(2 pi f t) acts at the force-sensor position. The gap stays open (linear response),
so each blade is driven on its own: the active blade through its force sensor, the passive blade
(no sensor) at the same position. Curves: displacement (m) and acceleration (m/s^2) peak
amplitudes (RMS = peak / sqrt 2) at each shroud and each excitation point, FEM (all-mode
superposition) and AM (assumed modes), with the rig's damping. In the plot FEM is solid, AM
dashed with open markers (o shroud, s excitation point), each location in its own colour.

Columns of the CSV: frequency_hz, then <model>_<location>_displacement_m and
<model>_<location>_acceleration_m_s2 for model in fem, am and location in active_shroud,
active_force_point, passive_shroud, passive_force_point. The PNG is written next to the output
(same name, .png). An existing output is replaced only with --overwrite.

"""
    + exit_status_help(0, 2, notes={0: "written", 2: "bad input (options, rig file, --out)"})
    + """

examples:
  rig harmonic --out fig7.csv
  rig harmonic --force "10 N" --fmin 20 --fmax "2 kHz" --points 4000 --out curves.json
"""
)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "harmonic",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--rig", metavar="FILE", help="rig file (TOML); default: the calibrated default rig")
    p.add_argument(
        "--force", default="15 N", help='force amplitude F0 (default "15 N"; a plain number is newtons)'
    )
    p.add_argument("--fmin", default="10 Hz", help='lowest frequency (default "10 Hz")')
    p.add_argument("--fmax", default="1500 Hz", help='highest frequency (default "1500 Hz")')
    p.add_argument(
        "--points",
        type=int,
        default=2000,
        help=f"frequencies, evenly spaced (default 2000, {MIN_POINTS} to {MAX_POINTS})",
    )
    p.add_argument(
        "--out",
        required=True,
        metavar="FILE",
        help="output file, .csv or .json (peak amplitudes); the plot goes to FILE.png",
    )
    p.add_argument("--overwrite", action="store_true", help="replace FILE if it exists")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.config import load_rig
    from rigtools.derived_files import plot_path
    from rigtools.figures import save_figure
    from rigtools.harmonic_curves import curves_figure, implausible_note, linear_curves, write_curves
    from rigtools.model_options import announce_model
    from rigtools.progress import working

    out = check_out(args, suffixes=TABLE_SUFFIXES)
    rig_config = load_rig(args.rig)
    params = rig_config.to_params()
    elements = announce_model(params)
    with working(f"FEM and AM curves at {args.points} frequencies ({elements})"):
        fem, am = linear_curves(params, args.force, args.fmin, args.fmax, args.points)
    write_curves(out, fem, am, rig_config.name)
    note = implausible_note(fem, am)
    if note:
        print(note, file=sys.stderr)
    png = save_figure(curves_figure(fem, am, rig_config.name), plot_path(out), dpi=120)
    f = fem.frequencies_hz
    print(
        f"wrote {out} and {png} ({args.points} frequencies {f[0]:g}-{f[-1]:g} Hz, "
        f"F0 = {fem.force_amplitude:g} N peak, FEM and AM peak amplitudes)"
    )
    return 0
