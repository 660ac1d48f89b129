"""``rig devices``: list NI-DAQmx devices and VISA resources, or say why none can be listed."""

from __future__ import annotations

import argparse
from pathlib import Path

from rigtools import json_values
from rigtools.errors import UserError, exit_status_help

SIMULATED_HINT = "use --backend sim to run on the simulated rig (no hardware needed)"

HELP = (
    f"""\
List the acquisition hardware this machine can see:

  NI-DAQmx  devices from the local NI-DAQmx system (name, product type, serial number,
            analog input and output channels), for [daq] in the rig file;
  VISA      resources of the default VISA library (e.g. a 33500-series waveform generator
            feeding the shaker amplifier), for [signal_source] in the rig file.

When a backend cannot be listed (NI-DAQmx driver or VISA library not installed), one line says
why. Without hardware, {SIMULATED_HINT}.

"""
    + exit_status_help(
        0,
        2,
        3,
        notes={
            0: "at least one backend could be listed (even if it found nothing)",
            2: "bad usage",
            3: "neither NI-DAQmx nor VISA is available on this machine",
        },
    )
    + """

examples:
  rig devices
  rig devices --json
  rig devices --visa-backend @py                 # pyvisa-py instead of NI-VISA/Keysight VISA
  rig devices --visa-backend simulated           # the simulated generator shipped with rigtools
"""
)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "devices",
        help="list NI-DAQmx devices and VISA resources (exit 0 listed, 3 none available)",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help='print {"nidaqmx": {"available", "driver_version", "devices", "reason"}, '
        '"visa": {"available", "backend", "resources", "reason"}}',
    )
    parser.add_argument(
        "--visa-backend",
        default="",
        metavar="BACKEND",
        help='pyvisa backend: "" default VISA library (default), "@py" pyvisa-py, '
        '"FILE.yaml@sim" a pyvisa-sim description, "simulated" the shipped one',
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rigtools.drivers.inventory import list_ni_devices, list_visa_resources

    if args.visa_backend and not (
        args.visa_backend in ("simulated", "@py", "@ivi") or args.visa_backend.endswith("@sim")
    ):
        raise UserError(
            f"--visa-backend {args.visa_backend!r}: expected '', '@py', '@ivi', "
            "'FILE.yaml@sim' or 'simulated'"
        )
    description = args.visa_backend.removesuffix("@sim")
    if args.visa_backend.endswith("@sim") and description and not Path(description).is_file():
        raise UserError(f"--visa-backend {args.visa_backend!r}: no such file {description!r}")
    ni = list_ni_devices()
    visa = list_visa_resources(args.visa_backend)
    code = 0 if (ni["available"] or visa["available"]) else 3
    if args.json:
        print(json_values.dumps({"nidaqmx": ni, "visa": visa}, indent=1))
        return code

    if ni["available"]:
        print(
            f"NI-DAQmx {ni['driver_version']}: "
            f"{len(ni['devices'])} device{'s' * (len(ni['devices']) != 1)}"
            + ("" if ni["devices"] else " found")
        )
        for dev in ni["devices"]:
            print(
                f"  {dev['name']}  {dev['product_type']}  s/n {dev['serial_number']}  "
                f"AI {len(dev['ai_channels'])}  AO {len(dev['ao_channels'])}"
            )
    else:
        print(f"NI-DAQmx: cannot list devices: {ni['reason']}")
    if visa["available"]:
        n = len(visa["resources"])
        print(f"VISA ({visa['library']}): {n} resource{'s' * (n != 1)}" + ("" if n else " found"))
        for name in visa["resources"]:
            print(f"  {name}")
    else:
        print(f"VISA: cannot list resources: {visa['reason']}")
    if not ni["available"]:
        print(f"Without NI hardware, {SIMULATED_HINT}.")
    return code
