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
from typing import Any, Unpack

import numpy as np

from rigtools.errors import UserError, in_script_words
from rigtools.interop.channels import LBF, ForeignChannel, G, check_known, check_names, resolve
from rigtools.interop.checks import (
    ImportKeywords,
    ImportRequest,
    import_request,
    importer,
    non_finite_reason,
    number,
    parsed,
    parser_notes,
    source_file,
)
from rigtools.interop.imported import ForeignPoint, split_by_timing

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
@importer
def import_tdms(
    source: str | Path,
    out: str | Path,
    *,
    groups: list[str] | None = None,
    sample_rate: float | None = None,
    **options: Unpack[ImportKeywords],
) -> dict:
    """Convert a TDMS log into a recording (backend ``"tdms"``).

    Parameters
    ----------
    source
        The ``.tdms`` file.
    out
        The recording to write (``.h5``).
    groups
        Only these groups; default all.
    sample_rate
        Hz, for logs without waveform timing (``wf_increment``).
    %(shared)s

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
    request = import_request(source, options)
    with parser_notes(request.notes, "npTDMS", ("nptdms",)):
        return _import(request, out, list(groups or []), sample_rate)


def _import(request: ImportRequest, out: str | Path, groups: list[str], sample_rate: float | None) -> dict:
    """:func:`import_tdms`'s work, its parser's warnings collected into ``request.notes``."""
    source, mapping, units, reference, notes = (
        request.source,
        request.mapping,
        request.units,
        request.reference,
        request.notes,
    )
    with _open(source) as tdms:
        chosen = _selected(tdms, groups, request.channels)
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
        return request.write(out, "tdms", experiment, points, every)


def _offset(channel: Any) -> float:
    """The channel's ``wf_start_offset`` in seconds (0 where absent or not a number)."""
    offset = number(channel.properties.get("wf_start_offset", 0.0))
    return offset if math.isfinite(offset) else 0.0


def _reader(objects: list[Any]):
    def read(start: int, n: int) -> np.ndarray:
        return np.vstack([np.asarray(o.read_data(start, n), dtype=float) for o in objects])

    return read
