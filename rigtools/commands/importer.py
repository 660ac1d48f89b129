"""``rig import``: another tool's log as a recording (TDMS from NI-DAQmx logging or LabVIEW)."""

from __future__ import annotations

import argparse

from rigtools import json_values
from rigtools.errors import UserError
from rigtools.options import output_path, quantity

HELP = "import a TDMS log (NI-DAQmx configure_logging, LabVIEW) as a recording"
EPILOG = """\
rig import tdms IN.tdms OUT.h5 reads the log with npTDMS and writes a recording (backend
"tdms"): every TDMS group becomes a point, its channels the point's channels; the sample rate
comes from the waveform property wf_increment (or --sample-rate), units from unit_string,
converted to SI (g -> m/s^2, lbf -> N, mV -> V). DAQmx raw logs are scaled with the scaling
stored in the file. Channel names keep letters, digits, _ . - ("Dev1/ai0" -> "Dev1_ai0");
--rename maps them onto the toolkit's names so analysis and comparison find them.

examples:
  rig import tdms log.tdms log.h5
  rig import tdms log.tdms log.h5 --rename "Dev1/ai0=force,Dev1/ai1=active_shroud_accel" --rig lab.toml --overwrite

Exit status: 0 written, 2 bad input (not a TDMS file, no units or timing, existing OUT).
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "import",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("format", choices=("tdms",), help="input format")
    p.add_argument("source", metavar="IN", help="the file to import")
    p.add_argument("out", metavar="OUT.h5", help="recording to write")
    p.add_argument(
        "--rig", metavar="FILE", help="rig file stored with the recording (default: the default rig)"
    )
    p.add_argument("--rename", default="", metavar="OLD=NEW,...", help="channel renames")
    p.add_argument("--sample-rate", default=None, help='for logs without waveform timing, e.g. "51.2 kHz"')
    p.add_argument("--overwrite", action="store_true", help="replace OUT if it exists")
    p.add_argument("--json", action="store_true", help="print what was written as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.config import load_rig
    from rigtools.interop.tdms import check_renames, import_tdms, parse_rename

    rename = parse_rename(args.rename)
    rate = None
    if args.sample_rate is not None:
        rate = quantity(args.sample_rate, "frequency", "--sample-rate")
        if not rate > 0:
            raise UserError(f"--sample-rate = {args.sample_rate!r}: must be > 0 Hz")
    out = output_path(
        args.out, args.overwrite, "OUT", inputs=[args.source, *([args.rig] if args.rig else [])]
    )
    cfg = load_rig(args.rig)
    check_renames(args.source, rename)
    summary = import_tdms(
        args.source, out, rig=cfg.to_json(), overwrite=args.overwrite, rename=rename, sample_rate=rate
    )
    if args.json:
        print(json_values.dumps({"file": str(out), **summary}))
    else:
        for p in summary["points"]:
            print(
                f"point from group {p['group']!r}: {len(p['channels'])} channels "
                f"({', '.join(p['channels'])}), {p['samples']} samples at {p['sample_rate']:g} Hz"
            )
        print(f"wrote {out}")
    return 0
