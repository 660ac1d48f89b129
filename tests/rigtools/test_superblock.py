"""``rigtools.recording.superblock`` held against files h5py writes with each ``libver`` after a
simulated kill (issue 32, item 4).

Why the module stays: HDF5 (h5py 3.16 / HDF5 2.0 here) refuses a file whose writer died in plain
write mode with superblock v2/v3 ("file is already open for write") with ``locking=False`` too,
and SWMR-read mode refuses it ("not already open for SWMR writing"); ``h5clear -s`` and HDF5's
private "clear status flags" property clear the flags in place, which a reader must never do.
The reference here is independent: the values the killed writer flushed, and the same file copied
and cleared by HDF5's own ``h5clear -s`` (where the tool is installed).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from rigtools.recording.reader import open_h5
from rigtools.recording.superblock import FlagClearedFile, consistency_flags

LIBVERS = ["earliest", "v108", "v110", "latest"]
WRITER = """
import os, sys
import h5py, numpy as np
libver = sys.argv[2]
f = h5py.File(sys.argv[1], "w", libver=(libver, "latest"), locking=False)
f.attrs["status"] = "recording"
f.create_dataset("x", data=np.arange(1000.0) * 0.5)
f.create_group("points").create_dataset("0000", data=np.linspace(-1, 1, 257))
f.flush()
os._exit(0)  # killed: the file is never closed
"""


def _killed(path: Path, libver: str) -> Path:
    subprocess.run([sys.executable, "-c", WRITER, str(path), libver], check=True, timeout=60)
    return path


@pytest.mark.parametrize("libver", LIBVERS)
def test_a_killed_writers_file_opens_with_what_it_flushed(libver, tmp_path):
    path = _killed(tmp_path / f"{libver}.h5", libver)
    flags = consistency_flags(path)
    # superblock v0/v1 (earliest) carries no flags; v2 (v108) flags HDF5 ignores; v3 (v110+) refused
    assert flags is None if libver == "earliest" else flags != 0
    f, opened_as = open_h5(path, wait=False)
    with f:
        assert opened_as == ("flags-cleared" if libver in ("v110", "latest") else "clean")
        np.testing.assert_array_equal(f["x"][:], np.arange(1000.0) * 0.5)
        np.testing.assert_array_equal(f["points/0000"][:], np.linspace(-1, 1, 257))
        assert f.attrs["status"] == "recording"
    assert consistency_flags(path) == flags  # never modified


@pytest.mark.parametrize("libver", ["v110", "latest"])
def test_hdf5_itself_refuses_them(libver, tmp_path):
    path = _killed(tmp_path / f"{libver}.h5", libver)
    for kw in ({}, {"locking": False}, {"swmr": True}):
        with pytest.raises(OSError, match="already open for"):
            h5py.File(path, "r", **kw)


@pytest.mark.skipif(shutil.which("h5clear") is None, reason="h5clear (hdf5-tools) not installed")
@pytest.mark.parametrize("libver", ["v108", "v110", "latest"])
def test_the_flag_cleared_view_reads_as_h5clear_leaves_the_file(libver, tmp_path):
    path = _killed(tmp_path / f"{libver}.h5", libver)
    cleared = tmp_path / f"{libver}-cleared.h5"
    shutil.copy(path, cleared)
    subprocess.run(["h5clear", "-s", str(cleared)], check=True, timeout=60)
    assert consistency_flags(cleared) == 0
    with FlagClearedFile(path) as view:
        presented = view.read()
    # byte for byte the file h5clear leaves: the same cleared flags and recomputed checksum
    # (lookup3 over the superblock), nothing else changed
    assert presented == cleared.read_bytes() and presented != path.read_bytes()
    with h5py.File(FlagClearedFile(path), "r") as ours, h5py.File(cleared, "r") as theirs:
        for name in ("x", "points/0000"):
            np.testing.assert_array_equal(ours[name][:], theirs[name][:])


def _with_stale_end(src, dst, short_by: int) -> bytes:
    """``src`` copied to ``dst`` with its superblock's end-of-allocation ``short_by`` bytes before
    the file's end (checksum recomputed): what a writer killed between writing objects and
    recording the file's new end leaves."""
    import struct

    from rigtools.recording.superblock import lookup3, superblock_size

    data = bytearray(Path(src).read_bytes())
    n, at, width = superblock_size(bytes(data[:64])), 12 + 2 * data[9], data[9]
    eoa = int.from_bytes(data[at : at + width], "little")
    data[at : at + width] = (eoa - short_by).to_bytes(width, "little")
    data[n - 4 : n] = struct.pack("<I", lookup3(bytes(data[: n - 4])))
    Path(dst).write_bytes(bytes(data))
    return bytes(data)


@pytest.mark.parametrize("short_by", [100, 2000, 20000])
def test_objects_past_the_recorded_end_are_read_and_the_file_left_as_it_is(tmp_path, short_by):
    """A killed writer's file whose recorded end of allocation lies before objects it wrote ("addr
    overflow", "actual len exceeds EOA": the concurrency test's SIGKILL met it under load) is read
    as ``h5clear --increment`` would leave it, in memory only: every sample equal to the sound
    file's (exactly: the same bytes are read), ``rig check`` valid with a note naming the fix,
    and the file byte for byte unchanged."""
    from rigtools.cli import main
    from rigtools.recording import ChannelSpec, RecordingWriter, open_recording

    spec = ChannelSpec("force", "N", "force", 1000.0)
    good = tmp_path / "good.h5"
    waves = [np.sin(np.arange(2000) * 0.1 + k) for k in range(3)]
    with RecordingWriter(good, backend="simulated", rig="{}", experiment={}) as rec:
        for w in waves:
            point = rec.begin_point({"fe": 60.0}, [spec])
            point.append(w[None, :])
            point.end()
    stale = tmp_path / "stale.h5"
    before = _with_stale_end(good, stale, short_by)
    with open_recording(stale) as run:
        assert run.status == "complete" and len(run.points) == 3
        for point, w in zip(run.points, waves, strict=True):
            np.testing.assert_array_equal(point.channels["force"][:], w)
    assert main(["check", str(stale)]) == 0
    assert stale.read_bytes() == before


def test_resume_continues_a_study_whose_file_has_objects_past_its_recorded_end(tmp_path):
    """``rig acquire study --resume`` of a killed study's file with a stale end of allocation (what
    CI met: SIGKILL between writing point 3's objects and recording the new end). The resume holds
    the file's writer lock while it reads the file it continues; its reads take the file for a
    killed writer's (no live writer to wait for) and read it as ``h5clear --increment`` would: the
    two complete points are kept bit for bit, the third is measured again, exit 0."""
    from cli_helpers import acquire_gap_study, run_cli

    from rigtools.recording import check_recording, open_recording

    study = acquire_gap_study("0.5 mm:0.9 mm:0.2 mm", fe="60 Hz", periods=12)
    whole = tmp_path / "whole.h5"
    code, _, err = run_cli([*study, "--out", whole])
    assert code == 0, err
    with h5py.File(whole, "r+", libver=("v110", "v110"), locking=False) as f:
        f["points/0002"].attrs["point_complete"] = False  # the point the kill cut short
        f.attrs["status"] = "recording"
    out = tmp_path / "study.h5"
    _with_stale_end(whole, out, 2000)
    with open_recording(whole) as rec:
        kept = [np.asarray(p["force"]).copy() for p in rec.points[:2]]
    code, _, err = run_cli([*study, "--out", out, "--resume"])
    assert code == 0, err
    assert check_recording(out).valid
    with open_recording(out) as rec:
        assert rec.status == "complete" and rec.experiment["resumed"] is True
        assert [round(p.params["gap"] * 1e3, 6) for p in rec.points] == [0.5, 0.7, 0.9]
        assert all(bool(p.params["point_complete"]) for p in rec.points)
        for force, p in zip(kept, rec.points[:2], strict=True):
            np.testing.assert_array_equal(np.asarray(p["force"]), force)


def test_a_lock_held_only_to_read_is_no_live_writer(tmp_path):
    """``WriterLock(path, writing=False)``: this process reads the file under its own lock and
    ``writer_alive`` answers None here; once a writer adopts the lock it names the holder."""
    from rigtools.recording import ChannelSpec, RecordingWriter, writer_alive
    from rigtools.recording.lock import WriterLock

    path = tmp_path / "r.h5"
    lock = WriterLock(path, writing=False)
    lock.acquire()
    try:
        assert writer_alive(path) is None
        with RecordingWriter(path, backend="simulated", rig="{}", experiment={}, lock=lock) as rec:
            assert writer_alive(path) is not None and "pid" in writer_alive(path)
            point = rec.begin_point({"fe": 60.0}, [ChannelSpec("force", "N", "force", 1000.0)])
            point.append(np.zeros((1, 10)))
            point.end()
    finally:
        lock.release()
    assert writer_alive(path) is None
