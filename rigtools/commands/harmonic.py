"""``rig harmonic``: linear amplitude-frequency curves, FEM and AM side by side (paper's Figure 7)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from rigtools.errors import UserError

HELP = "linear amplitude-frequency curves (no contact), FEM and AM, written as CSV or JSON plus a PNG plot"
EPILOG = """\
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

Exit status: 0 written, 2 bad input (options, rig file, --out), 130 Ctrl-C.

examples:
  rig harmonic --out fig7.csv
  rig harmonic --force "10 N" --fmin 20 --fmax "2 kHz" --points 4000 --out curves.json
"""


MIN_POINTS, MAX_POINTS = 2, 200_000


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


def _columns(fem: HarmonicResponse, am: HarmonicResponse) -> dict[str, np.ndarray]:
    from rigtools.sim.harmonic import LOCATIONS

    cols = {"frequency_hz": fem.frequencies_hz}
    for res in (fem, am):
        for loc in LOCATIONS:
            cols[f"{res.model}_{loc}_displacement_m"] = res.displacement_amplitude(loc)
            cols[f"{res.model}_{loc}_acceleration_m_s2"] = res.acceleration_amplitude(loc)
    return cols


def write_curves(path: Path, fem: HarmonicResponse, am: HarmonicResponse, rig_name: str) -> None:
    """Write the curves as CSV (one column per curve) or JSON (nested by model and location)."""
    from rigtools.sim.harmonic import LOCATIONS

    if path.suffix.lower() == ".csv":
        cols = _columns(fem, am)
        np.savetxt(
            path,
            np.column_stack(list(cols.values())),
            delimiter=",",
            header=",".join(cols),
            comments="",
            fmt="%.9g",
        )
        return
    doc = {
        "rig": rig_name,
        "force_amplitude_n": fem.force_amplitude,
        "frequency_hz": fem.frequencies_hz.tolist(),
    }
    for res in (fem, am):
        doc[res.model] = {
            loc: {
                "displacement_m": res.displacement_amplitude(loc).tolist(),
                "acceleration_m_s2": res.acceleration_amplitude(loc).tolist(),
            }
            for loc in LOCATIONS
        }
    path.write_text(json.dumps(doc), encoding="utf-8")


def curves_figure(fem: HarmonicResponse, am: HarmonicResponse, title: str):
    """The FEM and AM curves as :func:`rigtools.analysis.plots.amplitude_frequency_figure`."""
    from rigtools.analysis.plots import amplitude_frequency_figure
    from rigtools.sim.harmonic import LOCATIONS

    curves = {
        label: {
            "displacement": {loc: res.displacement_amplitude(loc) for loc in LOCATIONS},
            "acceleration": {loc: res.acceleration_amplitude(loc) for loc in LOCATIONS},
        }
        for label, res in (("FEM", fem), ("AM", am))
    }
    return amplitude_frequency_figure(
        fem.frequencies_hz, curves, force_amplitude=fem.force_amplitude, title=title
    )


def run(args: argparse.Namespace) -> int:
    from rigtools.commands.simulate import announce_model, check_output, number, working

    out = Path(args.out)
    if out.suffix.lower() not in (".csv", ".json"):
        raise UserError(f"--out = {args.out!r}: the file name must end in .csv or .json")
    out = check_output(args)
    force = number(args.force, "force", "--force")
    fmin = number(args.fmin, "frequency", "--fmin")
    fmax = number(args.fmax, "frequency", "--fmax")
    if force <= 0:
        raise UserError(f"--force = {args.force!r}: must be > 0")
    if not 0 <= fmin < fmax:
        raise UserError(f"--fmin = {args.fmin!r}, --fmax = {args.fmax!r}: need 0 <= fmin < fmax")
    if not MIN_POINTS <= args.points <= MAX_POINTS:
        raise UserError(f"--points = {args.points}: must be between {MIN_POINTS} and {MAX_POINTS}")
    from rigtools.config import load_rig

    rig_config = load_rig(args.rig)
    params = rig_config.to_params()
    if params.force_sensor.position >= params.passive.length:
        raise UserError(
            f"force_sensor.position = {params.force_sensor.position} m is beyond the passive blade "
            f"(length {params.passive.length} m), which is driven at the same position"
        )
    elements = announce_model(params)
    from rigtools.sim.harmonic import harmonic_curves
    from rigtools.sim.rig_model import build_rig_model

    with working(f"FEM and AM curves at {args.points} frequencies ({elements})"):
        rig = build_rig_model(params)
        fem, am = harmonic_curves(rig, np.linspace(fmin, fmax, args.points), force)
    write_curves(out, fem, am, rig_config.name)
    from rigtools.figures import plot_path, save_figure

    png = save_figure(curves_figure(fem, am, rig_config.name), plot_path(out), dpi=120)
    print(
        f"wrote {out} and {png} ({args.points} frequencies {fmin:g}-{fmax:g} Hz, F0 = {force:g} N peak, "
        "FEM and AM peak amplitudes)"
    )
    return 0
