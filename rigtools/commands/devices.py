"""``rig devices``: list NI-DAQmx devices and VISA resources, or say why none can be listed."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from rigtools.errors import UserError

SIMULATED_HINT = "use --backend sim to run on the simulated rig (no hardware needed)"

HELP = f"""\
List the acquisition hardware this machine can see:

  NI-DAQmx  devices from the local NI-DAQmx system (name, product type, serial number,
            analog input and output channels), for [daq] in the rig file;
  VISA      resources of the default VISA library (e.g. a 33500-series waveform generator
            feeding the shaker amplifier), for [signal_source] in the rig file.

When a backend cannot be listed (NI-DAQmx driver or VISA library not installed), one line says
why. Without hardware, {SIMULATED_HINT}.

Exit status: 0 at least one backend could be listed (even if it found nothing),
3 neither NI-DAQmx nor VISA is available on this machine, 2 bad usage.

examples:
  rig devices
  rig devices --json
  rig devices --visa-backend @py                 # pyvisa-py instead of NI-VISA/Keysight VISA
  rig devices --visa-backend simulated           # the simulated generator shipped with rigtools
"""


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


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def list_ni_devices() -> dict[str, Any]:
    """NI-DAQmx devices as plain data; ``reason`` says why there are none to list."""
    try:  # here, not at the top: `rig --help` must not load nidaqmx
        import nidaqmx.system
        from nidaqmx.errors import DaqError, DaqNotFoundError, DaqNotSupportedError
    except ImportError as exc:
        return {
            "available": False,
            "driver_version": None,
            "devices": [],
            "reason": f"the nidaqmx Python package is not installed ({_first_line(exc)})",
        }
    try:
        system = nidaqmx.system.System.local()
        version = system.driver_version
        devices = []
        for dev in system.devices:
            devices.append(
                {
                    "name": dev.name,
                    "product_type": dev.product_type,
                    "serial_number": f"{dev.serial_num:X}",
                    "ai_channels": [c.name for c in dev.ai_physical_chans],
                    "ao_channels": [c.name for c in dev.ao_physical_chans],
                }
            )
    except DaqNotFoundError:
        return {
            "available": False,
            "driver_version": None,
            "devices": [],
            "reason": "NI-DAQmx driver not installed on this machine",
        }
    except DaqNotSupportedError:
        return {
            "available": False,
            "driver_version": None,
            "devices": [],
            "reason": "NI-DAQmx is not supported on this platform",
        }
    except DaqError as exc:
        return {
            "available": False,
            "driver_version": None,
            "devices": [],
            "reason": f"NI-DAQmx error: {_first_line(exc)} (DAQmx {exc.error_code})",
        }
    return {
        "available": True,
        "driver_version": f"{version.major_version}.{version.minor_version}.{version.update_version}",
        "devices": devices,
        "reason": None,
    }


def list_visa_resources(backend: str = "") -> dict[str, Any]:
    """VISA resources as plain data; ``reason`` says why there are none to list."""
    try:  # here, not at the top: `rig --help` must not load pyvisa
        from rigtools.drivers.contracts import DriverUnavailable
        from rigtools.drivers.visa_source import open_resource_manager, simulator_backend
    except ImportError as exc:
        return {
            "available": False,
            "backend": backend or "default",
            "resources": [],
            "reason": f"the pyvisa Python package is not installed ({_first_line(exc)})",
        }
    if backend == "simulated":
        backend = simulator_backend()
    try:
        rm = open_resource_manager(backend)
    except DriverUnavailable as exc:
        return {
            "available": False,
            "backend": backend or "default",
            "resources": [],
            "reason": str(exc).removesuffix(", or use --backend sim"),
        }
    try:
        resources = list(rm.list_resources())
        library = str(rm.visalib)
    except Exception as exc:  # a VISA library that fails while listing: say so, don't crash
        return {
            "available": False,
            "backend": backend or "default",
            "resources": [],
            "reason": f"VISA library failed to list resources: {_first_line(exc)}",
        }
    finally:
        try:
            rm.close()
        except Exception:
            pass
    return {
        "available": True,
        "backend": backend or "default",
        "library": library,
        "resources": resources,
        "reason": None,
    }


def run(args: argparse.Namespace) -> int:
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
        print(json.dumps({"nidaqmx": ni, "visa": visa}, indent=1))
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
