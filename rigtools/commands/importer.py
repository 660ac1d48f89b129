"""``rig import``: another tool's file as a recording (TDMS, LabVIEW .lvm, UFF 58)."""

from __future__ import annotations

import argparse

from rigtools import json_values
from rigtools.errors import UserError, exit_status_help
from rigtools.options import HDF5_SUFFIXES, output_path, positive_finite

HELP = "import a TDMS log, a LabVIEW measurement file or UFF 58 records as a recording"
EPILOG = (
    """\
rig import FORMAT IN OUT.h5 writes a recording of another tool's file and prints one line per
channel saying what it did with it (kept: name, quantity, SI units and conversion; skipped: why).
  tdms  NI-DAQmx / LabVIEW logs (npTDMS): every group a point; rate from wf_increment (or
        --sample-rate), units from unit_string.
  lvm   LabVIEW measurement files (.lvm or .lvm.gz; decimal comma, several segments, multi
        headings): every segment a point; rate from Delta_X, units from Y_Unit_Label.
  uff   UFF 58: time records become a recording; FRFs (with their coherence) an FRF set
        (an .h5 that rig analyze identifies modes from). A record is named by its entity,
        node and direction (acc:2+Y; :acceleration etc. added where only the quantity tells
        two apart; the full channel name in files rig export uff wrote); recordN (the file's
        N-th record 58) names one record alone in --map, --units and --channel.
Units are converted to SI (g -> m/s^2, lbf -> N, mV -> V, degC -> K, ...). A channel without
units takes those of the toolkit channel of its name (force -> N), else is skipped: supply them
with --units NAME=UNIT. Channels of unequal length or rate are kept whole in points of their own.
Channel names keep letters, digits, _ . - ("Dev1/ai0" -> "Dev1_ai0"); --map OLD=NEW renames.
The excitation is the one channel of quantity force, or the one --reference names.

examples:
  rig import tdms log.tdms log.h5
  rig import tdms log.tdms log.h5 --rename "Dev1/ai0=force,Dev1/ai1=active_shroud_accel" --rig lab.toml --overwrite

"""
    + exit_status_help(
        0,
        2,
        notes={
            0: "written",
            2: "bad input (unreadable file, nothing to import, an option naming no channel, existing OUT)",
        },
    )
    + """
"""
)
FORMATS = ("tdms", "lvm", "uff")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "import",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("format", choices=FORMATS, help="input format")
    p.add_argument("source", metavar="IN", help="the file to import")
    p.add_argument("out", metavar="OUT.h5", help="recording (or FRF set) to write")
    p.add_argument(
        "--rig", metavar="FILE", help="rig file stored with the recording (default: the default rig)"
    )
    p.add_argument(
        "--map", "--rename", dest="map", action="append", metavar="OLD=NEW", help="rename a channel"
    )
    p.add_argument(
        "--units", action="append", metavar="CHANNEL=UNIT", help="units of a channel, e.g. force=N"
    )
    p.add_argument("--group", action="append", metavar="NAME", help="TDMS: import only this group")
    p.add_argument("--channel", action="append", metavar="NAME", help="import only this channel")
    p.add_argument("--reference", metavar="CHANNEL", help="the excitation (default: the one force channel)")
    p.add_argument("--sample-rate", default=None, help='TDMS logs without waveform timing, e.g. "51.2 kHz"')
    p.add_argument("--overwrite", action="store_true", help="replace OUT if it exists")
    p.add_argument("--json", action="store_true", help="print what was done with each channel as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.config import load_rig
    from rigtools.interop.channels import parse_pairs

    mapping = parse_pairs(args.map, "--map")
    units = parse_pairs(args.units, "--units")
    rate = None
    if args.sample_rate is not None:
        if args.format != "tdms":
            raise UserError("--sample-rate is for TDMS logs (LVM and UFF files state their timing)")
        rate = positive_finite(args.sample_rate, "frequency", "--sample-rate", unit="Hz")
    if args.group and args.format != "tdms":
        raise UserError("--group is for TDMS files (their groups)")
    out = output_path(
        args.out,
        args.overwrite,
        "OUT",
        suffixes=HDF5_SUFFIXES,
        inputs=[args.source, *([args.rig] if args.rig else [])],
    )
    common = {
        "rig": load_rig(args.rig).to_json(),
        "overwrite": args.overwrite,
        "mapping": mapping,
        "units": units,
        "channels": args.channel,
        "reference": args.reference,
    }
    if args.format == "tdms":
        from rigtools.interop.tdms import import_tdms

        summary = import_tdms(args.source, out, groups=args.group, sample_rate=rate, **common)
    elif args.format == "lvm":
        from rigtools.interop.lvm import import_lvm

        summary = import_lvm(args.source, out, **common)
    else:
        from rigtools.interop.uff import import_uff

        summary = import_uff(args.source, out, **common)
    if args.json:
        print(json_values.dumps({"file": str(out), **{k: v for k, v in summary.items() if k != "lines"}}))
    else:
        for line in summary["lines"]:
            print(line)
        print(f"wrote {out}")
    return 0
