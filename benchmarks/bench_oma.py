"""Operational modes of the public TDMS records beside the field's chain, and their cost.

For the running wind turbine (``../shared/data/owi-turbine-tdms``, 0.1-2.5 Hz) and the footbridge
(``owi-footbridge-tdms``, 3-10 Hz), imported with ``rig import tdms``: the modes and harmonics of
``rigtools.analysis.oma.operational_modes`` (what ``rig analyze --band`` reports), and beside them
pyOMA2's SSI-cov with its automated clustering (``tests/rigtools/pyoma_reference.py``: block rows
20, 30 and 40) with the range of the poles its clusters hold (its spread). Each of our modes is
marked ``in`` or ``OUT`` of that spread. The wall time of ours and of the reference chain (the
baseline, measured in the same run) and their ratio are printed last.

    .venv/bin/python benchmarks/bench_oma.py          # ~30 s; needs pyOMA2 (pip install .[oma])
    .venv/bin/python benchmarks/bench_oma.py --json
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
sys.path.insert(0, str(ROOT / "tests" / "rigtools"))

RECORDS = {
    # name: (file, band, decimation of the reference, windows of the modes of interest)
    "turbine": (
        DATA / "owi-turbine-tdms" / "good_tdms_1.tdms",
        (0.1, 2.5),
        3,
        {"first tower mode": (0.3, 0.45), "3P (0.803 Hz)": (0.79, 0.82)},
    ),
    "footbridge": (
        DATA / "owi-footbridge-tdms" / "good_tdms_2.tdms",
        (3.0, 10.0),
        5,
        {"mode 1": (5.0, 6.4), "mode 2": (6.4, 7.6)},
    ),
}


def _load(src: Path, folder: Path) -> tuple[list[str], np.ndarray, float]:
    from rigtools.cli import main
    from rigtools.recording import open_recording

    out = folder / f"{src.stem}.h5"
    if main(["import", "tdms", str(src), str(out)]) != 0:
        raise SystemExit(f"rig import tdms {src} failed")
    with open_recording(out) as rec:
        p = rec.points[0]
        names = list(p.channels)
        return names, np.vstack([np.asarray(p.channels[c][:], float) for c in names]), float(p.sample_rate)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    from pyoma_reference import reference_clusters, reference_mode

    from rigtools.analysis.oma import operational_modes

    rows, times = [], {"ours": 0.0, "pyOMA2 chain": 0.0}
    with tempfile.TemporaryDirectory() as tmp:
        for name, (src, band, q, windows) in RECORDS.items():
            if not src.is_file():
                print(f"{src} absent: skipped")
                continue
            names, y, fs = _load(src, Path(tmp))
            t = time.perf_counter()
            ours = operational_modes(y, fs, band=band, channels=names)
            times["ours"] += time.perf_counter() - t
            t = time.perf_counter()
            runs = reference_clusters(y, fs, q=q, band=band)
            times["pyOMA2 chain"] += time.perf_counter() - t
            for what, (lo, hi) in windows.items():
                ref = reference_mode(runs, (lo, hi))
                mine = [m for m in ours.modes if lo <= m.frequency_hz <= hi]
                tones = [h for h in ours.harmonics if lo <= h.frequency_hz <= hi]
                rows.append(
                    {
                        "record": name,
                        "what": what,
                        "ours_modes": [
                            {
                                "frequency_hz": m.frequency_hz,
                                "spread_hz": m.frequency_spread_hz,
                                "damping_ratio": m.damping_ratio,
                                "in_reference_spread": bool(ref is not None and ref.holds(m.frequency_hz)),
                            }
                            for m in mine
                        ],
                        "ours_harmonics": [
                            {"frequency_hz": h.frequency_hz, "reason": h.reason} for h in tones
                        ],
                        "reference": None
                        if ref is None
                        else {
                            "frequency_hz": ref.frequency_hz.tolist(),
                            "damping_ratio": ref.damping_ratio.tolist(),
                            "spread_hz": list(ref.spread_hz),
                        },
                    }
                )
    ratio = times["ours"] / times["pyOMA2 chain"] if times["pyOMA2 chain"] else float("nan")
    if args.json:
        print(json.dumps({"rows": rows, "seconds": times, "ratio": ratio}, indent=1))
        return 0
    for r in rows:
        ref = r["reference"]
        print(f"{r['record']}, {r['what']}:")
        for m in r["ours_modes"]:
            mark = "in" if m["in_reference_spread"] else "OUT"
            print(
                f"  ours: mode {m['frequency_hz']:.4f} Hz +- {m['spread_hz']:.4f}, "
                f"damping {100 * m['damping_ratio']:.2f} %  ({mark} the reference's spread)"
            )
        for h in r["ours_harmonics"]:
            print(f"  ours: harmonic {h['frequency_hz']:.4f} Hz, not a mode: {h['reason']}")
        if ref is None:
            print("  pyOMA2 chain: nothing there")
        else:
            est = ", ".join(
                f"{f:.4f} Hz ({100 * z:.2f} %)"
                for f, z in zip(ref["frequency_hz"], ref["damping_ratio"], strict=True)
            )
            print(f"  pyOMA2 chain: {est}; spread {ref['spread_hz'][0]:.4f}-{ref['spread_hz'][1]:.4f} Hz")
    print(
        f"wall time: ours {times['ours']:.2f} s, pyOMA2 chain (baseline) {times['pyOMA2 chain']:.2f} s, "
        f"ratio {ratio:.2f}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
