"""Recording schema v1: the names, types and rules every recording follows.

The layout is documented for humans in ``docs/recording-format.md``; this module is the same
description for code (writer, reader and validator all take their names from here).

::

    /                         root attributes: ROOT_ATTRS
    /points/0000              one group per steady-state point; attributes: POINT_ATTRS + parameters
    /points/0000/<channel>    one 1-D float64 dataset per channel; attributes: CHANNEL_ATTRS
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from datetime import UTC, datetime
from numbers import Integral, Real
from typing import Any

import numpy as np

from rigtools.errors import FaultError, UserError
from rigtools.vocabulary import MODEL_BACKENDS, channel_name_legal

SCHEMA_NAME = "rigtools.recording"
SCHEMA_VERSION = 1

STATUS_RECORDING = "recording"
STATUS_COMPLETE = "complete"
STATUS_ABORTED = "aborted"
STATUSES = (STATUS_RECORDING, STATUS_COMPLETE, STATUS_ABORTED)

# "model": a model recording holding runs of more than one model (the demo's FEM and AM points,
# each naming its model in the point parameter "model"). Others are allowed: an import source.
KNOWN_BACKENDS = ("nidaqmx", "simulated", *MODEL_BACKENDS)
#: Procedures whose every point is a sine run at its parameter ``fe`` (as is every point of a
#: model recording): ``rig check`` refuses such a point without ``fe > 0``.
#: The procedures whose points are controlled points (:class:`rigtools.controlled_point.ControlledPoint`).
CONTROLLED_PROCEDURES = ("phase-locked loop", "control-based continuation")
SINE_PROCEDURES = ("sine dwell", "stepped sine", "rig study", *CONTROLLED_PROCEDURES)
#: The highest sample rate a channel may have (Hz): 1 GS/s is far above any DAQ that records
#: vibration; a rate above it is a header error (an increment of 1e-300 s), never a record.
MAX_SAMPLE_RATE = 1e9

POINTS_GROUP = "points"

# name -> (kind, meaning). kind: "text" (UTF-8 string), "int", "float".
ROOT_ATTRS: dict[str, tuple[str, str]] = {
    "schema": ("text", f'always "{SCHEMA_NAME}"'),
    "schema_version": ("int", f"format version; this software writes {SCHEMA_VERSION}"),
    "created": ("text", "ISO 8601 UTC time the file was created"),
    "software_version": ("text", "rigtools version that wrote the file"),
    "backend": (
        "text",
        'where the data came from: "nidaqmx", "simulated", "fem", "model" or an import source',
    ),
    "status": ("text", '"recording" while written, then "complete" or "aborted"'),
    "abort_reason": ("text", 'one line saying why the run stopped early; "" otherwise'),
    "ended": ("text", 'ISO 8601 UTC time the writer finished; "" while recording'),
    "rig": ("text", "the full rig description (TOML or JSON text)"),
    "experiment": ("text", "the experiment description (JSON object text)"),
}

# Optional root attributes: how a procedure ended (rigtools.procedures), set after the writer
# closed the file. status "complete" <-> end_status "finished"; "aborted" <-> "aborted" (a stop
# request, Ctrl-C, a signal) or "failed" (a fault, a safety abort, an error), abort_reason then
# starting "aborted: " / "failed: ".
END_FINISHED, END_ABORTED, END_FAILED = "finished", "aborted", "failed"
END_STATUSES = (END_FINISHED, END_ABORTED, END_FAILED)
OPTIONAL_ROOT_ATTRS: dict[str, tuple[str, str]] = {
    "end_status": ("text", 'how the procedure ended: "finished", "aborted" or "failed"'),
    "end_reason": ("text", 'one line: why it ended so ("" when finished)'),
}

POINT_ATTRS: dict[str, tuple[str, str]] = {
    "start_time": ("text", "ISO 8601 UTC time the point started"),
    "end_time": ("text", 'ISO 8601 UTC time the point ended; "" if it never ended (writer killed)'),
}

# Well-known point parameters (SI). Any other text/number/bool parameter may be added.
STANDARD_PARAMETERS: dict[str, str] = {
    "fe": "excitation frequency, Hz",
    "force_amplitude": "commanded (or simulated) force amplitude F0, N",
    "gap": "shroud gap, m",
    "force_amplitude_measured": "fundamental (peak) of the force into the blade, N (v1 files before "
    "this name: measured_force_amplitude)",
    "settled": "true if the response was steady when recorded",
    "drive_amplitude": "drive voltage amplitude, V",
    "record_start": "start of the settled record window, s from the start of the point",
    "record_samples": "samples in the settled record window (the analysed part of the point)",
    "model": 'model points: the model run, "fem" or "am"',
}

CHANNEL_ATTRS: dict[str, tuple[str, str]] = {
    "units": ("text", 'SI units of the samples, e.g. "N", "m/s^2", "m", "V"'),
    "quantity": ("text", '"force", "acceleration", "displacement", "velocity", "voltage", ...'),
    "sample_rate": ("float", "samples per second, Hz"),
    "t0": ("float", "time of the first sample, s from the start of the point"),
}
# For measured channels (all optional in the file; written when known).
MEASURED_CHANNEL_ATTRS: dict[str, tuple[str, str]] = {
    "sensitivity": ("float", "sensor sensitivity in sensitivity_units"),
    "sensitivity_units": ("text", 'units of sensitivity, e.g. "mV/g", "mV/N"'),
    "physical_channel": ("text", 'DAQ channel, e.g. "Dev1/ai0"'),
    "location": ("text", 'where the sensor sits, e.g. "active blade, x=0.180 m"'),
    "node": ("int", "the sensor's point number in a test geometry (UFF node), as an imported file gave it"),
    "direction": ("int", "what the sensor measures, a UFF direction code (-6..6: 1..6 = +X..+RZ, 0 none)"),
    "entity": ("text", "the file's name of the sensor's point (UFF entity name, 10 characters at most)"),
    "description": ("text", 'what the file calls the record (UFF ID line 1, e.g. "MPS set1 Dof1")'),
}
#: UFF node numbers are written in a 10-character integer field; readers take them as int32
NODE_MAX = 2**31 - 1
#: direction codes: +-1..6 (+X..+RZ and the opposite senses) and 0 (none)
DIRECTION_MAX = 6

RESERVED_POINT_NAMES = frozenset(POINT_ATTRS)
_POINT_NAME = re.compile(r"^\d{4,}$")


#: The SI units a channel's samples may be stored in (what every reader converts from): an
#: importer converts other units (g, mV, lbf, degC, psi, ...) to these. The rig's own channels use
#: the first five; an imported log keeps channels of other quantities (current, temperature,
#: pressure, strain, angle, speed, time, ratios) in theirs (:data:`rigtools.interop.channels.UNITS`).
CHANNEL_UNITS = ("N", "m/s^2", "m/s", "m", "V", "A", "K", "Pa", "m/m", "rad", "Hz", "s", "1")

#: Point parameters readers compute with, and their rule: ``(lowest, strictly above it)``.
#: ``fe`` is also below the Nyquist frequency of the point's channels (rig check).
NUMERIC_POINT_PARAMS: dict[str, tuple[float, bool]] = {
    "fe": (0.0, False),  # 0: no single excitation frequency (an FRF test)
    "force_amplitude": (0.0, False),
    "gap": (0.0, False),
    "record_start": (0.0, False),
    "record_samples": (0.0, False),
    "frame_samples": (0.0, True),
    "band_low": (0.0, False),
    "band_high": (0.0, True),
    "study_value": (-math.inf, False),
}


class RecordingError(UserError):
    """A recording file that cannot be created, opened or trusted; the message is one line."""


class RecordingWriteError(RecordingError, FaultError):
    """Writing a recording failed in the operating system (disk full, quota, file too large, I/O).

    The message names the file and the OS error on one line. Everything flushed before stays
    readable; the writer marked the file ``aborted`` with this message where the disk still
    allowed it. Exit status 4 (a fault stopped the run).
    """


def point_name(index: int) -> str:
    """Group name of point ``index``: ``"0000"``, ``"0001"``, ... (at least four digits)."""
    return f"{index:04d}"


def point_index(name: str) -> int | None:
    """Index encoded in a point group name, or ``None`` if the name is not a point name."""
    return int(name) if _POINT_NAME.match(name) else None


def utc_now() -> str:
    """The current time as ISO 8601 text in UTC, e.g. ``2026-11-01T05:31:07.123456+00:00``."""
    return datetime.now(UTC).isoformat(timespec="microseconds")


def parse_utc(text: str) -> datetime:
    """Parse ISO 8601 text written by :func:`utc_now`; raises ValueError unless it carries UTC."""
    value = datetime.fromisoformat(text)
    offset = value.utcoffset()
    if offset is None or offset.total_seconds() != 0:
        raise ValueError(f"{text!r} is not UTC")
    return value


#: the optional text fields of :class:`ChannelSpec`
TEXT_FIELDS = ("sensitivity_units", "physical_channel", "location", "entity", "description")


@dataclass(frozen=True)
class ChannelSpec:
    """What one recorded channel holds.

    Parameters
    ----------
    name : str
        Dataset name inside the point group (letters, digits, ``_ . -``), e.g. ``"force"``.
    units : str
        SI units of the samples as stored, e.g. ``"N"``, ``"m/s^2"``.
    quantity : str
        ``"force"``, ``"acceleration"``, ``"displacement"``, ``"velocity"``, ``"voltage"``, ...
    sample_rate : float
        Samples per second, Hz (> 0). All channels of a point share it.
    t0 : float
        Time of the first sample in seconds from the start of the point.
    sensitivity, sensitivity_units, physical_channel, location
        For measured channels: the sensor's sensitivity (e.g. ``10.0`` with ``"mV/g"``), the DAQ
        channel (``"Dev1/ai1"``) and where the sensor sits (``"active blade, x=0.180 m"``).
    node, direction, entity, description
        Where an imported file put the sensor and what it called the record: node number
        (0..2**31-1), UFF direction code (-6..6: 1..6 = +X..+RZ, negative the opposite sense, 0
        none), entity name and ID line 1 (``rig export uff`` writes them back).
    """

    name: str
    units: str
    quantity: str
    sample_rate: float
    t0: float = 0.0
    sensitivity: float | None = None
    sensitivity_units: str | None = None
    physical_channel: str | None = None
    location: str | None = None
    node: int | None = None
    direction: int | None = None
    entity: str | None = None
    description: str | None = None

    def __post_init__(self) -> None:
        if not channel_name_legal(self.name):
            raise ValueError(f"channel name {self.name!r}: use letters, digits, '_', '.', '-'")
        for key in ("units", "quantity"):
            if not isinstance(getattr(self, key), str):  # every bad field: ValueError (config.py catches it)
                raise ValueError(f"channel {self.name!r}: {key} must be text")  # noqa: TRY004 - see the if
        if not (
            isinstance(self.sample_rate, Real)
            and math.isfinite(self.sample_rate)
            and 0 < self.sample_rate <= MAX_SAMPLE_RATE
        ):
            raise ValueError(
                f"channel {self.name!r}: sample_rate {self.sample_rate!r} must be > 0 Hz and at most "
                f"{MAX_SAMPLE_RATE:g} Hz"
            )
        if not (isinstance(self.t0, Real) and math.isfinite(self.t0)):
            raise ValueError(f"channel {self.name!r}: t0 {self.t0!r} must be a finite number of s")
        if self.sensitivity is not None and not (
            isinstance(self.sensitivity, Real) and math.isfinite(self.sensitivity) and self.sensitivity != 0
        ):
            raise ValueError(
                f"channel {self.name!r}: sensitivity {self.sensitivity!r} must be a finite non-zero number"
            )
        for key in TEXT_FIELDS:
            value = getattr(self, key)
            if value is not None and not isinstance(value, str):
                raise ValueError(f"channel {self.name!r}: {key} must be text")
        for key, low, high in (("node", 0, NODE_MAX), ("direction", -DIRECTION_MAX, DIRECTION_MAX)):
            value = getattr(self, key)
            if value is not None and not (
                isinstance(value, Integral)
                and not isinstance(value, (bool, np.bool_))
                and low <= value <= high
            ):
                raise ValueError(
                    f"channel {self.name!r}: {key} {value!r} must be an integer in {low}..{high}"
                )

    def attrs(self) -> dict[str, Any]:
        """The dataset attributes of this channel (optional ones only when set)."""
        out: dict[str, Any] = {
            "units": self.units,
            "quantity": self.quantity,
            "sample_rate": float(self.sample_rate),
            "t0": float(self.t0),
        }
        if self.sensitivity is not None:
            out["sensitivity"] = float(self.sensitivity)
        for key in TEXT_FIELDS:
            value = getattr(self, key)
            if value is not None:
                out[key] = value
        for key in ("node", "direction"):
            value = getattr(self, key)
            if value is not None:
                out[key] = np.int64(value)
        return out


def parameter_value(name: str, value: Any) -> Any:
    """Check a point parameter and return it as stored: text, bool, int64, float64 or a 1-D array.

    Raises
    ------
    ValueError
        For reserved names, empty names, or values that are not text, numbers or bools.
    """
    if not isinstance(name, str) or not name or "/" in name:
        raise ValueError(f"parameter name {name!r} must be non-empty text without '/'")
    if name in RESERVED_POINT_NAMES:
        raise ValueError(f"parameter name {name!r} is reserved (set by the writer)")
    if isinstance(value, (bool, np.bool_)):
        return np.bool_(value)
    if isinstance(value, str):
        return value
    if isinstance(value, Integral):
        return np.int64(value)
    if isinstance(value, Real):
        return np.float64(value)
    if isinstance(value, (list, tuple, np.ndarray)):
        arr = np.asarray(value)
        if arr.ndim == 1 and arr.dtype.kind in "iuf":
            return arr.astype(np.float64 if arr.dtype.kind == "f" else np.int64)
    raise ValueError(f"parameter {name!r} = {value!r}: store text, numbers, bools or 1-D numeric lists only")


def python_value(value: Any) -> Any:
    """An attribute value as read by h5py turned into plain Python (str, bool, int, float, list)."""
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray):
        if value.ndim == 0:
            return python_value(value[()])
        return [python_value(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
