"""TDMS import with npTDMS: an NI-DAQmx log (``configure_logging``) or a LabVIEW waveform log
becomes a recording in our format, so old measurements enter the same analysis.

Mapping:

* every TDMS group becomes one point (in file order); its channels become the point's channels;
* the sample rate is ``1 / wf_increment`` of the waveform properties (all channels of a group
  share it; ``sample_rate`` may be given when a log has no waveform timing);
* units come from ``unit_string`` (DAQmx writes it); they are converted to SI: ``g`` to m/s^2
  (x 9.80665), ``lbf`` to N, ``mV`` to V; ``Newtons``/``Volts`` are read as N/V. A channel without
  units, or with units this table does not know, is refused with one line naming it;
* channel names keep letters, digits, ``_ . -`` (``Dev1/ai0`` becomes ``Dev1_ai0``); ``rename``
  maps TDMS names onto the toolkit's vocabulary (``{"Dev1/ai0": "force"}``);
* DAQmx raw logs are scaled by npTDMS with the scaling stored in the file.

Data is copied in chunks (bounded memory, whatever the log's length).
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from rigtools.errors import UserError, one_line

G = 9.80665
LBF = 4.4482216152605
# unit_string (lower case) -> (SI units, quantity, factor to SI)
UNITS: dict[str, tuple[str, str, float]] = {
    "n": ("N", "force", 1.0),
    "newtons": ("N", "force", 1.0),
    "newton": ("N", "force", 1.0),
    "lbf": ("N", "force", LBF),
    "pounds": ("N", "force", LBF),
    "m/s^2": ("m/s^2", "acceleration", 1.0),
    "m/s2": ("m/s^2", "acceleration", 1.0),
    "m/s\u00b2": ("m/s^2", "acceleration", 1.0),
    "meterspersecondsquared": ("m/s^2", "acceleration", 1.0),
    "g": ("m/s^2", "acceleration", G),
    "gs": ("m/s^2", "acceleration", G),
    "m/s": ("m/s", "velocity", 1.0),
    "m": ("m", "displacement", 1.0),
    "mm": ("m", "displacement", 1e-3),
    "v": ("V", "voltage", 1.0),
    "volts": ("V", "voltage", 1.0),
    "mv": ("V", "voltage", 1e-3),
}
CHUNK = 1 << 20  # samples per channel copied at a time
_BAD_NAME_CHARS = re.compile(r"[^A-Za-z0-9_.\-]")


class TdmsImportError(UserError):
    """A TDMS file that cannot become a recording (one line)."""


def channel_name(tdms_name: str, rename: dict[str, str]) -> str:
    """The recording channel name of a TDMS channel."""
    if tdms_name in rename:
        return rename[tdms_name]
    name = _BAD_NAME_CHARS.sub("_", tdms_name.strip()) or "channel"
    return name if name[0] != "." else "_" + name[1:]


def _units(channel: Any, source: str) -> tuple[str, str, float]:
    text = str(channel.properties.get("unit_string", "")).strip()
    if not text:
        raise TdmsImportError(
            f"{source}: channel {channel.path} has no unit_string property; "
            "the toolkit needs units to store SI values"
        )
    key = text.lower().replace(" ", "")
    if key not in UNITS:
        raise TdmsImportError(
            f"{source}: channel {channel.path} has units {text!r}, not one of "
            f"{', '.join(sorted({u[0] for u in UNITS.values()}))} or their usual "
            "spellings (g, lbf, mV, Newtons, Volts)"
        )
    return UNITS[key]


def _rate(channel: Any, source: str, sample_rate: float | None) -> float:
    inc = channel.properties.get("wf_increment")
    if inc is None:
        if sample_rate is None:
            raise TdmsImportError(
                f"{source}: channel {channel.path} has no wf_increment (no "
                "waveform timing); give the sample rate (--sample-rate)"
            )
        return float(sample_rate)
    inc = float(inc)
    if not (math.isfinite(inc) and inc > 0):
        raise TdmsImportError(
            f"{source}: channel {channel.path} has wf_increment {inc!r}; "
            "it must be a positive number of seconds"
        )
    return 1.0 / inc


def import_tdms(
    source: str | Path,
    out: str | Path,
    *,
    rig: Any,
    overwrite: bool = False,
    rename: dict[str, str] | None = None,
    sample_rate: float | None = None,
) -> dict:
    """Convert a TDMS log into a recording (backend ``"tdms"``).

    Parameters
    ----------
    source
        The ``.tdms`` file.
    out
        The recording to write (``.h5``).
    rig
        The rig description stored in the recording (a ``RigConfig`` or its JSON text).
    overwrite
        Replace ``out`` if it exists.
    rename
        TDMS channel name -> recording channel name.
    sample_rate
        Hz, for logs without waveform timing (``wf_increment``).

    Returns
    -------
    dict
        ``{"points": [{"group", "channels", "samples", "sample_rate"}, ...]}``.

    Raises
    ------
    TdmsImportError
        One line: not a TDMS file, no channels, missing units or timing, mixed rates in a group.
    """
    from nptdms import TdmsFile

    from rigtools.recording import ChannelSpec, RecordingWriter

    source = Path(source)
    rename = dict(rename or {})
    if not source.is_file():
        raise TdmsImportError(f"{source}: no such file")
    try:
        tdms = TdmsFile.open(source)
    except Exception as exc:  # noqa: BLE001 - npTDMS raises ValueError, KeyError, struct.error, ...
        raise TdmsImportError(
            f"{source}: not a readable TDMS file ({type(exc).__name__}: {one_line(exc, 200)})"
        ) from None
    with tdms:
        groups = [g for g in tdms.groups() if g.channels()]
        if not groups:
            raise TdmsImportError(f"{source}: no channels with data in any group")
        plan = []
        for group in groups:
            specs, factors, lengths, names = [], [], [], set()
            rates = set()
            for ch in group.channels():
                units, quantity, factor = _units(ch, str(source))
                rate = _rate(ch, str(source), sample_rate)
                rates.add(round(rate, 9))
                name = channel_name(ch.name, rename)
                if name in names:
                    raise TdmsImportError(
                        f"{source}: group {group.name!r}: two channels map to the name {name!r}; rename one"
                    )
                names.add(name)
                try:
                    specs.append(
                        ChannelSpec(
                            name=name,
                            units=units,
                            quantity=quantity,
                            sample_rate=rate,
                            t0=float(ch.properties.get("wf_start_offset", 0.0)),
                            physical_channel=str(ch.properties.get("NI_ChannelName", ch.name)),
                        )
                    )
                except ValueError as exc:
                    raise TdmsImportError(f"{source}: {exc}") from None
                factors.append(factor)
                lengths.append(len(ch))
            if len(rates) != 1:
                raise TdmsImportError(
                    f"{source}: group {group.name!r} mixes sample rates "
                    f"{sorted(rates)} Hz; a point has one rate"
                )
            plan.append((group, specs, factors, min(lengths), len(set(lengths)) > 1))
        experiment = {
            "procedure": "import",
            "source_format": "tdms",
            "source": source.name,
            "properties": {k: str(v) for k, v in tdms.properties.items()},
        }
        summary = []
        with RecordingWriter(out, backend="tdms", rig=rig, experiment=experiment, overwrite=overwrite) as rec:
            for group, specs, factors, n, uneven in plan:
                params: dict[str, Any] = {"source_group": group.name}
                if uneven:
                    params["trimmed_to_shortest_channel"] = True
                point = rec.begin_point(params=params, channels=specs)
                scale = np.asarray(factors)[:, None]
                for start in range(0, n, CHUNK):
                    length = min(CHUNK, n - start)
                    block = np.vstack(
                        [np.asarray(ch.read_data(start, length), dtype=float) for ch in group.channels()]
                    )
                    point.append(block * scale)
                point.end()
                summary.append(
                    {
                        "group": group.name,
                        "channels": [s.name for s in specs],
                        "samples": int(n),
                        "sample_rate": specs[0].sample_rate,
                    }
                )
    return {"points": summary}


# ------------------------------------------------------------------------------ renames


def parse_rename(text: str) -> dict[str, str]:
    """``"a=b,c=d"`` as ``{"a": "b", "c": "d"}``."""
    out = {}
    for item in (t for t in text.split(",") if t.strip()):
        old, sep, new = item.partition("=")
        if not sep or not old.strip() or not new.strip():
            raise UserError(f"--rename = {text!r}: write OLD=NEW pairs separated by commas")
        out[old.strip()] = new.strip()
    return out


def check_renames(source: str, rename: dict[str, str]) -> None:
    """Refuse ``--rename`` entries naming no channel of ``source`` (a typo would otherwise import
    the channel under its old name without a word). A file npTDMS cannot read is left to the
    import, which says so."""
    if not rename:
        return
    try:
        from nptdms import TdmsFile

        meta = TdmsFile.read_metadata(source)
        names = {ch.name for group in meta.groups() for ch in group.channels()}
    except Exception:  # noqa: BLE001 -- not readable by npTDMS in any way: import_tdms gives the one-line reason
        return
    unknown = sorted(set(rename) - names)
    if unknown:
        raise UserError(
            f"--rename: no channel {', '.join(repr(u) for u in unknown)} in {source} "
            f"(channels: {', '.join(sorted(names)) or 'none'})"
        )
