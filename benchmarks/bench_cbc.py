"""The buffered CBC's must-show figures (issue 33) on the simulated rig, each printed with met /
NOT met against the model (tests/rigtools/data/cbc_model_64hz.json, benchmarks/cbc_model_reference.py).

Run: ``PYTHONPATH=. python benchmarks/bench_cbc.py`` -- the command's own sweep
``rig acquire cbc --backend sim --gap "0.5 mm" --fe "64 Hz" --amplitude "0.300 mm:0.360 mm:0.005 mm"
--release "2 s" --inner-loop buffered`` (about 10 s of CPU), then the figures.
"""

from __future__ import annotations

import json
import math
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
TABLE = ROOT / "tests" / "rigtools" / "data" / "cbc_model_64hz.json"
FE = 64.0


def s_curve() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    pts = [
        r
        for r in json.loads(TABLE.read_text())["points"]
        if r["impacts_per_period"] > 0 and r["force_n"] < 6.2
    ]
    pts.sort(key=lambda r: r["amplitude_m"])
    a = np.array([r["amplitude_m"] for r in pts])
    keep = np.concatenate([[True], np.diff(a) > 0])
    f = np.array([r["force_n"] for r in pts])[keep]
    mu = np.array([r["max_multiplier"] for r in pts])[keep]
    return a[keep], f, mu


def branch_by_drive() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The impacting branch through the grazing hairpin as a function of the drive (V): A and F1.
    Past the turn in A (0.3059 mm) the branch is no graph over A, it is one over the drive."""
    pts = [
        r
        for r in json.loads(TABLE.read_text())["points"]
        if r["impacts_per_period"] > 0 and r["drive_v"] > 0.42 and r["amplitude_m"] < 0.345e-3
    ]
    pts.sort(key=lambda r: r["drive_v"])
    u = np.array([r["drive_v"] for r in pts])
    keep = np.concatenate([[True], np.diff(u) > 0])
    a = np.array([r["amplitude_m"] for r in pts])[keep]
    f = np.array([r["force_n"] for r in pts])[keep]
    return u[keep], a, f


def verdict(ok: bool) -> str:
    return "met" if ok else "NOT met"


def main() -> None:
    out = Path(tempfile.mkdtemp()) / "cbc.h5"
    cmd = [sys.executable, "-m", "rigtools.cli", "acquire", "cbc", "--backend", "sim", "--gap", "0.5 mm"]
    cmd += ["--fe", "64 Hz", "--amplitude", "0.300 mm:0.360 mm:0.005 mm", "--release", "2 s"]
    cmd += ["--inner-loop", "buffered"]
    t0 = time.process_time()
    res = subprocess.run(
        [*cmd, "--out", str(out), "--json"], capture_output=True, text=True, cwd=ROOT, check=False
    )
    if res.returncode != 0:
        print(res.stderr)
        raise SystemExit(res.returncode)
    doc = json.loads(res.stdout)
    a, f, mu = s_curve()
    print(f"{len(doc['points'])} points measured, skipped {doc.get('skipped_amplitudes', [])}")
    worst, conv_unstable = 0.0, []
    bu, ba, bf = branch_by_drive()
    for p in doc["points"]:
        model = float(np.interp(p["amplitude_m"], a, f, left=math.nan, right=math.nan))
        if p["parameterisation"] == "arclength":  # past the turn in A: the model at the same drive
            model = float(np.interp(p["drive_amplitude_v"], bu, bf, left=math.nan, right=math.nan))
        err = p["force_fundamental_n"] / model - 1 if math.isfinite(model) else math.nan
        on = p["converged"] and math.isfinite(err) and abs(err) <= 0.02
        if on:
            worst = max(worst, abs(err))
        if on and float(np.interp(p["amplitude_m"], a, mu)) > 1.0:
            conv_unstable.append(p["amplitude_m"])
        print(
            f"  A {p['amplitude_m'] * 1e3:.4f} mm  F1 {p['force_fundamental_n']:.4f} N  model {model:.4f} N  "
            f"({err * 100:+.2f} %)  {'converged' if p['converged'] else 'NOT converged'} in {p['iterations']}  "
            f"drive 2-10 {p['drive_harmonics_ratio'] * 100:.3f} %  drive {p['drive_amplitude_v']:.4f} V"
            + ("  (arclength)" if p["parameterisation"] == "arclength" else "")
        )
    good = [p for p in doc["points"] if p["converged"]]
    print(f"F1 within 2 % of the model at every converged point on the S-curve: worst {worst * 100:.2f} %")
    grid = [p for p in good if p["parameterisation"] == "amplitude"]
    arc = [p for p in good if p["parameterisation"] == "arclength"]
    turn = float(ba.min())
    beyond = [x for x in doc.get("skipped_amplitudes", []) if x < turn]
    print(
        f"grid values converged: {len(grid)} of 13; {len(beyond) + 1} lie beyond the branch's turn in A "
        f"({turn * 1e3:.4f} mm, the model), where no orbit of it is (the first one's A-step fails, then arclength)"
    )
    if arc:
        amps = [p["amplitude_m"] for p in arc]
        i = int(np.argmin(amps))
        passed = 0 < i < len(amps) - 1 or (i == 0 and amps[-1] > amps[0])
        print(
            f"arclength points past the grazing hairpin: {len(arc)} converged, A "
            f"{' -> '.join(f'{x * 1e3:.4f}' for x in amps)} mm, smallest {min(amps) * 1e3:.4f} mm vs the "
            f"model's turn {turn * 1e3:.4f} mm ({(min(amps) / turn - 1) * 100:+.2f} %); the turn passed -> "
            f"{verdict(passed)}"
        )
    if good:
        i = int(np.argmin([p["force_fundamental_n"] for p in good]))
        fm, am, tip = good[i]["force_fundamental_n"], good[i]["amplitude_m"], good[i]["tip_amplitude_m"]
        ok = abs(fm / 4.656 - 1) <= 0.02 and abs(tip - 0.328e-3) <= 0.005e-3
        print(
            f"F1 minimum {fm:.4f} N at A {tip * 1e3:.4f} mm as half the peak-to-peak, the issue's measure "
            f"({am * 1e3:.4f} mm the fundamental's amplitude; 4.656 N at 0.328 +- 0.005 mm) -> {verdict(ok)}"
        )
    print(
        f"converged points where the model's orbit is unstable (|mu| > 1, A >= 0.3462 mm): {len(conv_unstable)} "
        f"({', '.join(f'{x * 1e3:.4f}' for x in conv_unstable)} mm) -> {verdict(len(conv_unstable) >= 3)}"
    )
    ratios = [p["drive_harmonics_ratio"] for p in good]
    iters = [p["iterations"] for p in good]
    print(
        f"drive harmonics 2-10 at most {max(ratios, default=math.nan) * 100:.3f} % -> {verdict(max(ratios, default=1) <= 0.01)}"
    )
    print(f"iterations at most {max(iters, default=0)} -> {verdict(max(iters, default=99) <= 8)}")
    rel = doc.get("release")
    if rel:
        held = [p for p in good if p["amplitude_m"] >= 0.3425e-3]
        amp = max((p["amplitude_m"] for p in held), default=math.nan)
        m = float(np.interp(amp, a, mu))
        expected = FE * math.log(m)
        ok = math.isfinite(rel["growth_rate"]) and abs(rel["growth_rate"] / expected - 1) <= 0.25
        print(
            f"gains 0 at A {amp * 1e3:.4f} mm: leaves at {rel['growth_rate']:.3g} 1/s, model fe ln|mu| = "
            f"{expected:.3g} 1/s (|mu| {m:.4f}) -> {verdict(ok)}"
        )
    child = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(
        f"CPU: the command {child.ru_utime + child.ru_stime:.1f} s, this script {time.process_time() - t0:.1f} s"
    )


if __name__ == "__main__":
    main()
