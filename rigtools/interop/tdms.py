"""TDMS import with npTDMS: an NI-DAQmx log (``configure_logging``) or a LabVIEW waveform log
becomes a recording in our format, so old measurements enter the same analysis.

Mapping (units, names and the excitation as every import treats them, :mod:`rigtools.interop.channels`):

* every TDMS group (or the ones ``groups`` selects) becomes a point, in file order; its channels
  (or the ones ``channels`` selects) become the point's channels. Channels of one group with
  unequal lengths or sample rates are kept whole in a point each per length and rate (a point's
  channels share both), never cut to the shortest;
* the sample rate is ``1 / wf_increment`` of the waveform properties (``sample_rate`` for logs
  without waveform timing);
* units come from ``unit_string`` (DAQmx writes it) or ``units``, converted to SI; a channel
  without units or timing, with unknown units or non-numeric data is skipped with one line;
* DAQmx raw logs are scaled by npTDMS with the scaling stored in the file.

Data is copied in chunks (bounded memory, whatever the log's length).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from rigtools.errors import UserError, in_script_words
from rigtools.interop.channels import LBF, ForeignChannel, G, check_known, check_names, resolve
from rigtools.interop.checks import non_finite_reason, number, parsed, parser_notes, source_file
from rigtools.interop.imported import ForeignPoint, split_by_timing, write_imported

__all__ = ["LBF", "G", "TdmsImportError", "import_tdms"]

_NUMERIC = "biuf"  # numpy kinds imported (bool, integers, floats)


class TdmsImportError(UserError):
    """A TDMS file that cannot become a recording (one line)."""


def _rate(channel: Any, sample_rate: float | None) -> tuple[float | None, str]:
    """``(rate, "")`` or ``(None, why not)``."""
    inc = channel.properties.get("wf_increment")
    if inc is None:
        if sample_rate is None:
            return None, "no wf_increment (no waveform timing); give the sample rate (--sample-rate)"
        return float(sample_rate), ""
    seconds = number(inc)
    if not (math.isfinite(seconds) and seconds > 0):
        return None, f"wf_increment {inc!r} is not a positive number of seconds"
    inc = seconds
    return 1.0 / inc, ""


def _open(source: Path) -> Any:
    from nptdms import TdmsFile

    source = source_file(source, TdmsImportError)
    return parsed(source, "TDMS", lambda: TdmsFile.open(source), TdmsImportError)


def _selected(tdms: Any, groups: list[str], channels: list[str]) -> list[tuple[Any, list[Any]]]:
    """``(group, channels)`` chosen by ``--group``/``--channel`` (names or ``group/channel``)."""
    all_groups = [g for g in tdms.groups() if g.channels()]
    check_known("--group", groups, [g.name for g in all_groups], "group")
    names = {c.name for g in all_groups for c in g.channels()}
    check_known(
        "--channel", channels, names | {f"{g.name}/{c.name}" for g in all_groups for c in g.channels()}
    )
    out = []
    for g in all_groups:
        if groups and g.name not in groups:
            continue
        chosen = [
            c for c in g.channels() if not channels or c.name in channels or f"{g.name}/{c.name}" in channels
        ]
        if chosen:
            out.append((g, chosen))
    return out


@in_script_words
def import_tdms(
    source: str | Path,
    out: str | Path,
    *,
    rig: Any,
    overwrite: bool = False,
    mapping: dict[str, str] | None = None,
    units: dict[str, str] | None = None,
    groups: list[str] | None = None,
    channels: list[str] | None = None,
    reference: str | None = None,
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
    mapping
        TDMS channel name (or ``group/channel``) -> recording channel name (``--map``).
    units
        TDMS channel name (or ``group/channel``) -> unit (``--units``), for channels without
        ``unit_string`` or with a wrong one.
    groups, channels
        Only these groups / channels (names or ``group/channel``); default all.
    reference
        The excitation channel (default: the one channel of quantity force).
    sample_rate
        Hz, for logs without waveform timing (``wf_increment``).

    Returns
    -------
    dict
        :func:`rigtools.interop.imported.write_imported`'s summary: one entry (and one line) per
        channel, kept or skipped, and one per point.

    Raises
    ------
    TdmsImportError
        One line: not a TDMS file, no channel left to import, an option naming no channel.
    """
    source = Path(source)
    notes: list[str] = []
    with parser_notes(notes, "npTDMS", ("nptdms",)):
        return _import(
            source, out, rig, overwrite, mapping, units, groups, channels, reference, sample_rate, notes
        )


def _import(
    source: Path,
    out: str | Path,
    rig: Any,
    overwrite: bool,
    mapping: dict[str, str] | None,
    units: dict[str, str] | None,
    groups: list[str] | None,
    channels: list[str] | None,
    reference: str | None,
    sample_rate: float | None,
    notes: list[str],
) -> dict:
    """:func:`import_tdms`'s work, its parser's warnings collected into ``notes``."""
    mapping, units = dict(mapping or {}), dict(units or {})
    with _open(source) as tdms:
        chosen = _selected(tdms, list(groups or []), list(channels or []))
        if not chosen:
            raise TdmsImportError(f"{source}: no channels with data in any group")
        names = {c.name for _, chans in chosen for c in chans}
        paths = {f"{g.name}/{c.name}" for g, chans in chosen for c in chans}
        check_known("--map", mapping, names | paths)
        check_known("--units", units, names | paths)
        if reference is not None:
            check_known("--reference", [reference], names | paths | {mapping.get(n, n) for n in names})
        points: list[ForeignPoint] = []
        every: list[ForeignChannel] = []
        for group, chans in chosen:
            kept: list[tuple[ForeignChannel, int, float]] = []
            objects = []
            for ch in chans:
                path = f"{group.name}/{ch.name}"
                fc = resolve(
                    path,
                    ch.name,
                    str(ch.properties.get("unit_string") or ch.properties.get("units") or ""),
                    mapping=mapping,
                    units=units,
                    path=path,
                )
                fc.extra["file_name"] = ch.name
                fc.samples = len(ch)
                rate, why = _rate(ch, sample_rate)
                if fc.kept and rate is None:
                    fc.si, fc.name, fc.reason = None, "", why
                elif fc.kept and np.dtype(ch.dtype).kind not in _NUMERIC:
                    fc.si, fc.name, fc.reason = None, "", f"its data are {np.dtype(ch.dtype)}, not numbers"
                elif fc.kept and len(ch) == 0:
                    fc.si, fc.name, fc.reason = None, "", "no samples"
                elif fc.kept and (bad := non_finite_reason(_reader([ch]), len(ch))) is not None:
                    fc.si, fc.name, fc.reason = None, "", bad
                every.append(fc)
                if not fc.kept:
                    continue
                fc.sample_rate = float(rate or 0.0)
                kept.append((fc, len(ch), fc.sample_rate))
                objects.append(ch)
            parts = split_by_timing(kept)
            if len(parts) > 1:
                notes.append(
                    f"group {group.name!r}: channels of {len(parts)} lengths or sample rates, each kept "
                    f"whole in points {len(points)}-{len(points) + len(parts) - 1} (none cut)"
                )
            for part in parts:
                fcs = [kept[i][0] for i in part]
                objs = [objects[i] for i in part]
                check_names(fcs, f"{source}: group {group.name!r}")
                points.append(
                    ForeignPoint(
                        params={"source_group": group.name},
                        channels=fcs,
                        samples=kept[part[0]][1],
                        sample_rate=kept[part[0]][2],
                        read=_reader(objs),
                        t0=[_offset(o) for o in objs],
                        physical=[str(o.properties.get("NI_ChannelName", o.name)) for o in objs],
                    )
                )
        experiment = {
            "procedure": "import",
            "source_format": "tdms",
            "source": source.name,
            "properties": {k: str(v) for k, v in tdms.properties.items()},
        }
        return write_imported(
            out,
            backend="tdms",
            rig=rig,
            experiment=experiment,
            points=points,
            every=every,
            reference=reference,
            overwrite=overwrite,
            notes=notes,
        )


def _offset(channel: Any) -> float:
    """The channel's ``wf_start_offset`` in seconds (0 where absent or not a number)."""
    offset = number(channel.properties.get("wf_start_offset", 0.0))
    return offset if math.isfinite(offset) else 0.0


def _reader(objects: list[Any]):
    def read(start: int, n: int) -> np.ndarray:
        return np.vstack([np.asarray(o.read_data(start, n), dtype=float) for o in objects])

    return read
