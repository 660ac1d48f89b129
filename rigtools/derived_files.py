"""Derived files (plots, reports) next to the files they describe, never over them: their names and
their safe, atomic writing. Standard library only.

Naming rule for derived files (docs/recording-format.md, "Derived files"): the derived file of
``DIR/STEM.SUFFIX`` is ``DIR/STEM.png`` (``run.h5`` -> ``run.png``), unless that name is the
source itself (a source named ``x.png``) or an existing file that is not a rigtools plot (a
recording, a user's image, anything else) or was made read-only (``-r--r--r--``); then ``STEM.plot.png``, ``STEM.plot-2.png``, ... the
first that is free or a rigtools plot. ``STEM.plot.png`` can never equal the source's name (a
suffix holds no dot), and :func:`write_derived` checks again when writing, replaces a file only
atomically and never replaces the source or a file that is not a derived file.
"""

from __future__ import annotations

import os
import struct
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rigtools.errors import FaultError, UserError, one_line
from rigtools.write_targets import read_only, writable_target

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
SOFTWARE_PREFIXES = ("rigtools", "Matplotlib")  # whose PNGs a new plot may replace


def png_software(path: str | os.PathLike) -> str | None:
    """The ``Software`` text of a PNG file (None if it is not a PNG or has none)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
    except OSError:
        return None
    if not head.startswith(PNG_SIGNATURE):
        return None
    pos = len(PNG_SIGNATURE)
    while pos + 8 <= len(head):
        length, kind = struct.unpack(">I4s", head[pos : pos + 8])
        if kind == b"IDAT":
            break
        data = head[pos + 8 : pos + 8 + length]
        if kind == b"tEXt" and b"\0" in data:
            key, _, value = data.partition(b"\0")
            if key == b"Software":
                return value.decode("latin-1")
        pos += 12 + length
    return None


def is_derived_plot(path: str | os.PathLike) -> bool:
    """True if ``path`` is a PNG written by rigtools (or matplotlib): a plot a new one may replace."""
    software = png_software(path)
    return software is not None and software.startswith(SOFTWARE_PREFIXES)


def _same(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and a.samefile(b))
    except OSError:
        return False


def derived_path(
    source: str | os.PathLike,
    ext: str = ".png",
    kind: str = "plot",
    replaceable: Callable[[Path], bool] = is_derived_plot,
) -> Path:
    """Name of the ``kind`` file derived from ``source`` (see the module's naming rule).

    Parameters
    ----------
    source : path
        The file the derived file describes (a recording, a CSV of curves...).
    ext : str
        Extension of the derived file, with its dot.
    kind : str
        Word inserted when the plain name is taken: ``STEM.{kind}{ext}``.
    replaceable : callable
        Whether an existing file of that name may be replaced (default: a rigtools/matplotlib PNG).

    Returns
    -------
    Path
        Never ``source`` itself, never an existing file ``replaceable`` refuses or whose
        permission bits let no one write it (:func:`rigtools.write_targets.read_only`).
    """
    source = Path(source)
    stem = source.stem
    candidates = [source.with_name(stem + ext), source.with_name(f"{stem}.{kind}{ext}")]
    candidates += (source.with_name(f"{stem}.{kind}-{n}{ext}") for n in range(2, 1000))
    for path in candidates:
        if path.name.lower() == source.name.lower() or _same(path, source):
            continue
        if not path.exists() and not path.is_symlink():
            return path
        if path.is_file() and not path.is_symlink() and replaceable(path) and not read_only(path):
            return path
    raise UserError(f"no free name for the {kind} of {source} ({candidates[-1].name} taken)")


def plot_path(out: str | os.PathLike) -> Path:
    """The figure written beside an output file: ``STEM.png``, never ``out`` itself nor a file
    that is not a plot (then ``STEM.plot.png``; see the module's naming rule)."""
    return derived_path(out, ".png", "plot")


def write_derived(
    path: str | os.PathLike,
    write: Callable[[Path], object],
    *,
    source: str | os.PathLike | None = None,
    replaceable: Callable[[Path], bool] = is_derived_plot,
) -> Path:
    """Write a derived file safely: ``write(tmp)`` fills a temporary file in the same folder,
    which then atomically takes the name ``path``.

    Raises
    ------
    UserError
        If ``path`` is ``source`` or exists and ``replaceable`` refuses it (a recording, a file
        not made by rigtools): nothing is written and the existing file is untouched.
    """
    path = Path(path)
    if source is not None and (
        path.name.lower() == Path(source).name.lower()
        and path.parent.resolve() == Path(source).parent.resolve()
        or _same(path, Path(source))
    ):
        raise UserError(f"{path} is the file it is derived from; not overwritten")
    if (path.exists() or path.is_symlink()) and not (
        path.is_file() and not path.is_symlink() and replaceable(path)
    ):
        raise UserError(f"{path} exists and was not made by rigtools as a derived file; not overwritten")
    return atomic_write(path, write)


def atomic_write(path: str | os.PathLike, write: Callable[[Path], object]) -> Path:
    """Write a file as a whole or not at all: ``write(tmp)`` fills a temporary file in the same
    folder, which then takes the name ``path`` by one rename. The one way rigtools writes a
    derived file (plots, UFF, CSV, JSON, reports, rig files).

    ``path`` is checked by :func:`rigtools.write_targets.writable_target` first (no device node, FIFO,
    socket, kernel file system, or symbolic link out of the folder). A failed write (disk full,
    quota, a library's error on a write) removes the temporary file and leaves an existing
    ``path`` untouched.

    Raises
    ------
    UserError
        ``path`` is not a place rigtools writes (exit 2).
    FaultError
        The write failed (exit 4), in one line naming the file.
    """
    path = Path(path)
    writable_target(path)
    existed = path.exists()
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name[:200]}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise FaultError(f"cannot write {path}: {exc.strerror or exc}") from None
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it private; a derived file is an ordinary file
        write(tmp)
        os.replace(tmp, path)
    except BaseException as exc:
        tmp.unlink(missing_ok=True)
        cause = _os_error(exc)
        if cause is not None:
            # the file's own name: "nothing written" read as if the recording it derives from were lost
            kept = " (the one there is unchanged)" if existed else ""
            raise FaultError(
                f"cannot write {path}: {cause.strerror or one_line(cause)}; {path.name} not written{kept}"
            ) from None
        raise
    return path


def atomic_write_hdf5(path: str | os.PathLike, fill: Callable[[Any], object]) -> Path:
    """Write a small HDF5 file whole or not at all: ``fill(f)`` fills an h5py file built in
    memory, whose bytes :func:`atomic_write` then writes. A full disk is then an ordinary
    ``OSError`` of a plain write (exit 4, nothing left behind), never the HDF5 library failing
    inside its own close (a segmentation fault that left ``NAME.partial``)."""
    import io

    import h5py

    def write(tmp: Path) -> None:
        buffer = io.BytesIO()
        with h5py.File(buffer, "w") as f:
            fill(f)
        tmp.write_bytes(buffer.getbuffer())

    return atomic_write(path, write)


def _os_error(exc: BaseException) -> OSError | None:
    """The OSError behind ``exc`` (itself, or its cause/context: pyuff wraps a full disk in
    ``Exception('Error writing data-set #58')``), else None."""
    seen = 0
    while exc is not None and seen < 5:
        if isinstance(exc, OSError):
            return exc
        exc = exc.__cause__ or exc.__context__  # type: ignore[assignment]
        seen += 1
    return None
