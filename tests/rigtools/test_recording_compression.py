"""Compressed channels: chunks the writer deflates itself are standard HDF5 shuffle + deflate.

The writer compresses full chunks on worker threads and stores them with ``write_direct_chunk``;
partial chunks go through HDF5's own filters at each flush and are replaced later. References,
all independent of the writer's compression code: the input arrays (exact, bit for bit) read
back through plain h5py (HDF5's own filters decode the chunks), HDF5's own record of the
dataset's filter pipeline, zlib + a numpy un-shuffle of the raw stored chunk bytes, and the
``h5dump`` command-line tool (decimal text with 17 significant digits, which round-trips float64
exactly).
"""

from __future__ import annotations

import subprocess
import zlib
from pathlib import Path

import h5py
import numpy as np
import pytest

from rigtools.recording import ChannelSpec, RecordingWriter

RATE = 51200.0
CHUNK = 1000
CHANNELS = [ChannelSpec("force", "N", "force", RATE), ChannelSpec("accel", "m/s^2", "acceleration", RATE)]


def _blocks() -> list[np.ndarray]:
    """Blocks of odd sizes (inside one chunk, across several), many magnitudes, special values."""
    rng = np.random.default_rng(11)
    parts = [
        rng.standard_normal((2, n)) * 10.0 ** rng.integers(-3, 4)
        for n in (1, 999, 2, 1500, 4321, 700, 300, 12345, 17)
    ]
    parts.append(np.array([[np.nan, np.inf, -0.0, 5e-324], [-np.inf, 1e308, 0.0, -1.0]]))
    return parts


def _write(path: Path, flush_interval: float) -> np.ndarray:
    """Write the blocks into one point; returns the samples written, shape (2, n)."""
    with RecordingWriter(
        path, backend="simulated", rig="{}", chunk_samples=CHUNK, flush_interval=flush_interval
    ) as rec:
        point = rec.begin_point({"fe": 60.0}, CHANNELS)
        for block in _blocks():
            point.append(block)
            block[:] = 0.0  # the caller may reuse its buffer once append returns
        point.end()
    return np.hstack(_blocks())


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype="<f8").view(np.uint64)


@pytest.mark.parametrize("flush_interval", [0.0, 60.0])  # flush at every append / only at the end
def test_direct_chunks_read_back_bit_for_bit_with_standard_filters(tmp_path, flush_interval):
    path = tmp_path / "deflated.h5"
    expected = _write(path, flush_interval)
    n = expected.shape[1]
    with h5py.File(path, "r") as f:
        for row, spec in enumerate(CHANNELS):
            dataset = f["points/0000"][spec.name]
            np.testing.assert_array_equal(_bits(dataset[:]), _bits(expected[row]))
            plist = dataset.id.get_create_plist()
            filters = [plist.get_filter(i) for i in range(plist.get_nfilters())]
            assert [(code, tuple(values)) for code, _, values, _ in filters] == [
                (h5py.h5z.FILTER_SHUFFLE, (8,)),
                (h5py.h5z.FILTER_DEFLATE, (1,)),
            ]
            assert dataset.chunks == (CHUNK,)
            # every stored chunk, full (written directly) or last (written by HDF5), passed both
            # filters: zlib + un-shuffle of its raw bytes give the samples
            for start in range(0, n, CHUNK):
                mask, raw = dataset.id.read_direct_chunk((start,))
                assert mask == 0
                shuffled = np.frombuffer(zlib.decompress(raw), np.uint8)
                values = shuffled.reshape(8, -1).T.copy().view("<f8").ravel()
                stop = min(start + CHUNK, n)
                np.testing.assert_array_equal(_bits(values[: stop - start]), _bits(expected[row, start:stop]))


def test_h5dump_reads_the_directly_written_chunks(tmp_path, h5dump):
    path = tmp_path / "deflated.h5"
    expected = _write(path, flush_interval=0.0)
    out = tmp_path / "force.txt"
    subprocess.run(
        [h5dump, "-d", "/points/0000/force", "-m", "%.17g", "-y", "-w", "0", "-o", str(out), str(path)],
        check=True,
        capture_output=True,
        timeout=60,
    )
    text = out.read_text().replace(",", " ").split()
    values = np.array([float(v) for v in text])
    np.testing.assert_array_equal(_bits(values), _bits(expected[0]))
