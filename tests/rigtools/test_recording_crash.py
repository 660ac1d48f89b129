"""Crash test: a streaming writer killed with SIGKILL at random moments loses nothing it flushed.

Each child (``recording_crash_writer.py``) streams 4 channels in 0.05 s blocks, paced in real
time, starting a new point every 1.2 s (so kills also land near the point-structure phases), and
prints the wall time of every flush. After the kill the file must open, report status
"recording", and hold every block reported flushed more than 1 s before the kill, bit for bit
(compared as raw 64-bit patterns against the regenerated blocks). Points reported ended more
than 1 s before the kill must carry their end-of-point parameters.

12 kills at random times between 0.2 s and 3.5 s after the writer started (fixed seed, so the
schedule is reproducible); two children run at a time to keep the test near 15 s.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from rigtools.recording import open_recording

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
import recording_crash_writer as child

N_KILLS = 12
POINT_BLOCKS = 24  # 1.2 s points
MARGIN_S = 1.0  # the guarantee: flushed more than 1 s before the kill


def _start(path: Path, seed: int) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, str(HERE / "recording_crash_writer.py"), str(path), str(seed), str(POINT_BLOCKS)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_started(proc: subprocess.Popen) -> None:
    line = proc.stdout.readline()
    assert line.startswith("S"), f"writer did not start: {line!r} {proc.stderr.read()}"


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


def _verify(path: Path, seed: int, kill_time: float, log: str) -> tuple[int, int]:
    """Check one killed file; returns (points checked, samples per channel checked)."""
    flushed: dict[int, int] = {}
    ended: set[int] = set()
    for line in log.splitlines():
        kind, stamp, *rest = line.split()
        if float(stamp) >= kill_time - MARGIN_S:
            continue
        if kind == "F":
            flushed[int(rest[0])] = max(flushed.get(int(rest[0]), 0), int(rest[1]))
        elif kind == "E":
            ended.add(int(rest[0]))
            flushed[int(rest[0])] = POINT_BLOCKS * child.BLOCK
    with open_recording(path) as rec:
        assert rec.status == "recording"
        assert rec.incomplete
        assert rec.experiment == {"procedure": "crash-test", "seed": seed}
        samples = 0
        for p, n_flushed in flushed.items():
            point = rec.points[p]
            assert point.params["fe"] == 60.0 + p
            n_blocks = -(-n_flushed // child.BLOCK)
            expected = np.hstack([child.block(seed, p, b) for b in range(n_blocks)])[:, :n_flushed]
            for row, spec in enumerate(child.CHANNELS):
                channel = point.channels[spec.name]
                assert len(channel) >= n_flushed
                np.testing.assert_array_equal(_bits(channel[:n_flushed]), _bits(expected[row]))
            samples += n_flushed
        for p in ended:
            point = rec.points[p]
            assert point.ended and point.params["settled"] is True
            assert point.n_samples == POINT_BLOCKS * child.BLOCK
        return len(flushed), samples


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs SIGKILL (POSIX)")
def test_sigkill_at_random_moments_keeps_everything_flushed(tmp_path):
    rng = np.random.default_rng(20261101)
    delays = rng.uniform(0.2, 3.5, N_KILLS)
    exercised = checked_samples = 0
    for first in range(0, N_KILLS, 2):
        batch = []
        for k in range(first, min(first + 2, N_KILLS)):
            path = tmp_path / f"killed_{k:02d}.h5"
            proc = _start(path, seed=k)
            batch.append((k, path, proc))
        for _, _, proc in batch:
            _wait_started(proc)
        started = time.time()
        kills = {}
        for k, _, proc in sorted(batch, key=lambda item: delays[item[0]]):
            time.sleep(max(0.0, started + delays[k] - time.time()))
            kills[k] = time.time()
            os.kill(proc.pid, signal.SIGKILL)
        for k, path, proc in batch:
            out, err = proc.communicate(timeout=30)
            assert proc.returncode == -signal.SIGKILL, err
            _points, samples = _verify(path, k, kills[k], out)
            exercised += samples > 0
            checked_samples += samples
    # the schedule must have exercised the guarantee, not only files with nothing old enough
    assert exercised >= N_KILLS // 2 and checked_samples > 20 * child.BLOCK


def _three_point_file(path: Path) -> Path:
    from rigtools.recording import ChannelSpec, RecordingWriter

    with RecordingWriter(path, backend="simulated", rig="{}") as rec:
        for k in range(3):
            point = rec.begin_point({"fe": 60.0 + k}, [ChannelSpec("force", "N", "force", 1e4)])
            point.append(np.full((1, 100), float(k)))
            point.end()
    return path


@pytest.mark.parametrize("status, kept", [("recording", True), ("complete", False)])
def test_a_point_cut_off_mid_creation_costs_only_that_point(tmp_path, status, kept):
    """A writer killed between creating a point's group and writing its attributes leaves a group
    without them: in an unfinished file (status "recording") the other points open and the cut-off
    one is listed as unreadable; in a finished file the same defect is refused in one line."""
    import h5py

    from rigtools.recording import RecordingError

    path = _three_point_file(tmp_path / "cut.h5")
    with h5py.File(path, "r+") as f:
        for key in list(f["points/0001"].attrs):
            del f["points/0001"].attrs[key]
        f.attrs["status"] = status
    if kept:
        with open_recording(path) as rec:
            assert [p.index for p in rec.points] == [0, 2]
            assert rec.unreadable_points == ["0001"]
            assert float(rec.points[1]["force"][:][0]) == 2.0
    else:
        with pytest.raises(RecordingError, match="points/0001"):
            open_recording(path)
