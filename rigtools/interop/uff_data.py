"""What the values of a UFF 58 record say, checked against its labels by the import
(:func:`rigtools.interop.uff.import_uff`): the kind of an FRF, the sample rate of a time record
whose increment the format wrote with 6 digits, a file cut inside a record, a coherence record's
frequency lines."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rigtools.interop.channels import si_units

FRF_DATA_RULE = "peaks of |H| near +-90 deg: not mobility; |H| away from the peaks rising with frequency: accelerance, falling: receptance"


def frf_kind_from_data(f: np.ndarray, h: np.ndarray) -> str | None:
    """What an FRF measures, read from the data, or None when they do not tell (real-valued data
    have no phase: they tell nothing).

    A lightly damped mode's receptance and accelerance are near +-90 deg at its peak, its mobility
    near 0/180 deg (the median over the largest peaks decides). Between receptance and accelerance,
    ``|H|`` away from the peaks (the lower quartile of each end third of the grid) rises with frequency
    for accelerance (x omega^2) and falls for receptance; a change under 10 dB decides nothing.
    """
    from scipy.signal import find_peaks

    keep = f > 0
    f, h = f[keep], h[keep]
    mag = np.abs(h)
    if f.size < 30 or not np.all(np.isfinite(mag)) or mag.max() == 0:
        return None
    if not np.any(h.imag):  # real values (a magnitude or real-part record): no phase to read
        return None
    peaks, props = find_peaks(mag, prominence=0.05 * mag.max())
    if peaks.size == 0:
        return None
    top = peaks[np.argsort(props["prominences"])[::-1][:8]]
    off_real = float(np.median(np.abs(np.sin(np.angle(h[top])))))
    if off_real < 0.5:
        return "mobility"
    if off_real < 0.8:
        return None
    third = f.size // 3
    low, high = np.percentile(mag[:third], 25), np.percentile(mag[-third:], 25)
    if low <= 0 or high <= 0:
        return None
    change_db = 20 * np.log10(high / low)
    if change_db > 10:
        return "accelerance"
    if change_db < -10:
        return "receptance"
    return None


def rate_of_increment(inc: float) -> float:
    """The sample rate of an abscissa increment. Dataset 58 writes the increment in its ASCII
    header with 6 significant digits (``9.76562E-04`` for 1024 Hz), in binary files (58b) too:
    the rate is the roundest number (whole Hz, then 0.1, 0.01, 0.001 Hz) whose increment rounds
    to the written one."""
    rate = 1.0 / inc
    for decimals in range(4):
        candidate = round(rate, decimals)
        if candidate > 0 and abs(1.0 / candidate - inc) <= 5e-6 * abs(inc):
            return float(candidate)
    return rate


def uff_date(created: str) -> str:
    """ISO time (``2024-05-01T12:00:00+00:00``) as UFF's ``01-May-24 12:00:00``; empty if unreadable."""
    from datetime import datetime

    try:
        return datetime.fromisoformat(str(created)).strftime("%d-%b-%y %H:%M:%S")
    except ValueError:
        return ""


class _ForceNamed:
    """A point view whose force channel is ``name`` (``--reference``): the other force-quantity
    channels are left out of it."""

    def __init__(self, point, name: str) -> None:
        self._point = point
        self.channels = {c: ch for c, ch in point.channels.items() if c == name or ch.quantity != "force"}

    def __getattr__(self, attr):
        return getattr(self._point, attr)


def _with_force(point, name: str):
    return _ForceNamed(point, name)


def cut_record(source: Path, whole: int) -> str | None:
    """A file whose last line is not a record's closing ``-1`` ends inside a record (a cut copy,
    an interrupted export); pyuff leaves that record out without a word: say so."""
    with source.open("rb") as f:
        f.seek(max(0, source.stat().st_size - 512))
        tail = f.read().rstrip()
    if not tail or tail.rsplit(b"\n", 1)[-1].strip() == b"-1":
        return None
    return f"{source}: the file ends inside a record after {whole} whole record(s) (a cut file?)" + (
        ": the partial record is left out" if whole else ""
    )


def coherence_text(coh: dict | None, grid: np.ndarray) -> str:
    """How an FRF's coherence record pairs with it: ``"with its coherence"`` only on the FRF's own
    frequency lines; a record on another grid is left out, saying so (never paired line by line)."""
    if coh is None:
        return "no coherence record"
    x = np.asarray(coh["x"], dtype=float)
    if x.size == grid.size and np.allclose(x, grid, rtol=1e-9, atol=0.0):
        return "with its coherence"
    span = f"{x.size} lines {x[0]:g}-{x[-1]:g} Hz" if x.size else "no lines"
    return f"its coherence record left out: on another frequency grid ({span})"


def code_against_label(s: dict, quantity_of_code: dict[int, str]) -> str | None:
    """Why a time record whose units label and data-type code name different quantities (``N``
    over code 12, acceleration) is not guessed: which one is wrong cannot be told. None when they
    agree or one of them says nothing."""
    label = str(s.get("ordinate_axis_units_lab", "")).strip()
    code = int(s.get("ordinate_spec_data_type", 0))
    by_code = quantity_of_code.get(code)
    si = si_units(label) if label else None
    if by_code is None or si is None or si.quantity == by_code:
        return None
    return f"its units label {label!r} says {si.quantity}, its data-type code {code} says {by_code}"
