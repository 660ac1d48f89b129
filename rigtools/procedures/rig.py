"""Device and channel assembly for procedures: the backend, its channels, limits and metadata.

Command modules and lab scripts get a configured device from :func:`open_device` and
:func:`configure`; the recording's channels from :func:`channel_specs`; the safety monitor from
:func:`safety_monitor`; the experiment description from :func:`experiment_metadata`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict

from rigtools.drivers.contracts import ConfigurationError, DriverUnavailable
from rigtools.drivers.safety import ChannelLimit, SafetyMonitor
from rigtools.drivers.simulated import SimulatedRig
from rigtools.errors import UserError, option, reword
from rigtools.recording import ChannelSpec

BACKENDS = ("nidaq", "sim")


def sim_only(backend: str, *, pace: bool = False, faults: Sequence = (), seed: int | None = None) -> None:
    """Refuse the simulated rig's options (``pace``, ``faults``, ``seed``) with another backend:
    one line naming them (``rig acquire`` says it before any note of the backend)."""
    if backend == "sim" or not (pace or faults or seed is not None):
        return
    asked = (("pace", "--pace", pace), ("faults", "--fault", faults), ("seed", "--seed", seed is not None))
    given = [option(name, flag=flag) for name, flag, value in asked if value]
    raise UserError(f"{', '.join(given)}: for the simulated rig only; add {option('backend', 'sim')}")


def open_device(
    cfg,
    backend: str = "nidaq",
    *,
    pace: bool = False,
    faults: Sequence = (),
    seed: int | None = None,
    model: str = "auto",
):
    """The acquisition device of ``backend`` (not configured yet).

    Parameters
    ----------
    cfg
        The rig (:class:`rigtools.config.RigConfig`).
    backend
        ``"nidaq"`` (NI-DAQmx hardware) or ``"sim"`` (the simulated rig of ``cfg``).
    pace, faults, seed, model
        Simulated rig only: real-time pacing, injected faults, noise seed (``None``: 0, so that
        two runs record the same noise, as the demo's do), physics model.

    Raises
    ------
    UserError
        Simulated-rig options with the NI backend, or an unknown backend.
    rigtools.drivers.contracts.DriverUnavailable
        (exit 3) When NI-DAQmx is not installed; raised by :func:`configure`.
    """
    if backend == "sim":
        seed = 0 if seed is None else seed
        return SimulatedRig.from_config(cfg, pace=pace, faults=list(faults), seed=seed, model=model)
    if backend != "nidaq":
        raise UserError(
            f"backend = {backend!r}: use {option('backend', 'nidaq')} or {option('backend', 'sim')}"
        )
    sim_only(backend, pace=pace, faults=faults, seed=seed)
    try:  # the NI-DAQmx package is for the hardware only (a heavy optional package)
        from rigtools.drivers.nidaq import NiDaqDevice
    except ImportError:
        raise DriverUnavailable(
            "NI-DAQmx (the nidaqmx package) is not installed; "
            f"use {option('backend', 'sim')} to run on the simulated rig"
        ) from None
    return NiDaqDevice(abort_ramp_time=cfg.safety.abort_ramp_time)


def configure(device, cfg) -> float:
    """Channels and clock from ``[daq]``; returns the actual (coerced) sample rate."""
    try:
        return device.configure(
            cfg.daq.input_specs(), cfg.daq.output_spec(), cfg.daq.sample_rate, cfg.daq.block_size()
        )
    except DriverUnavailable as exc:
        text = str(exc).replace("--simulated", "--backend sim")
        raise reword(DriverUnavailable(text)) from None
    except ConfigurationError as exc:
        raise UserError(str(exc)) from None


def safety_monitor(cfg, device):
    """The ``[safety]`` limits on the device's inputs and the drive."""
    limits = [ChannelLimit(name, lim.warning, lim.abort) for name, lim in cfg.safety.limits.items()]
    return SafetyMonitor(limits, device.input_channels, max_drive=cfg.safety.max_drive)


def channel_specs(device, cfg, rate: float) -> list:
    """Recording channels: every input (from its spec), then the drive as written."""
    specs = [
        ChannelSpec(
            name=s.name,
            units=s.units,
            quantity=s.quantity,
            sample_rate=rate,
            sensitivity=s.sensitivity,
            sensitivity_units=s.sensitivity_units,
            physical_channel=s.physical_channel,
            location=s.location or None,
        )
        for s in device.input_channels
    ]
    out = cfg.daq.output_spec()
    specs.append(
        ChannelSpec(
            name=out.name,
            units="V",
            quantity="voltage",
            sample_rate=rate,
            physical_channel=out.physical_channel,
            location="drive output to the shaker amplifier (as written)",
        )
    )
    return specs


def force_row(device) -> int:
    """Row of the force sensor in the device's blocks."""
    for i, spec in enumerate(device.input_channels):
        if spec.kind == "force":
            return i
    raise UserError('the rig file\'s [daq] has no force channel (kind = "force"); force control needs one')


def experiment_metadata(procedure: str, device, parameters: dict, **extra) -> dict:
    """The recording's ``experiment`` attribute: procedure, its parameters, the device."""
    doc = {
        "procedure": procedure,
        "parameters": parameters,
        "device": asdict(device.info()),
        "faults": [
            f"{f.kind}@{f.at_time if f.at_time is not None else f.at_block}:{f.channel or ''}"
            for f in getattr(device, "faults", ())
        ],
        "pace": bool(getattr(device, "pace", False)),
    }
    doc.update(extra)
    return doc
