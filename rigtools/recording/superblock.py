"""Read a file whose writer died outside SWMR mode, without modifying it.

HDF5 1.10+ files record in their superblock that a writer has the file open ("file consistency
flags"). A writer killed while it held the file in plain write mode (the few milliseconds in
which :class:`~rigtools.recording.RecordingWriter` adds a point or sets the final status) leaves
the flag set, and HDF5 then refuses to open the file ("file is already open for write"); the
HDF5 tool ``h5clear -s FILE`` clears it in place. The reader instead opens the file through
:class:`FlagClearedFile`, a read-only file object that presents the superblock with the flags
cleared and its checksum recomputed (superblock version 2/3 layout and Jenkins lookup3 checksum,
as in the HDF5 file format specification, sections II.A and "checksum").

Why HDF5 itself cannot do this (h5py 3.16 / HDF5 2.0, ``tests/rigtools/test_superblock.py``):
``locking=False`` and SWMR-read mode both refuse such a file; ``h5clear`` and HDF5's "clear status
flags" file-access property (not reachable from h5py) clear the flags in place, and a reader
must not modify the file it reads. The view presents byte for byte what ``h5clear -s`` leaves.
"""

from __future__ import annotations

import io
import os
import struct

SIGNATURE = b"\x89HDF\r\n\x1a\n"
_FLAGS_OFFSET = 11
_MASK = 0xFFFFFFFF


def _rot(x: int, k: int) -> int:
    return ((x << k) | (x >> (32 - k))) & _MASK


def _mix(a: int, b: int, c: int) -> tuple[int, int, int]:
    for r1, r2, r3 in ((4, 6, 8), (16, 19, 4)):
        a = ((a - c) & _MASK) ^ _rot(c, r1)
        c = (c + b) & _MASK
        b = ((b - a) & _MASK) ^ _rot(a, r2)
        a = (a + c) & _MASK
        c = ((c - b) & _MASK) ^ _rot(b, r3)
        b = (b + a) & _MASK
    return a, b, c


def _final(a: int, b: int, c: int) -> int:
    v = [a, b, c]
    for target, source, shift in (
        (2, 1, 14),
        (0, 2, 11),
        (1, 0, 25),
        (2, 1, 16),
        (0, 2, 4),
        (1, 0, 14),
        (2, 1, 24),
    ):
        v[target] = ((v[target] ^ v[source]) - _rot(v[source], shift)) & _MASK
    return v[2]


def lookup3(data: bytes, initval: int = 0) -> int:
    """Bob Jenkins' lookup3 ``hashlittle`` of ``data``, the checksum HDF5 uses for metadata."""
    length = len(data)
    a = b = c = (0xDEADBEEF + length + initval) & _MASK
    offset = 0
    while length > 12:
        x, y, z = struct.unpack_from("<3I", data, offset)
        a, b, c = _mix((a + x) & _MASK, (b + y) & _MASK, (c + z) & _MASK)
        length -= 12
        offset += 12
    if length == 0:
        return c
    x, y, z = struct.unpack("<3I", data[offset : offset + length].ljust(12, b"\0"))
    return _final((a + x) & _MASK, (b + y) & _MASK, (c + z) & _MASK)


def superblock_size(head: bytes) -> int | None:
    """Length of a version 2/3 superblock at the start of ``head`` (incl. checksum), else None."""
    if len(head) < 12 or not head.startswith(SIGNATURE) or head[8] not in (2, 3):
        return None
    size_of_offsets = head[9]
    return 12 + 4 * size_of_offsets + 4


def consistency_flags(path: str | os.PathLike) -> int | None:
    """The superblock's file consistency flags (0 = closed cleanly), or None if not v2/v3."""
    with open(path, "rb") as fh:
        head = fh.read(64)
    return head[_FLAGS_OFFSET] if superblock_size(head) else None


def _eoa_offset(head: bytes) -> int:
    """Offset of the end-of-file address in a version 2/3 superblock (after the base and the
    superblock-extension addresses)."""
    return 12 + 2 * head[9]


class FlagClearedFile(io.RawIOBase):
    """Read-only view of an HDF5 file whose superblock consistency flags read as cleared.

    ``extend_eoa``: the end-of-file address also reads as at least the file's size, as
    ``h5clear --increment`` would write it: a writer killed between writing an object and
    updating the superblock leaves objects past the recorded end ("addr overflow")."""

    def __init__(self, path: str | os.PathLike, extend_eoa: bool = False):
        super().__init__()
        self._fh = open(path, "rb")  # noqa: SIM115 - open for this object's life; close() closes it
        head = self._fh.read(64)
        size = superblock_size(head)
        if size is None or len(head) < size:
            self._fh.close()
            raise OSError("no version 2/3 HDF5 superblock at the start of the file")
        patched = bytearray(head[:size])
        patched[_FLAGS_OFFSET] = 0
        if extend_eoa:
            at, width = _eoa_offset(head), head[9]
            eoa = int.from_bytes(patched[at : at + width], "little")
            size_now = os.fstat(self._fh.fileno()).st_size
            patched[at : at + width] = max(eoa, size_now).to_bytes(width, "little")
        patched[-4:] = struct.pack("<I", lookup3(bytes(patched[:-4])))
        self._head = bytes(patched)
        self._pos = 0
        self._fh.seek(0)

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        self._pos = self._fh.seek(offset, whence)
        return self._pos

    def tell(self) -> int:
        return self._pos

    def readinto(self, buffer) -> int:
        view = memoryview(buffer).cast("B")
        self._fh.seek(self._pos)
        n = self._fh.readinto(view)
        if n and self._pos < len(self._head):
            stop = min(len(self._head), self._pos + n)
            view[: stop - self._pos] = self._head[self._pos : stop]
        self._pos += n or 0
        return n

    def close(self) -> None:
        if not self.closed:
            self._fh.close()
        super().close()
