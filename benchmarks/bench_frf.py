"""H1/H2 and coherence of a long recording, block by block from its HDF5 file, versus scipy on
the same arrays in memory.

The recording: 10 minutes, 4 channels (force + 3 accelerations), 51.2 kS/s, written with
``rigtools.recording.RecordingWriter`` (its default storage: chunked, shuffle + deflate), 30.7 M
samples per channel. Force: white noise; responses: three different two-resonator digital
filters of it plus 1 % noise, generated and written block by block.

* **chunked path** (the goal's subject), in a fresh subprocess so its peak RSS is its own:
  read 0.5 M samples per channel at a time with ``rigtools.recording.open_recording`` and feed
  ``rigtools.analysis.frf.SpectraAccumulator`` (Hann, 8192 samples, 50 % overlap); the time includes
  reading and decompressing the file.
* **in-memory baseline**: the four channels read whole (not timed), then ``scipy.signal.welch``
  of the force and of each response and ``scipy.signal.csd`` of the force with each response
  (the spectra H1, H2 and coherence need), same settings.

Reported: chunked time, peak memory (tracemalloc peak of Python/numpy allocations, and the
process's peak RSS above its start-up level, which also counts HDF5's own buffers), the
in-memory time, their ratio, and the largest difference between the two results.

Goals (issue 10): peak memory < 300 MB; time <= 1.5 x the in-memory path.

    .venv/bin/python benchmarks/bench_frf.py                 # ~1-2 min (writes ~1 GB to a temp dir)
    .venv/bin/python benchmarks/bench_frf.py --minutes 1     # quick look
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

SAMPLE_RATE = 51200.0
NPERSEG = 8192
READ_BLOCK = 2**19
WRITE_BLOCK = 51200
CHANNELS = ("force", "acc_1", "acc_2", "acc_3")


def _filters():
    from scipy import signal

    out = []
    for modes in (
        ((150.0, 0.02), (900.0, 0.01)),
        ((420.0, 0.015), (2500.0, 0.02)),
        ((1300.0, 0.01), (6000.0, 0.03)),
    ):
        num, den = np.array([0.0]), np.array([1.0])
        for fn, z in modes:
            w = 2 * np.pi * fn
            b, a = signal.bilinear([w**2], [1.0, 2 * z * w, w**2], fs=SAMPLE_RATE)
            num = np.polyadd(np.polymul(num, a), np.polymul(b, den))
            den = np.polymul(den, a)
        out.append((num, den))
    return out


def write_recording(path: Path, minutes: float) -> int:
    from scipy import signal

    from rigtools.recording import ChannelSpec, RecordingWriter

    rng = np.random.default_rng(1)
    filters = _filters()
    states = [signal.lfilter_zi(b, a) * 0.0 for b, a in filters]
    n_total = int(minutes * 60 * SAMPLE_RATE)
    specs = [ChannelSpec("force", "N", "force", SAMPLE_RATE)] + [
        ChannelSpec(name, "m/s^2", "acceleration", SAMPLE_RATE) for name in CHANNELS[1:]
    ]
    with RecordingWriter(path, backend="simulated", rig="{}") as rec:
        point = rec.begin_point({"fe": 0.0}, specs)
        done = 0
        while done < n_total:
            n = min(WRITE_BLOCK, n_total - done)
            x = rng.standard_normal(n)
            rows = [x]
            for i, (b, a) in enumerate(filters):
                y, states[i] = signal.lfilter(b, a, x, zi=states[i])
                rows.append(y + 0.01 * rng.standard_normal(n))
            point.append(np.vstack(rows))
            done += n
        point.end()
    return n_total


def chunked(path: str) -> dict:
    """The chunked path; run in its own process (see module docstring)."""
    from rigtools.analysis.frf import SpectraAccumulator
    from rigtools.recording import open_recording

    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    tracemalloc.start()
    start = time.perf_counter()
    with open_recording(path) as rec:
        point = next(iter(rec))
        chans = [point[name] for name in CHANNELS]
        n = point.n_samples
        acc = SpectraAccumulator(SAMPLE_RATE, nperseg=NPERSEG, noverlap=NPERSEG // 2, window="hann")
        for i in range(0, n, READ_BLOCK):
            acc.add(np.vstack([c[i : min(i + READ_BLOCK, n)] for c in chans]))
        est = acc.frf()
    elapsed = time.perf_counter() - start
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    np.save(path + ".h1.npy", est.h1)
    np.save(path + ".coh.npy", est.coherence)
    return {
        "time_s": elapsed,
        "tracemalloc_peak_mb": peak / 2**20,
        "rss_growth_mb": rss - rss0,
        "n_averages": est.n_averages,
    }


def in_memory(path: str) -> tuple[float, np.ndarray, np.ndarray]:
    from scipy import signal

    from rigtools.recording import open_recording

    with open_recording(path) as rec:
        point = next(iter(rec))
        data = [point[name].read() for name in CHANNELS]
    kw = dict(fs=SAMPLE_RATE, window="hann", nperseg=NPERSEG, noverlap=NPERSEG // 2, detrend="constant")
    start = time.perf_counter()
    _, sxx = signal.welch(data[0], **kw)
    h1, coh = [], []
    for y in data[1:]:
        _, syy = signal.welch(y, **kw)
        _, sxy = signal.csd(data[0], y, **kw)
        h1.append(sxy / sxx)
        coh.append(np.abs(sxy) ** 2 / (sxx * syy))
    elapsed = time.perf_counter() - start
    return elapsed, np.array(h1), np.array(coh)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0, help="recording length (default 10)")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    parser.add_argument("--chunked-only", metavar="FILE", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.chunked_only:
        print(json.dumps(chunked(args.chunked_only)))
        return 0

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "frf_bench.h5"
        t0 = time.perf_counter()
        n = write_recording(path, args.minutes)
        t_write = time.perf_counter() - t0
        size_mb = path.stat().st_size / 2**20
        env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
        out = subprocess.run(
            [sys.executable, __file__, "--chunked-only", str(path)],
            check=True,
            capture_output=True,
            text=True,
            env=env,
        ).stdout
        res = json.loads(out.strip().splitlines()[-1])
        t_mem, h1_mem, coh_mem = in_memory(str(path))
        h1_chunk = np.load(str(path) + ".h1.npy")
        coh_chunk = np.load(str(path) + ".coh.npy")

    band = slice(1, None)
    h1_diff = float(np.max(np.abs(h1_chunk[:, band] - h1_mem[:, band]) / np.abs(h1_mem[:, band])))
    coh_diff = float(np.max(np.abs(coh_chunk[:, band] - coh_mem[:, band])))
    ratio = res["time_s"] / t_mem
    peak_mb = max(res["tracemalloc_peak_mb"], res["rss_growth_mb"])
    figures = {
        "minutes": args.minutes,
        "samples_per_channel": n,
        "channels": len(CHANNELS),
        "file_mb": size_mb,
        "write_s": t_write,
        "n_averages": res["n_averages"],
        "chunked_s": res["time_s"],
        "in_memory_scipy_s": t_mem,
        "time_ratio": ratio,
        "tracemalloc_peak_mb": res["tracemalloc_peak_mb"],
        "rss_growth_mb": res["rss_growth_mb"],
        "max_rel_diff_h1": h1_diff,
        "max_abs_diff_coherence": coh_diff,
        "memory_goal_met": peak_mb < 300.0,
        "time_goal_met": ratio <= 1.5,
    }
    if args.json:
        print(json.dumps(figures, indent=2))
        return 0
    print(
        f"recording: {args.minutes:g} min x {len(CHANNELS)} channels at {SAMPLE_RATE:g} S/s "
        f"({n} samples per channel, {size_mb:.0f} MB on disk, written in {t_write:.1f} s)"
    )
    print(
        f"chunked (read + H1/H2/coherence, {res['n_averages']} averages): {res['time_s']:.2f} s, "
        f"peak memory {res['tracemalloc_peak_mb']:.1f} MB (tracemalloc), "
        f"{res['rss_growth_mb']:.1f} MB (RSS growth)"
    )
    print(f"in-memory scipy.signal.welch/csd on the same arrays: {t_mem:.2f} s")
    print(f"time ratio chunked / in-memory: {ratio:.2f}")
    print(f"agreement: max |dH1|/|H1| = {h1_diff:.1e}, max |d coherence| = {coh_diff:.1e}")
    print(f"goal peak memory < 300 MB: {'met' if peak_mb < 300 else 'NOT met'} ({peak_mb:.0f} MB)")
    print(f"goal time <= 1.5 x in-memory: {'met' if ratio <= 1.5 else 'NOT met'} ({ratio:.2f} x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
