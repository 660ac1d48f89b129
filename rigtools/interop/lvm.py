"""LabVIEW measurement files (``.lvm``, also gzip-compressed ``.lvm.gz``) as recordings, read with
ladisk's ``lvm_read``.

Mapping (units, names and the excitation as every import treats them, :mod:`rigtools.interop.channels`):

* every data segment becomes a point (channels of one segment with unequal ``Samples`` or
  ``Delta_X`` are kept whole in a point each per length and rate);
* a channel's samples are the first ``Samples`` rows of its column (the rest of a ragged segment
  is padding); its rate is ``1 / Delta_X``, its ``t0`` its ``X0`` less the segment's earliest
  (an absolute ``X0``, LabVIEW's seconds since 1904, is kept as the point parameter
  ``source_x0``);
* units come from ``Y_Unit_Label`` (or ``--units``); decimal commas, tab or comma separators and
  X columns (``No``, ``One``, ``Multi``) are read as the header states; segments without their
  own heading take the previous segment's.
"""

from __future__ import annotations

import gzip
import math
from pathlib import Path
from typing import Any

import numpy as np

from rigtools.errors import UserError, one_line
from rigtools.interop.channels import ForeignChannel, check_known, check_names, resolve
from rigtools.interop.imported import ForeignPoint, rows_reader, split_by_timing, write_imported

_HEADINGS = ("Samples", "Delta_X", "X0", "Y_Unit_Label")


class LvmImportError(UserError):
    """A LabVIEW measurement file that cannot become a recording (one line)."""


def read_lvm(source: str | Path) -> dict:
    """The file as ``lvm_read`` reads it (gzip recognised by its first bytes)."""
    import lvm_read

    source = Path(source)
    if not source.is_file():
        raise LvmImportError(f"{source}: no such file")
    raw = source.read_bytes()
    if raw[:2] == b"\x1f\x8b":
        try:
            raw = gzip.decompress(raw)
        except (OSError, EOFError) as exc:
            raise LvmImportError(f"{source}: a damaged gzip file ({exc})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("cp1252", errors="replace")  # LabVIEW on Windows writes its code page
    if not text.startswith("LabVIEW Measurement"):
        raise LvmImportError(f"{source}: not a LabVIEW measurement file (no 'LabVIEW Measurement' heading)")
    try:
        return lvm_read.read_str(text)
    except (ValueError, SyntaxError, KeyError, IndexError) as exc:
        raise LvmImportError(f"{source}: cannot read the LabVIEW data ({one_line(exc, 200)})") from None


def _numbers(values: Any, count: int) -> list[float]:
    out = []
    for v in list(values or [])[:count]:
        try:
            out.append(float(v))
        except (TypeError, ValueError):
            out.append(math.nan)
    return out + [math.nan] * (count - len(out))


def segments(lvm: dict) -> list[dict]:
    """Per segment: ``names``, ``columns`` (data column of each), ``samples``, ``delta_x``,
    ``x0``, ``units`` (one entry per channel) and ``data``."""
    out: list[dict] = []
    previous: dict = {}
    for s in range(int(lvm.get("Segments", 0))):
        seg = lvm[s]
        if "data" not in seg:
            continue
        names = list(seg.get("Channel names", []))
        columns = [j for j, n in enumerate(names) if n not in ("X_Value", "Comment", "")]
        count = len(columns)
        heads = {k: seg.get(k, previous.get(k)) for k in _HEADINGS}
        previous = {k: v for k, v in heads.items() if v is not None}
        units = list(heads["Y_Unit_Label"] or [])[:count]
        out.append(
            {
                "names": [names[j] for j in columns],
                "columns": columns,
                "samples": _numbers(heads["Samples"], count),
                "delta_x": _numbers(heads["Delta_X"], count),
                "x0": _numbers(heads["X0"], count),
                "units": units + [""] * (count - len(units)),
                "data": np.asarray(seg["data"], dtype=float),
            }
        )
    return out


def import_lvm(
    source: str | Path,
    out: str | Path,
    *,
    rig: Any,
    overwrite: bool = False,
    mapping: dict[str, str] | None = None,
    units: dict[str, str] | None = None,
    channels: list[str] | None = None,
    reference: str | None = None,
) -> dict:
    """Convert a LabVIEW measurement file into a recording (backend ``"lvm"``).

    Parameters are those of :func:`rigtools.interop.tdms.import_tdms` (``channels`` selects by
    the file's channel names; ``--units`` and ``--map`` name them too).

    Returns
    -------
    dict
        :func:`rigtools.interop.imported.write_imported`'s summary (one entry and one line per
        channel of every segment).
    """
    source = Path(source)
    mapping, units, chosen = dict(mapping or {}), dict(units or {}), list(channels or [])
    lvm = read_lvm(source)
    segs = segments(lvm)
    if not segs:
        raise LvmImportError(f"{source}: no data segment")
    names = {n for s in segs for n in s["names"]}
    for option, given in (("--channel", chosen), ("--map", mapping), ("--units", units)):
        check_known(option, given, names)
    if reference is not None:
        check_known("--reference", [reference], names | {mapping.get(n, n) for n in names})
    points: list[ForeignPoint] = []
    every: list[ForeignChannel] = []
    for number, seg in enumerate(segs, start=1):
        kept: list[tuple[ForeignChannel, int, float]] = []
        cols: list[tuple[int, float]] = []
        for k, name in enumerate(seg["names"]):
            if chosen and name not in chosen:
                continue
            fc = resolve(f"segment {number}/{name}", name, seg["units"][k], mapping=mapping, units=units)
            fc.extra["file_name"] = name
            every.append(fc)
            column = seg["data"][:, seg["columns"][k]]
            n = (
                int(seg["samples"][k])
                if math.isfinite(seg["samples"][k])
                else int(np.sum(np.isfinite(column)))
            )
            n = min(n, column.size)
            dx = seg["delta_x"][k]
            fc.samples = n
            if fc.kept and not (math.isfinite(dx) and dx > 0):
                fc.si, fc.name, fc.reason = None, "", f"Delta_X {dx!r} is not a positive sample interval"
            elif fc.kept and (n == 0 or not np.all(np.isfinite(column[:n]))):
                fc.si, fc.name, fc.reason = (
                    None,
                    "",
                    "non-numeric or missing values in its first Samples rows",
                )
            if not fc.kept:
                continue
            fc.sample_rate = 1.0 / dx
            kept.append((fc, n, fc.sample_rate))
            cols.append((seg["columns"][k], seg["x0"][k]))
        x0s = [x for _, x in cols if math.isfinite(x)]
        first = min(x0s) if x0s else 0.0
        for part in split_by_timing(kept):
            fcs = [kept[i][0] for i in part]
            check_names(fcs, f"{source}: segment {number}")
            n = kept[part[0]][1]
            block = seg["data"][:n, [cols[i][0] for i in part]].T
            params: dict[str, Any] = {"source_segment": number}
            if first:
                params["source_x0"] = first
            points.append(
                ForeignPoint(
                    params=params,
                    channels=fcs,
                    samples=n,
                    sample_rate=kept[part[0]][2],
                    read=rows_reader(block),
                    t0=[(cols[i][1] - first) if math.isfinite(cols[i][1]) else 0.0 for i in part],
                )
            )
    experiment = {
        "procedure": "import",
        "source_format": "lvm",
        "source": source.name,
        "properties": {k: str(v) for k, v in lvm.items() if isinstance(k, str) and k != "Segments"},
    }
    return write_imported(
        out,
        backend="lvm",
        rig=rig,
        experiment=experiment,
        points=points,
        every=every,
        reference=reference,
        overwrite=overwrite,
    )
