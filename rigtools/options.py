"""Command-line option helpers shared by every ``rig`` sub-command: quantities with units, gaps,
durations, counts, seeds and output paths (the memory check: :mod:`rigtools.memory`). Each refuses bad input with one
:class:`~rigtools.errors.UserError` line naming the option and the value (exit 2).

Light on purpose (stdlib, rigtools.units, .derived_files and .write_targets only; no scipy, h5py,
numba, pydantic): command modules import it at the top. The unit rules (a plain number is SI, case-sensitive prefixes, Vpp)
are those of :mod:`rigtools.units`, the same as in a rig file.
"""

from __future__ import annotations

import argparse
import math
import os
import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from rigtools.derived_files import is_derived_plot
from rigtools.errors import UserError
from rigtools.errors import option as advised_option
from rigtools.units import MAX_GAP, parse_quantity, voltage_amplitude
from rigtools.write_targets import name_fits, same_file, writable_target


def quantity(text: str | float, dimension: str, option: str) -> float:
    """Parse a CLI quantity (``"0.5 mm"``, ``"15 N"``; a plain number is SI) or raise a one-line
    :class:`UserError` naming the option. Non-finite values are refused."""
    try:
        return parse_quantity(text, dimension)
    except ValueError as exc:
        raise UserError(f"{option} = {text!r}: {exc}") from None


def ratio(text: str) -> float:
    """An argparse type for a ratio: a plain number (``0.01``) or a percentage (``"1 %"``,
    ``"1%"``: 0.01); else argparse's one line naming the option.

    Examples
    --------
    >>> ratio("1 %"), ratio("0.02")
    (0.01, 0.02)
    """
    number = text.strip().removesuffix("%")
    scale = 0.01 if number != text.strip() else 1.0
    try:
        value = float(number) * scale
    except ValueError:
        raise argparse.ArgumentTypeError(f"cannot read {text!r} as a ratio, e.g. 0.01 or '1 %'") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite ratio")
    return value


def switch(value: object, name: str) -> bool:
    """A yes/no argument of the front door: ``True``/``False`` (numpy's too), else a one-line
    :class:`UserError` naming ``name`` (a string such as ``'no'`` is truthy, so it is refused
    rather than taken as True).

    Examples
    --------
    >>> switch(False, "overwrite")
    False
    >>> switch("no", "overwrite")
    Traceback (most recent call last):
    rigtools.errors.UserError: overwrite = 'no': give True or False
    """
    if isinstance(value, bool) or type(value).__name__ == "bool_":
        return bool(value)
    raise UserError(f"{name} = {value!r}: give True or False")


def positive_finite(
    text: str | float,
    dimension: str,
    option: str,
    *,
    allow_zero: bool = False,
    maximum: float | None = None,
    unit: str = "",
) -> float:
    """A quantity that must be > 0 (``>= 0`` with ``allow_zero``), finite and at most ``maximum``.

    Parameters
    ----------
    text
        The option's text, e.g. ``"2 s"``.
    dimension
        As for :func:`rigtools.units.parse_quantity`.
    option
        The option's name for the message, e.g. ``"--duration"``.
    allow_zero
        Accept 0.
    maximum
        Largest value accepted (SI), or ``None``.
    unit
        SI unit shown in the message (``"s"``, ``"N"``).

    Returns
    -------
    float
        The value in SI units.
    """
    value = quantity(text, dimension, option)
    low_ok = value >= 0 if allow_zero else value > 0
    if not low_ok:
        raise UserError(f"{option} = {text!r}: must be {'>= 0' if allow_zero else '> 0'}")
    if maximum is not None and value > maximum:
        raise UserError(f"{option} = {text!r}: must be at most {maximum:g} {unit}".rstrip())
    return value


def duration(
    text: str | float, option: str = "--duration", *, maximum: float | None = None, allow_zero: bool = False
) -> float:
    """A time in seconds (``"2 s"``, ``"500 ms"``, ``"1 min"``; a plain number is seconds), > 0
    (or >= 0 with ``allow_zero``) and at most ``maximum`` s."""
    return positive_finite(text, "time", option, allow_zero=allow_zero, maximum=maximum, unit="s")


def gap(text: str | float, option: str = "--gap") -> float:
    """A shroud gap in metres, ``0 <= gap <= MAX_GAP`` (the same limit as the rig file's
    ``[contact] gap``): the one gap rule of every ``--gap``, gap study and map. A plain number is
    metres: ``--gap 0.5`` is refused, write ``"0.5 mm"``."""
    value = quantity(text, "length", option)
    if value < 0:
        raise UserError(f"{option} = {text!r}: a gap must be between 0 and {MAX_GAP * 1e3:g} mm")
    if value > MAX_GAP:
        raise UserError(
            f"{option} = {text!r} is {value * 1e3:g} mm, wider than any blade could close "
            f"(a gap must be between 0 and {MAX_GAP * 1e3:g} mm); a plain number is metres: write gaps with units, e.g. '0.5 mm'"
        )
    return value


STUDY_DIMENSION = {"gap": "length", "force": "force", "frequency": "frequency", "amplitude": "length"}
MAX_POINTS = 10_000  # values in one list or grid
#: a value list of each kind as the messages show one
LIST_EXAMPLE = {
    "gap": "0.5 mm:2 mm:0.5 mm",
    "force": "5 N:20 N:5 N",
    "frequency": "55 Hz:80 Hz:1 Hz",
    "amplitude": "0.300 mm:0.360 mm:0.005 mm",
}
_PLURAL = {"gap": "gaps", "force": "forces", "frequency": "frequencies", "amplitude": "amplitudes"}


#: the option that holds each study kind's swept quantity fixed, where the study is not of it
SWEPT_OPTION = {"gap": "--gap", "force": "--force", "frequency": "--fe"}


def swept_not_fixed(kind: str, fixed: Mapping[str, Any]) -> None:
    """A study's swept quantity also given as a fixed option (``--force "3 N"`` in a force study)
    would be ignored: one line naming it. ``fixed``: option -> value given (``None``: not given).

    Raises
    ------
    UserError
        ``fixed[SWEPT_OPTION[kind]]`` is given.
    """
    option = SWEPT_OPTION.get(kind, "")
    if fixed.get(option) is not None:
        raise UserError(
            f"{option} = {fixed[option]!r}: a {kind} study sweeps the {_PLURAL[kind]} given by --values; "
            f"leave {option} out (it would be ignored)"
        )


def comma_items(text: str, option: str) -> list[str]:
    """The items of a comma list ``"a,b,c"``, each stripped; an empty one (``"a,,b"``, a comma at
    an end) is one line naming ``option``, the text and the item, never a silently shorter list."""
    parts = text.split(",")
    empty = [i for i, p in enumerate(parts, 1) if not p.strip()]
    if empty:
        where = "two commas in a row" if 1 < empty[0] < len(parts) else "a comma at an end"
        raise UserError(f"{option} = {text!r}: item {empty[0]} is empty ({where})")
    return [p.strip() for p in parts]


def value_list(
    text: str, kind: str, option: str = "--values", *, minimum: int = 1, positive: bool = False
) -> list[float]:
    """The one grammar of value lists: ``"a,b,c"`` or ``"start:stop:step"`` (stop included) with
    units, of a ``kind`` (``"gap"``, ``"force"``, ``"frequency"``) in SI units, each checked (a gap
    by :func:`gap`; forces ``>= 0``, ``> 0`` with ``positive``; frequencies ``> 0``), at least
    ``minimum`` different values (a stepped sine: 2) and at most :data:`MAX_POINTS`."""
    dimension = STUDY_DIMENSION[kind]

    def one(part: str) -> float:
        return gap(part, option) if kind == "gap" else quantity(part, dimension, option)

    text = text.strip()
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise UserError(f"{option} = {text!r}: write start:stop:step")
        empty = [name for name, p in zip(("start", "stop", "step"), parts, strict=True) if not p.strip()]
        if empty:  # "0.3 mm:0.9 mm:": else the line quotes '' alone, not the list it came from
            raise UserError(f"{option} = {text!r}: the {empty[0]} is empty (write start:stop:step)")
        start, stop, step = (one(p) for p in parts)
        if not step > 0 or stop < start:
            raise UserError(f"{option} = {text!r}: need step > 0 and stop >= start")
        n = math.floor((stop - start) / step + 1e-9) + 1
        if n > MAX_POINTS:
            raise UserError(f"{option} = {text!r}: {n} points is too many (at most {MAX_POINTS})")
        values = [start + i * step for i in range(n)]
    else:
        if not text:
            raise UserError(f"{option}: give at least one value")
        values = [one(p) for p in comma_items(text, option)]
        if len(values) > MAX_POINTS:
            raise UserError(f"{option}: {len(values)} points is too many (at most {MAX_POINTS})")
    strict = positive or kind in ("frequency", "amplitude")
    bad = [v for v in values if (v <= 0 if strict else v < 0)]
    if bad:
        what = {
            "gap": "gaps must be >= 0",
            "force": f"force amplitudes must be {'>' if strict else '>='} 0",
            "frequency": "frequencies must be > 0",
            "amplitude": "displacement amplitudes must be > 0",
        }[kind]
        raise UserError(f"{option} = {text!r}: {what} (got {bad[0]:g})")
    if len(set(values)) < minimum:
        raise UserError(
            f"{option} = {text!r}: give at least {minimum} different {_PLURAL[kind]}, "
            f'as "a,b,c" or "start:stop:step", e.g. "{LIST_EXAMPLE[kind]}"'
        )
    return values


def drive_amplitude(text: str, option: str = "--drive") -> float:
    """A drive voltage amplitude in peak volts: ``"1 V"``, ``"500 mV"``, ``1`` (peak) or
    ``"2 Vpp"`` (= 1 V peak), > 0; as ``[signal_source] max_amplitude`` and ``[safety] max_drive``
    read it."""
    try:
        value = voltage_amplitude(text)
    except ValueError as exc:
        raise UserError(f"{option} = {text!r}: {exc}") from None
    if not value > 0:
        raise UserError(f"{option} = {text!r}: must be > 0 V")
    return value


_INTEGER = re.compile(r"^\s*[-+]?\d+\s*$")


def count(text: str | int, option: str, *, minimum: int = 1, maximum: int | None = None) -> int:
    """A whole number (steps, points, elements) in ``[minimum, maximum]``."""
    if isinstance(text, bool) or not (isinstance(text, int) or _INTEGER.match(str(text))):
        raise UserError(f"{option} = {text!r}: expected a whole number")
    value = int(text)
    if value < minimum or (maximum is not None and value > maximum):
        allowed = f">= {minimum}" if maximum is None else f"between {minimum} and {maximum}"
        raise UserError(f"{option} = {text!r}: must be {allowed}")
    return value


_SCHEDULER = re.compile(r"^(tcp|tls|ws|wss|ucx|inproc)://[^\s/:]+(:\d{1,5})?/?$")


def scheduler_address(text: str, option: str = "--scheduler") -> str:
    """A Dask scheduler address ``scheme://host:port`` (``tcp://10.0.0.5:8786``), checked before
    any connection is tried."""
    if not _SCHEDULER.match(str(text).strip()):
        raise UserError(f"{option} = {text!r}: write a scheduler address, e.g. tcp://10.0.0.5:8786")
    return str(text).strip()


MAX_SEED = 2**63 - 1


def seed(value: str | int | None, option: str = "--seed") -> int | None:
    """A random seed: a whole number ``0 <= seed < 2**63``; ``None`` passes through (no seed)."""
    if value is None:
        return None
    if isinstance(value, bool) or not (isinstance(value, int) or _INTEGER.match(str(value))):
        raise UserError(f"{option} = {value!r}: a seed is a whole number >= 0")
    number = int(value)
    if not 0 <= number <= MAX_SEED:
        raise UserError(f"{option} = {value!r}: a seed is a whole number between 0 and 2**63 - 1")
    return number


#: Suffixes of the files rigtools writes, by kind (``output_path(..., suffixes=HDF5_SUFFIXES)``):
#: a name that says another format (``--out run.txt``) is refused before any work is done.
HDF5_SUFFIXES = (".h5", ".hdf5")
UFF_SUFFIXES = (".uff", ".unv")
TABLE_SUFFIXES = (".csv", ".json")
RIG_FILE_SUFFIXES = (".toml",)


def output_path(
    text: str,
    overwrite: bool = False,
    option: str = "--out",
    *,
    suffixes: Iterable[str] | None = None,
    inputs: Iterable[str | Path] = (),
) -> Path:
    """Check an output file before any work is done.

    Parameters
    ----------
    text
        The path given on the command line.
    overwrite
        Whether an existing file may be replaced (``--overwrite``).
    option
        The option's name for the message.
    suffixes
        Allowed suffixes, compared case-insensitively (:data:`HDF5_SUFFIXES`, ...); ``None``: any.
    inputs
        Files this command reads (a recording, a rig file): the output may never be one of them,
        ``--overwrite`` or not.

    Returns
    -------
    Path
        The output path.

    Raises
    ------
    UserError
        One line if the path is empty or a directory, its folder is missing, not a folder or not
        writable, it exists without ``overwrite`` or is read-only, has a suffix not in ``suffixes``,
        or is one of ``inputs``.
    """
    overwrite = switch(overwrite, advised_option("overwrite"))
    if not str(text).strip():
        raise UserError(f"{option}: give a file name")
    out = Path(text)
    where = f"{option} = {str(text)!r}"
    name_fits(out, where)
    if out.is_dir() or str(text).endswith(("/", os.sep)):
        raise UserError(f"{where} is a directory; give a file name")
    folder = out.parent
    if not folder.exists():
        raise UserError(f"{where}: folder {str(folder)!r} does not exist")
    if not folder.is_dir():
        raise UserError(f"{where}: {str(folder)!r} is not a folder")
    writable_target(out, where)
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UserError(f"{where}: folder {str(folder)!r} is not writable")
    for source in inputs:
        if same_file(out, Path(source)):
            raise UserError(f"{where} is an input of this command ({str(source)!r}); give another file name")
    if suffixes is not None:
        allowed = tuple(s.lower() for s in suffixes)
        if out.suffix.lower() not in allowed:
            raise UserError(f"{where}: the file name must end in {' or '.join(allowed)}")
    if out.exists() or out.is_symlink():  # a link to a file still to be made is a name taken too
        if not overwrite:
            raise UserError(f"{where} exists; give {advised_option('overwrite', True)} to replace it")
        if out.exists() and not os.access(out, os.W_OK):
            raise UserError(f"{where} exists and is read-only")
    return out


def output_folder(
    text: str | os.PathLike,
    option: str = "--out",
    *,
    replaceable: str | None = None,
    owner: str | None = None,
    owner_name: str = "this command",
) -> Path:
    """Check an output folder before any work is done (the one rule of every ``--out DIR``).

    Parameters
    ----------
    text
        The folder given; it may not exist yet (it is made when written).
    option
        The option's name for the message.
    replaceable
        A glob (``"run.compare-*.png"``): files of that name in the folder may be replaced only if
        rigtools wrote them as derived files (:func:`rigtools.derived_files.is_derived_plot`).
    owner
        A marker file name (``".rig-demo"``): a folder holding other files must hold this marker
        (a folder a previous run of the same command wrote), else it is refused.
    owner_name
        Who writes the marker, for the message (``"a demo"``).

    Raises
    ------
    UserError
        One line: the path exists and is not a folder, a taken name is not a rigtools file, or
        the folder holds files another program wrote.
    """
    if not str(text).strip():
        raise UserError(f"{option}: give a folder name")
    out = Path(text)
    if out.exists() and not out.is_dir():
        raise UserError(f"{option} {out}: exists and is not a folder")
    writable_target(out / "x", f"{option} {out}")
    if not out.is_dir():
        return out
    if owner is not None and any(out.iterdir()) and not (out / owner).exists():
        raise UserError(
            f"{option} {out}: holds files that {owner_name} did not write; give a new or empty folder"
        )
    if replaceable is not None:
        for path in sorted(out.glob(replaceable)):
            if not (path.is_file() and not path.is_symlink() and is_derived_plot(path)):
                raise UserError(
                    f"{option}: {path} exists and was not made by rigtools as a derived file; "
                    "not overwritten (move it or choose another folder)"
                )
    return out


def check_out(
    args: argparse.Namespace, *, suffixes: Iterable[str], inputs: Iterable[str | Path] = ()
) -> Path:
    """``args.out`` checked by :func:`output_path` (``args.overwrite`` if the command has it); the
    rig file ``args.rig`` (if any) is always one of the ``inputs``; ``suffixes`` (the file kind's:
    :data:`HDF5_SUFFIXES`, ...) always given, so every ``--out FILE`` says what it writes."""
    rig = getattr(args, "rig", None)
    sources = [*inputs, *([rig] if rig else [])]
    return output_path(
        args.out, getattr(args, "overwrite", False), "--out", suffixes=suffixes, inputs=sources
    )


def band_option(text: str, option: str = "--band", *, allow_zero: bool = True) -> tuple[float, float]:
    """The one ``LOW:HIGH`` band grammar of every command (``rig analyze``, ``rig acquire frf``,
    ``rig update``): ``"100 Hz:4 kHz"`` (a plain number is Hz) as ``(100.0, 4000.0)``.

    Parameters
    ----------
    text
        The option's text.
    option
        The option's name for the message.
    allow_zero
        Accept LOW = 0 Hz (an identification band may start at 0; an excitation band may not).

    Returns
    -------
    tuple of float
        ``(low, high)`` in Hz.

    Raises
    ------
    UserError
        One line naming the option when the text is not two increasing finite frequencies.
    """
    parts = [t.strip() for t in str(text).split(":")]
    if len(parts) != 2 or not all(parts):
        raise UserError(f'{option} = {text!r}: write LOW:HIGH, e.g. "100 Hz:4 kHz"')
    lo, hi = (quantity(p, "frequency", option) for p in parts)
    if not ((0 <= lo if allow_zero else 0 < lo) and lo < hi and math.isfinite(hi)):
        raise UserError(f"{option} = {text!r}: need {'0 <=' if allow_zero else '0 <'} LOW < HIGH")
    return lo, hi


# the readers' --skip-damaged, shared by the commands that read recordings
SKIP_DAMAGED_HELP = (
    "read a recording rig check rejects, leaving each damaged point or channel out with a note "
    "(without it such a file is refused in one line naming its first problem)"
)


def add_skip_damaged(parser: argparse.ArgumentParser) -> None:
    """The readers' ``--skip-damaged`` (``rig``'s entry point applies it to every recording the
    command opens: ``rigtools.recording.reader.reading_damaged``)."""
    parser.add_argument("--skip-damaged", action="store_true", help=SKIP_DAMAGED_HELP)
