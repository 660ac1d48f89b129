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
from typing import Any, Unpack

import numpy as np

from rigtools.errors import UserError, in_script_words, one_line
from rigtools.interop.channels import ForeignChannel, check_known, check_names, resolve
from rigtools.interop.checks import ImportKeywords, import_request, importer, non_finite_reason, source_file
from rigtools.interop.imported import ForeignPoint, rows_reader, split_by_timing

_HEADINGS = ("Samples", "Delta_X", "X0", "Y_Unit_Label", "X_Dimension")


class LvmImportError(UserError):
    """A LabVIEW measurement file that cannot become a recording (one line)."""


def _decimal_separator_held(text: str) -> tuple[str, str | None]:
    """The text with its ``Decimal_Separator`` held against the numbers of its first data row.

    A tab-separated file whose header says ``.`` while its numbers carry a decimal comma (and no
    point) is read with ``,``; the returned note says so. Anything else is returned as is.
    """
    head, sep, rest = text.partition("***End_of_Header***")
    declared = dict(line.split("\t", 1)[:2] for line in head.splitlines() if "\t" in line)
    if declared.get("Separator", "").strip() != "Tab" or declared.get("Decimal_Separator", "").strip() != ".":
        return text, None
    rows = rest.split("***End_of_Header***")[-1].splitlines()
    data = [r for r in rows[2:] if r.strip()][:1]  # after the blank line and the column heading
    fields = [f.strip() for f in (data[0].split("\t") if data else []) if f.strip()]
    if not fields or not all("," in f and "." not in f for f in fields):
        return text, None
    fixed = head.replace("Decimal_Separator\t.", "Decimal_Separator\t,", 1) + sep + rest
    return fixed, "the header says Decimal_Separator '.', the numbers use ',' (e.g. " + fields[
        0
    ] + "): read with ','"


def read_lvm(source: str | Path, notes: list[str] | None = None) -> dict:
    """The file as ``lvm_read`` reads it (gzip recognised by its first bytes).

    A wrong ``Decimal_Separator`` is corrected from the data (:func:`_decimal_separator_held`)
    and said in ``notes`` when a list is given.
    """
    import lvm_read

    source = source_file(source, LvmImportError)
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
    text = text.removeprefix("\ufeff")  # a byte-order mark some editors write
    if not text.startswith("LabVIEW Measurement"):
        raise LvmImportError(f"{source}: not a LabVIEW measurement file (no 'LabVIEW Measurement' heading)")
    text, note = _decimal_separator_held(text)
    if note is not None and notes is not None:
        notes.append(f"{source.name}: {note}")
    try:
        return lvm_read.read_str(text)
    except KeyError as exc:
        if exc.args == ("data",):  # lvm_read found a segment header and no data rows under it
            raise LvmImportError(
                f"{source}: a segment header with no data rows under it (a file cut after its header, "
                "or a column heading missing)"
            ) from None
        raise LvmImportError(f"{source}: cannot read the LabVIEW data (no {one_line(exc, 200)})") from None
    except (ValueError, SyntaxError, IndexError) as exc:
        raise LvmImportError(f"{source}: cannot read the LabVIEW data ({one_line(exc, 200)})") from None


def _numbers(values: Any, count: int) -> list[float]:
    out = []
    for v in list(values or [])[:count]:
        try:
            out.append(float(v))
        except (TypeError, ValueError):
            out.append(math.nan)
    return out + [math.nan] * (count - len(out))


def _rows(data: Any) -> np.ndarray:
    """The segment's data as rows x columns (one column read as a 1-D array; none as 0 x 0)."""
    arr = np.asarray(data, dtype=float)
    if arr.ndim == 1:
        arr = arr.reshape(arr.size, 1) if arr.size else arr.reshape(0, 0)
    return arr


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
        dimensions = [str(d).strip() for d in list(heads["X_Dimension"] or [])[:count]]
        # each channel's X column: the nearest X_Value column before it (X_Columns One or Multi)
        x_columns = [max((i for i in range(j) if names[i] == "X_Value"), default=None) for j in columns]
        out.append(
            {
                "names": [names[j] for j in columns],
                "columns": columns,
                "samples": _numbers(heads["Samples"], count),
                "delta_x": _numbers(heads["Delta_X"], count),
                "x0": _numbers(heads["X0"], count),
                "units": units + [""] * (count - len(units)),
                "x_dimension": dimensions + [""] * (count - len(dimensions)),
                "x_columns": x_columns,
                "data": _rows(seg["data"]),
            }
        )
    return out


@in_script_words
@importer
def import_lvm(source: str | Path, out: str | Path, **options: Unpack[ImportKeywords]) -> dict:
    """Convert a LabVIEW measurement file into a recording (backend ``"lvm"``).

    Parameters
    ----------
    source
        The ``.lvm`` (or ``.lvm.gz``) file.
    out
        The recording to write (``.h5``).
    %(shared)s

    Returns
    -------
    dict
        :func:`rigtools.interop.imported.write_imported`'s summary (one entry and one line per
        channel of every segment).
    """
    request = import_request(source, options)
    source, mapping, units, chosen = request.source, request.mapping, request.units, request.channels
    reference, notes = request.reference, request.notes
    lvm = read_lvm(source, notes)
    segs = segments(lvm)
    if not segs:
        raise LvmImportError(f"{source}: no data segment")
    for number, seg in enumerate(segs, start=1):
        if seg["data"].size == 0:
            raise LvmImportError(
                f"{source}: segment {number} has no data rows after its column heading (a cut file?)"
            )
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
            n, reason = _samples_held(seg, k, number, name, notes)
            dx = seg["delta_x"][k]
            fc.samples = max(n, 0)
            if fc.kept and reason is None and not (math.isfinite(dx) and dx > 0):
                reason = f"Delta_X {dx!r} is not a positive sample interval"
            if fc.kept and reason is None:
                reason = _x_axis_reason(seg, k, dx, n)
            if fc.kept and reason is None:
                column = seg["data"][: fc.samples, seg["columns"][k]]
                reason = non_finite_reason(rows_reader(column[None, :]), column.size)
            if fc.kept and reason is not None:
                fc.si, fc.name, fc.reason = None, "", reason
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
    return request.write(out, "lvm", experiment, points, every)


def _x_axis_reason(seg: dict, k: int, dx: float, n: int) -> str | None:
    """Why channel ``k``'s X axis is not its samples' time: an ``X_Dimension`` other than time
    (a spectrum's frequency lines), or an X column whose span contradicts ``Delta_X`` (beyond
    half a sample and 0.1 %, more than the X column's written digits explain)."""
    dimension = seg["x_dimension"][k]
    if dimension and dimension.lower() != "time":
        return (
            f"X_Dimension {dimension!r}: its rows are not samples in time (a spectrum?); "
            "rig import lvm reads time records"
        )
    column = seg["x_columns"][k]
    data = seg["data"]
    if column is None or column >= data.shape[1] or n < 2:
        return None
    x = data[:n, column]
    if not (math.isfinite(x[0]) and math.isfinite(x[n - 1])):
        return None
    span, expected = float(x[n - 1] - x[0]), dx * (n - 1)
    if abs(span - expected) <= max(0.5 * dx, 1e-3 * expected):
        return None
    return (
        f"its X column steps by {span / (n - 1):.6g} s on average, the header's Delta_X says "
        f"{dx:.6g} s: correct whichever is wrong (the sample rate depends on it)"
    )


def _samples_held(seg: dict, k: int, number: int, name: str, notes: list[str]) -> tuple[int, str | None]:
    """Channel ``k``'s sample count held against its column: ``(count, reason it is skipped)``.

    A header ``Samples`` over more rows than the column holds imports the rows there are and says
    so in ``notes``; a count that is not a positive whole number, or a column the data rows lack,
    skips the channel with the reason.
    """
    data = seg["data"]
    column_index = seg["columns"][k]
    if column_index >= data.shape[1]:
        return 0, (
            f"its column ({column_index + 1}) is missing from the data rows ({data.shape[1]} column(s): "
            "does the header's X_Columns match the data?)"
        )
    column = data[:, column_index]
    declared = seg["samples"][k]
    if not math.isfinite(declared):
        return int(np.sum(np.isfinite(column))), None
    if declared < 1 or declared != int(declared):
        return 0, f"Samples {declared:g} is not a positive whole count"
    if declared < column.size and np.isfinite(column[int(declared) :]).any():
        notes.append(
            f"segment {number}/{name}: the header declares {declared:g} samples, its column holds "
            f"{int(np.isfinite(column).sum())} values: imported {declared:g} (the rest read as padding)"
        )
    if declared > column.size:
        notes.append(
            f"segment {number}/{name}: the header declares {declared:g} samples, the data hold "
            f"{column.size}: imported {column.size} (a cut file?)"
        )
        return column.size, None
    return int(declared), None
