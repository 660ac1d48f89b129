"""What acquisition hardware this machine can see: NI-DAQmx devices and VISA resources, as plain
data, each with the one-line reason when a backend cannot be listed (``rig devices``).

Only ``rig devices`` imports this module (inside its ``run``), so ``rig --help`` loads neither
pyvisa (a dependency, imported here at the head through :mod:`rigtools.drivers.visa_source`) nor
nidaqmx (imported when listing: the package may be absent or lack its driver library).
"""

from __future__ import annotations

import contextlib
from typing import Any

from rigtools.drivers.contracts import DriverUnavailable
from rigtools.drivers.errors import one_line
from rigtools.drivers.visa_source import open_resource_manager, simulator_backend


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
            "reason": f"the nidaqmx Python package is not installed ({one_line(exc, first=True)})",
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
            "reason": f"NI-DAQmx error: {one_line(exc, first=True)} (DAQmx {exc.error_code})",
        }
    return {
        "available": True,
        "driver_version": f"{version.major_version}.{version.minor_version}.{version.update_version}",
        "devices": devices,
        "reason": None,
    }


def list_visa_resources(backend: str = "") -> dict[str, Any]:
    """VISA resources as plain data; ``reason`` says why there are none to list."""
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
    except Exception as exc:  # noqa: BLE001 -- a VISA library may raise anything while listing: say so, don't crash
        return {
            "available": False,
            "backend": backend or "default",
            "resources": [],
            "reason": f"VISA library failed to list resources: {one_line(exc, first=True)}",
        }
    finally:
        with contextlib.suppress(Exception):  # closing a failed VISA session: nothing more to report
            rm.close()
    return {
        "available": True,
        "backend": backend or "default",
        "library": library,
        "resources": resources,
        "reason": None,
    }
