"""Writing what an import read: points of foreign channels as a recording (``experiment.procedure``
``"import"``), and the summary every ``rig import`` prints (one line per channel)."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rigtools.errors import UserError
from rigtools.interop.channels import ForeignChannel, excitation, excitation_line
from rigtools.recording import ChannelSpec, RecordingError, RecordingWriter
from rigtools.recording.lock import LockBusy, WriterLock

CHUNK = 1 << 20  # samples per channel copied at a time


@dataclass
class ForeignPoint:
    """One point to write: channels of one sample rate and one length.

    ``read(start, n)`` returns the raw samples (file units) of ``channels``, one row each.
    """

    params: dict
    channels: list[ForeignChannel]
    samples: int
    sample_rate: float
    read: Callable[[int, int], np.ndarray]
    t0: list[float] = field(default_factory=list)
    physical: list[str] = field(default_factory=list)


def rows_reader(block: np.ndarray) -> Callable[[int, int], np.ndarray]:
    """``read(start, n)`` of samples held in memory, one row per channel."""

    def read(start: int, n: int) -> np.ndarray:
        return block[:, start : start + n]

    return read


def split_by_timing(items: Sequence[tuple[Any, int, float]]) -> list[list[int]]:
    """Indices of ``(item, samples, rate)`` grouped by equal length and rate, in file order: a
    point holds channels of one length and rate, so channels of unequal length are kept whole in
    points of their own instead of being cut to the shortest.

    Rates are one rate when their clocks part by less than half a sample over the record
    (``n * |r1 - r2| / r1 < 0.5``): one clock written as rounded increments (``1.95312E-5``) in
    each channel, not two clocks. The point then takes the first channel's rate.
    """
    groups: list[tuple[int, float, list[int]]] = []
    for i, (_, n, rate) in enumerate(items):
        for length, first, members in groups:
            if length == int(n) and abs(float(rate) - first) * length < 0.5 * first:
                members.append(i)
                break
        else:
            groups.append((int(n), float(rate), [i]))
    return [members for _, _, members in groups]


def write_imported(
    out: str | Path,
    *,
    backend: str,
    rig: Any,
    experiment: dict,
    points: Sequence[ForeignPoint],
    every: Sequence[ForeignChannel],
    reference: str | None = None,
    overwrite: bool = False,
    notes: Sequence[str] = (),
) -> dict:
    """Write ``points`` as a recording and say what happened to every channel (``every``: all
    channels of the file, kept or skipped, in file order).

    Returns
    -------
    dict
        ``{"channels": [...], "points": [...], "lines": [...]}``: one entry per channel of the file
        (kept or skipped, :meth:`ForeignChannel.to_dict`), one per point written, and the lines
        the command prints (one per channel, one per point).
    """
    if not points:
        lines = [c.line() for c in every]
        raise UserError(
            "no channel to import: " + "; ".join(lines) if lines else "no channel with data in the file"
        )
    specs_of = []
    point_lines = []
    for index, p in enumerate(points):
        name = excitation(p.channels, reference)
        if name is not None:
            p.params["reference_channel"] = name
        point_lines.append(excitation_line(index, name, p.channels, reference))
        specs = []
        for i, ch in enumerate(p.channels):
            assert ch.si is not None
            ch.point, ch.samples, ch.sample_rate = index, p.samples, p.sample_rate
            place = ch.extra.get("place") or {}  # node, direction, entity, description (UFF)
            try:
                specs.append(
                    ChannelSpec(
                        name=ch.name,
                        units=ch.si.units,
                        quantity=ch.si.quantity,
                        sample_rate=p.sample_rate,
                        t0=p.t0[i] if p.t0 else 0.0,
                        physical_channel=(p.physical[i] if p.physical else None) or None,
                        **{k: place.get(k) for k in ("node", "direction", "entity", "description")},
                    )
                )
            except ValueError as exc:
                raise UserError(f"{ch.source}: {exc}") from None
        specs_of.append(specs)
    # over an existing file (--overwrite) the import is written beside it and takes its name only
    # when whole: an import stopped half-way (Ctrl-C, a full disk) leaves the old file as it was
    target = Path(out)
    replacing = overwrite and target.is_file()
    path = target.with_name(f".{target.name}.importing") if replacing else target
    held = _hold(target) if replacing else None  # no other run writes the file it replaces
    try:
        with RecordingWriter(
            path, backend=backend, rig=rig, experiment=experiment, overwrite=overwrite
        ) as rec:
            for p, specs in zip(points, specs_of, strict=True):
                writer = rec.begin_point(params=p.params, channels=specs)
                factor = np.array([c.si.factor for c in p.channels if c.si])[:, None]
                offset = np.array([c.si.offset for c in p.channels if c.si])[:, None]
                for start in range(0, p.samples, CHUNK):
                    block = np.asarray(p.read(start, min(CHUNK, p.samples - start)), dtype=float)
                    writer.append(block * factor + offset)
                writer.end()
        if replacing:
            os.replace(path, target)
    except BaseException:
        if replacing:
            path.unlink(missing_ok=True)
        raise
    finally:
        if held is not None:
            held.release()
    channels = list(every)
    return {
        "channels": [c.to_dict() for c in channels],
        "points": [
            {
                "point": i,
                "channels": [c.name for c in p.channels],
                "samples": p.samples,
                "sample_rate": p.sample_rate,
                "reference_channel": p.params.get("reference_channel"),
                **{k: v for k, v in p.params.items() if k.startswith("source")},
            }
            for i, p in enumerate(points)
        ],
        "lines": [c.line() for c in channels] + list(notes) + point_lines,
    }


def _hold(target: Path) -> WriterLock:
    """The writer lock of ``target`` taken (the one every writer takes), or the refusal every
    writer gives when another run writes it."""
    lock = WriterLock(target)
    try:
        lock.acquire()
    except LockBusy as busy:
        raise RecordingError(
            f"{target} is being written by another run ({busy.holder}); two runs cannot write one file"
        ) from None
    except OSError as exc:
        raise RecordingError(
            f"cannot replace {target}: cannot create its lock file ({exc.strerror})"
        ) from None
    return lock
