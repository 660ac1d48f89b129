"""Sustained write throughput of the streaming recording writer versus plain h5py appends.

4 float64 channels at 51.2 kS/s in 0.1 s blocks (5120 samples per channel per block), many
blocks into one point. The same pre-made blocks (sine + noise, 24-bit quantised like a DAQ, so
compression sees realistic data) are written by

* ``RecordingWriter`` (SWMR, flush every 0.5 s, the point/structure phases included), and
* plain h5py: one file in the same HDF5 1.10 format, four resizable chunked datasets with the
  same chunking and filters, ``resize`` + slice assignment per block, one close at the end (no
  SWMR, no flushes) - the baseline of the goal;
* the same plain file written with the writer's low-level calls (``dataset.id.write`` on a
  hyperslab), which isolates the cost of SWMR and the flushes,

alternating, ``--repeats`` times; each figure is the median. Throughput = samples (all channels)
/ wall seconds from creating the file to closing it. Run for both storage choices:
``--compression none`` (chunked, uncompressed) and ``gzip`` (shuffle + deflate level 1, the
writer's default). The writer deflates on two worker threads, so its gzip figure depends on a
second free core: the printed "writer CPU/wall" is near 1 when other jobs hold it.

Goals (issue 4): >= 20 million samples/s and >= 0.8 of plain h5py.

    .venv/bin/python benchmarks/bench_recording_writer.py            # ~1 min
    .venv/bin/python benchmarks/bench_recording_writer.py --blocks 400 --repeats 3 --json
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

from rigtools.recording import ChannelSpec, RecordingWriter
from rigtools.recording.writer import DEFAULT_CHUNK_SAMPLES, LIBVER

SAMPLE_RATE = 51200.0
BLOCK = 5120  # 0.1 s
N_CHANNELS = 4


def make_blocks(n_distinct: int = 32) -> list[np.ndarray]:
    """Realistic blocks: harmonics + noise, quantised to 24 bits over +-10 V, in SI units."""
    rng = np.random.default_rng(1)
    t = np.arange(n_distinct * BLOCK) / SAMPLE_RATE
    rows = []
    for k, scale in enumerate((15.0, 400.0, 250.0, 2.0)):  # N, m/s^2, m/s^2, V
        x = scale * (np.sin(2 * np.pi * 60 * t + k) + 0.2 * np.sin(2 * np.pi * 360 * t))
        x += rng.normal(0, 0.002 * scale, t.size)
        lsb = 20 * scale / 2**24
        rows.append(np.round(x / lsb) * lsb)
    data = np.vstack(rows)
    return [np.ascontiguousarray(data[:, i * BLOCK : (i + 1) * BLOCK]) for i in range(n_distinct)]


def run_writer(path: Path, blocks: list[np.ndarray], n_blocks: int, compression: str) -> float:
    channels = [ChannelSpec(f"ch{i}", "V", "voltage", SAMPLE_RATE) for i in range(N_CHANNELS)]
    start = time.perf_counter()
    with RecordingWriter(path, backend="simulated", rig="{}", compression=compression) as rec:
        point = rec.begin_point({"fe": 60.0}, channels)
        for i in range(n_blocks):
            point.append(blocks[i % len(blocks)])
        point.end()
    return time.perf_counter() - start


def plain_datasets(f: h5py.File, compression: str) -> list[h5py.Dataset]:
    """The baseline's resizable channel datasets, chunked and filtered like the writer's."""
    filters = {"compression": "gzip", "compression_opts": 1, "shuffle": True} if compression == "gzip" else {}
    return [
        f.create_dataset(
            f"ch{i}", shape=(0,), maxshape=(None,), dtype="f8", chunks=(DEFAULT_CHUNK_SAMPLES,), **filters
        )
        for i in range(N_CHANNELS)
    ]


def run_plain(path: Path, blocks: list[np.ndarray], n_blocks: int, compression: str) -> float:
    start = time.perf_counter()
    with h5py.File(path, "w", libver=LIBVER) as f:
        datasets = plain_datasets(f, compression)
        n = 0
        for i in range(n_blocks):
            block = blocks[i % len(blocks)]
            for dataset, row in zip(datasets, block, strict=True):
                dataset.resize((n + BLOCK,))
                dataset[n : n + BLOCK] = row
            n += BLOCK
    return time.perf_counter() - start


def run_plain_direct(path: Path, blocks: list[np.ndarray], n_blocks: int, compression: str) -> float:
    """Plain h5py with the writer's own low-level write calls: isolates SWMR + flush overhead."""
    start = time.perf_counter()
    with h5py.File(path, "w", libver=LIBVER) as f:
        datasets = plain_datasets(f, compression)
        memspace = h5py.h5s.create_simple((BLOCK,))
        n = 0
        for i in range(n_blocks):
            block = blocks[i % len(blocks)]
            for dataset, row in zip(datasets, block, strict=True):
                dataset.resize((n + BLOCK,))
                filespace = dataset.id.get_space()
                filespace.select_hyperslab((n,), (BLOCK,))
                dataset.id.write(memspace, filespace, row)
            n += BLOCK
    return time.perf_counter() - start


def measure(compression: str, n_blocks: int, repeats: int, folder: Path) -> dict:
    blocks = make_blocks()
    samples = n_blocks * BLOCK * N_CHANNELS
    times = {"writer": [], "plain": [], "direct": []}
    writer_cpu = []
    runs = [("writer", run_writer), ("plain", run_plain), ("direct", run_plain_direct)]
    size = 0
    for r in range(repeats):
        for name, func in runs[r % 3 :] + runs[: r % 3]:
            path = folder / f"bench_{name}.h5"
            path.unlink(missing_ok=True)
            cpu = time.process_time()
            times[name].append(func(path, blocks, n_blocks, compression))
            if name == "writer":  # > 1 when the deflate threads found a free core
                writer_cpu.append((time.process_time() - cpu) / times[name][-1])
            if name == "writer":
                size = path.stat().st_size
            path.unlink()
    writer = samples / statistics.median(times["writer"])
    plain = samples / statistics.median(times["plain"])
    direct = samples / statistics.median(times["direct"])
    return {
        "compression": compression,
        "samples": samples,
        "blocks": n_blocks,
        "writer_samples_per_s": writer,
        "plain_h5py_samples_per_s": plain,
        "ratio": writer / plain,
        "plain_lowlevel_samples_per_s": direct,
        "ratio_lowlevel": writer / direct,
        "file_mb": size / 1e6,
        "raw_mb": samples * 8 / 1e6,
        "writer_cpu_per_wall": statistics.median(writer_cpu),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--blocks", type=int, default=600, help="0.1 s blocks per run (default 600)")
    parser.add_argument("--repeats", type=int, default=5, help="runs of each writer (median)")
    parser.add_argument("--compression", choices=("none", "gzip", "both"), default="both")
    parser.add_argument("--dir", type=Path, default=None, help="folder for the temporary files")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    kinds = ("none", "gzip") if args.compression == "both" else (args.compression,)
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp:
        results = [measure(kind, args.blocks, args.repeats, Path(tmp)) for kind in kinds]
    if args.json:
        print(json.dumps(results, indent=1))
        return
    print(
        f"4 float64 channels, {SAMPLE_RATE / 1e3:g} kS/s, 0.1 s blocks, {args.blocks} blocks "
        f"({args.blocks * BLOCK * N_CHANNELS / 1e6:.1f} M samples) per run, median of "
        f"{args.repeats}, chunk {DEFAULT_CHUNK_SAMPLES} samples, cpus={os.cpu_count()}"
    )
    for res in results:
        ok = res["writer_samples_per_s"] >= 20e6 and res["ratio"] >= 0.8
        print(
            f"compression={res['compression']:<4}  writer {res['writer_samples_per_s'] / 1e6:6.1f} "
            f"M samples/s   plain h5py {res['plain_h5py_samples_per_s'] / 1e6:6.1f} M samples/s   "
            f"ratio {res['ratio']:.2f}   goal (>=20 M/s, >=0.8): {'met' if ok else 'NOT met'}"
        )
        print(
            f"{'':17}plain h5py low-level writes {res['plain_lowlevel_samples_per_s'] / 1e6:6.1f} M "
            f"samples/s (ratio {res['ratio_lowlevel']:.2f}: cost of SWMR + flushes)   file "
            f"{res['file_mb']:.0f} MB of {res['raw_mb']:.0f} MB raw   writer CPU/wall "
            f"{res['writer_cpu_per_wall']:.2f}"
        )


if __name__ == "__main__":
    main()
