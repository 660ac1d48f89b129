"""``rig simulate``: one vibro-impact run of the FE (or AM) model, settled and recorded as HDF5.

Parse, call :mod:`rigtools.simulation` (options shared with ``rig study``:
:mod:`rigtools.model_options`), print.
"""

from __future__ import annotations

import argparse
import math
import sys
import textwrap
from pathlib import Path

from rigtools import json_values
from rigtools import model_options as mo
from rigtools.errors import exit_status_help
from rigtools.options import HDF5_SUFFIXES, check_out, gap
from rigtools.vocabulary import channel_names, describe_channels

HELP = "simulate the vibro-impact response (FE or assumed-modes model) and record it as HDF5"
EPILOG = f"""\
A force F0 sin(2 pi fe t) acts at the force-sensor position of the active blade; the shrouds
hit each other across the gap (penalty contact of the rig file's [contact]). The reduced model
(low flexural modes plus static correction) is stepped exactly per mode with the contact solved
in every step, run from rest until the response repeats period after period (steady state,
reported), then --duration is recorded.

Written channels (one point, backend "fem", SI units, names as in rig acquire's recordings):
{textwrap.fill(describe_channels(channel_names("fem")) + ".", 95)}
"force" is the force into the active blade at the sensor, as on the rig.
Point parameters: fe, force_amplitude (F0, N), gap (m), model, steps_per_period, time_step,
settle_time; at the end settled, period_multiple, peak_contact_force (N), impacts_per_period,
force_amplitude_measured (N, harmonic 1 of the force channel, as rig acquire writes it).

--json prints {{"harmonics": {{channel: [{{"k", "frequency_hz", "amplitude"}}, ...]}},
"contact": {{"peak_force_n", "impacts_per_period"}}, "steady_state": true|false, "plot": PNG
path or null}} for k = 1..30 of active_shroud_accel, passive_shroud_accel, force and
contact_force (peak amplitudes; the acceleration harmonics come from the velocity, k w |V_k|,
exact for a periodic response).

Plot: FILE.png beside FILE.h5 (--no-plot skips it): the shroud displacements (mm) and the
contact force (N) over the last 3 periods, and the amplitude spectra (m/s^2) of both shroud
accelerations with k*fe and the blades' flexural natural frequencies marked (the paper's
Figure 9).

Quantities take units: "0.5 mm", "15 N", "60 Hz", "2 s"; a plain number is SI (m, N, Hz, s),
so write gaps with "mm": a gap above 50 mm is refused. Work that needs more memory than the
machine has (a very stiff contact with a long --duration) is refused up front with the
estimate; work that may take over a minute (a stiff contact, a high --fe: the steps per period
x the periods to settle, which grow with fe, x the model's modes; a large [blade] elements:
the model build) is announced on stderr with its estimate. An --fe more than 10 x the model's
highest mode is refused: the model's response there is not the blades'.

{exit_status_help(0, 2, notes={0: "written", 2: "bad input (options, rig file, --out)"})}
A signal before the run is written: nothing is written; once it is, the file is completed.

examples:
  rig simulate --out run.h5
  rig simulate --fe 60 --force 15 --gap "0.5 mm" --duration 1 --out fem.h5 --json
  rig simulate --model am --gap "0.7 mm" --out am.h5 --overwrite
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "simulate",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--fe", default="60 Hz", help='excitation frequency (default "60 Hz")')
    p.add_argument("--force", default="15 N", help='force amplitude F0 (default "15 N")')
    p.add_argument("--gap", default=None, help='shroud gap (default: the rig file\'s, e.g. "0.5 mm")')
    mo.add_model_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.errors import Interrupted as Stopped
    from rigtools.runtime import StopRequests

    written: list[Path] = []
    with StopRequests() as stops:
        try:
            code = _run(args, stops, written)
        except Stopped as exc:
            what = (
                "nothing written",
                "{} is complete (no summary or plot)",
                "{} and {} are complete (no summary)",
            )
            print(f"rig simulate: {exc.reason}; {what[len(written)].format(*written)}", file=sys.stderr)
            code = exc.exit_code
    return code


def _run(args: argparse.Namespace, stops, written: list) -> int:
    from rigtools import simulation as simu
    from rigtools.progress import simulated_time_bar
    from rigtools.recording import RecordingWriter

    out = check_out(args, suffixes=HDF5_SUFFIXES)
    fe, force = mo.excitation(args.fe, args.force)
    new_gap = None if args.gap is None else gap(args.gap)
    settings = mo.settings_of(args, [fe])
    with mo.plot_ahead(args.no_plot) as helper:
        cfg, system = mo.load_model(args.rig, args.model, quiet=args.json)
        if new_gap is not None:
            system = system.with_contact(gap=new_gap)
        mo.announce_work(system, [(fe, force)], settings, quiet=args.json)
        with simulated_time_bar(
            f"{fe:g} Hz, {force:g} N, gap {system.contact.gap * 1e3:g} mm",
            (max(math.ceil(settings.max_settle_time * fe), 5) + settings.record_periods(fe)) / fe,
            args.json,
        ) as progress:
            result = simu.simulate_point(system, fe, force, settings, progress=progress)
        experiment = {"procedure": "simulate", "model": args.model, "cli": "rig simulate"}
        with stops.protected():  # a stop request waits until the file is complete
            with RecordingWriter(
                out, backend="fem", rig=cfg.to_json(), experiment=experiment, overwrite=args.overwrite
            ) as rec:
                simu.write_point(rec, result, args.model)
            written.append(out)
        title = f"{cfg.name} ({args.model.upper()})"
        png = mo.write_plot(args.no_plot, out, simu.run_figure(result, system, title), helper)
        written += [png] if png is not None else []
    doc = {
        "harmonics": simu.harmonics_of(result),
        "contact": {
            "peak_force_n": result.peak_contact_force,
            "impacts_per_period": result.impacts_per_period,
        },
        "steady_state": bool(result.steady_state),
    }
    doc["plot"] = None if png is None else str(png)
    if args.json:
        print(json_values.dumps(doc))
    else:
        from rich.console import Console

        from rigtools.tables import run_tables

        console = Console()
        for item in run_tables(doc, result, out):
            console.print(item)
    return 0
