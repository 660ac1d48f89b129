"""What the simulated real-time inner loop costs: wall seconds per simulated second.

The simulated rig at 51.2 kS/s (gap 0.5 mm, noise-free chain, 0.1 s blocks), a 64 Hz sine of
0.375 V played (the drive of the model's unstable orbit at F1 5 N), without a loop and with the
loop of ``rigtools.drivers.realtime.RealTimeLoop`` (10 kHz, 1.04 ms, Kp 2000 V/m, Kd 1 V*s/m,
a 40-harmonic target). Goal: a simulated second well under a few seconds with the loop.

    .venv/bin/python benchmarks/bench_realtime_loop.py [--seconds 3] [--json]
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace

import numpy as np

from rigtools.config import load_rig
from rigtools.drivers.realtime import HarmonicTarget, RealTimeLoop
from rigtools.drivers.simulated import SimulatedRig

FS = 51200.0
FE = 64.0
DRIVE = 0.375


def _seconds_per_second(loop: RealTimeLoop | None, seconds: float) -> float:
    cfg = load_rig()
    p = cfg.to_params()
    p = replace(p, contact=replace(p.contact, gap=5e-4))
    rig = SimulatedRig(
        p, cfg.shaker.to_params(), cfg.test_article.to_params().ideal(), seed=0, max_time_to_zero=None
    )
    rig.set_realtime_loop(loop)
    block = int(0.1 * FS)
    rig.configure(cfg.daq.input_specs(), cfg.daq.output_spec(), FS, block)
    k = 0

    def next_block() -> np.ndarray:
        nonlocal k
        t = (np.arange(k, k + block) + 1) / FS
        k += block
        return DRIVE * np.sin(2 * np.pi * FE * t)

    rig.write(next_block())
    rig.write(next_block())
    rig.start()
    rig.read()  # compiled kernels warm
    rig.write(next_block())
    n = round(seconds * 10)
    t0 = time.perf_counter()
    for _ in range(n):
        rig.read()
        rig.write(next_block())
    wall = time.perf_counter() - t0
    rig.stop()
    return wall / (n * block / FS)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    target = HarmonicTarget(FE, cos=(0.0,) * 40, sin=(3.5e-4,) + (0.0,) * 39)
    result = {
        "no_loop_s_per_s": _seconds_per_second(None, args.seconds),
        "loop_s_per_s": _seconds_per_second(RealTimeLoop(kp=2000.0, kd=1.0, target=target), args.seconds),
    }
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"simulated rig, 51.2 kS/s: {result['no_loop_s_per_s']:.3f} s per simulated second without "
            f"the loop, {result['loop_s_per_s']:.3f} s with the 10 kHz loop"
        )


if __name__ == "__main__":
    main()
