"""Where rigtools writes: the one rule of a path it may write (:func:`writable_target`) and the
small checks behind it. Standard library only; :mod:`rigtools.options` (``--out``) and
:mod:`rigtools.derived_files` (every derived file) both check by it.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from rigtools.errors import UserError

#: File systems of the kernel: nothing of rigtools is ever written there.
SYSTEM_FOLDERS = ("/proc", "/sys")


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """True if ``a`` and ``b`` name one file (same resolved path, or same inode)."""
    a, b = Path(a), Path(b)
    try:
        if a.resolve() == b.resolve():
            return True
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except (OSError, RuntimeError):
        return False


def name_fits(path: Path, where: str) -> None:
    """Refuse a file name longer than the file system allows, before the file system is asked
    anything else about the path."""
    for part in path.parts:
        if len(os.fsencode(part)) > 255:
            raise UserError(
                f"{where[:80]}...: the file name is longer than the file system allows (255 bytes)"
            )


def read_only(path: str | os.PathLike) -> bool:
    """True if the permission bits of ``path`` let no one write it (``dr-xr-xr-x``, ``-r--r--r--``).

    Such a folder or file was made read-only on purpose (a folder of published data sets, a
    recording kept as it was measured). The operating system lets root write there anyway, and
    ``os.access`` says so; rigtools goes by the bits, so a lab account running as root (a
    container, a DAQ PC) cannot write into its input data by mistake.
    """
    try:
        return not os.stat(path).st_mode & (stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH)
    except OSError:
        return False


def _mode(path: str | os.PathLike) -> str:
    return stat.filemode(os.stat(path).st_mode)


def writable_target(path: str | os.PathLike, where: str | None = None) -> None:
    """The one rule of what rigtools writes: a regular file or a new name in an ordinary folder.

    Refused in one :class:`UserError` line: a name longer than the file system allows, a path in
    ``/proc`` or ``/sys``, a folder (the nearest existing one, for a folder still to be made) or
    existing file whose permission bits let no one write (:func:`read_only`, root included), an
    existing device node, FIFO, socket or other non-regular file, and a symbolic link pointing
    outside its own folder. Used by
    :func:`rigtools.options.output_path`, :func:`rigtools.options.output_folder` and every derived file (:func:`rigtools.derived_files.write_derived`).
    """
    p = Path(path)
    where = where or str(p)
    folder = p.parent
    name_fits(p, where)
    try:
        real = p.resolve()
    except (OSError, RuntimeError):
        raise UserError(f"{where}: cannot resolve the path (a symbolic link loop?)") from None
    if any(real == Path(s) or Path(s) in real.parents for s in SYSTEM_FOLDERS):
        raise UserError(f"{where} is in a kernel file system ({real}); give a file in an ordinary folder")
    folder_of = next((a for a in real.parents if a.exists()), None)  # the folder written into
    if folder_of is not None and read_only(folder_of):
        raise UserError(
            f"{where}: folder {str(folder_of)!r} is not writable ({_mode(folder_of)}: "
            "its permission bits let no one write there)"
        )
    try:
        link = os.lstat(p)
    except FileNotFoundError:
        return
    except OSError as exc:
        raise UserError(f"{where}: {exc.strerror}") from None
    if stat.S_ISLNK(link.st_mode):
        if real.parent != folder.resolve():
            raise UserError(f"{where} is a symbolic link to {real}, outside its folder; not written through")
        if not real.exists():
            return
    info = os.stat(p) if stat.S_ISLNK(link.st_mode) else link
    if stat.S_ISREG(info.st_mode) and read_only(p):
        raise UserError(f"{where} exists and is read-only ({_mode(p)}); not replaced")
    if not stat.S_ISREG(info.st_mode):
        kind = (
            "a device"
            if stat.S_ISCHR(info.st_mode) or stat.S_ISBLK(info.st_mode)
            else "a FIFO"
            if stat.S_ISFIFO(info.st_mode)
            else "a socket"
            if stat.S_ISSOCK(info.st_mode)
            else "a directory"
            if stat.S_ISDIR(info.st_mode)
            else "not a regular file"
        )
        raise UserError(f"{where} is {kind}, not a regular file; not written")
