"""Child process for the SIGKILL crash test of the recording writer (not a test module).

Usage: python recording_crash_writer.py PATH SEED [POINT_BLOCKS]

Streams blocks paced in real time (BLOCK_S per block) into PATH through
:class:`rigtools.recording.RecordingWriter`, starting a new point every POINT_BLOCKS blocks, until
it is killed. Block ``b`` of point ``p`` is ``block(seed, p, b)``, so the parent can regenerate
what was written. After every append whose flush moved ``flushed_samples`` it prints
``F <unix time> <point> <flushed samples>``; after a point ends ``E <unix time> <point>``.
The time is taken after the flush returned.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from rigtools.config import default_rig_text
from rigtools.recording import ChannelSpec, RecordingWriter

SAMPLE_RATE = 20000.0
BLOCK_S = 0.05
BLOCK = int(SAMPLE_RATE * BLOCK_S)
CHANNELS = [
    ChannelSpec(
        "force",
        "N",
        "force",
        SAMPLE_RATE,
        sensitivity=11.24,
        sensitivity_units="mV/N",
        physical_channel="Dev1/ai0",
        location="active blade, x=0.090 m",
    ),
    ChannelSpec("active_shroud_accel", "m/s^2", "acceleration", SAMPLE_RATE),
    ChannelSpec("passive_shroud_accel", "m/s^2", "acceleration", SAMPLE_RATE),
    ChannelSpec("drive", "V", "voltage", SAMPLE_RATE),
]


def block(seed: int, point: int, index: int) -> np.ndarray:
    """The (4, BLOCK) float64 block number ``index`` of ``point`` (full-mantissa random values)."""
    return np.random.default_rng([seed, point, index]).standard_normal((len(CHANNELS), BLOCK))


def main(path: str, seed: int, point_blocks: int) -> None:
    with RecordingWriter(
        path,
        backend="simulated",
        rig=default_rig_text(),  # a whole rig description: rig check holds the rig attribute
        experiment={"procedure": "crash-test", "seed": seed},
    ) as rec:
        print("S", time.time(), flush=True)
        point_no = 0
        next_due = time.monotonic()
        while True:
            point = rec.begin_point(
                params={"fe": 60.0 + point_no, "force_amplitude": 15.0, "gap": 5e-4}, channels=CHANNELS
            )
            reported = 0
            for index in range(point_blocks):
                point.append(block(seed, point_no, index))
                if point.flushed_samples != reported:
                    reported = point.flushed_samples
                    print("F", time.time(), point_no, reported, flush=True)
                next_due += BLOCK_S
                time.sleep(max(0.0, next_due - time.monotonic()))
            point.set_attrs(settled=True, measured_force_amplitude=14.9)
            point.end()
            print("E", time.time(), point_no, flush=True)
            point_no += 1


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]) if len(sys.argv) > 3 else 20)
