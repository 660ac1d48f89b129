"""Search for a default rig on which the paper's vibro-impact findings hold (docs/calibration.md).

The findings are evaluated exactly as ``tests/sim/test_studies.py`` asserts them, and reported
as *margins* (> 0: the test passes, the number says by how much):

* ``gap``   smallest relative fall of the peak contact force between successive gaps
  (0.3, 0.5, 0.7, 0.9 mm; F0 = 15 N, fe = 60 Hz, each point from rest);
* ``freq``  smallest relative fall between successive impacting points of the up sweep
  60, 62, ... 76 Hz (gap 0.7 mm, F0 = 15 N, state carried), -1 unless the impacts stop inside;
* ``force`` smallest relative growth over F0 = 5 ... 25 N (gap 0.7 mm, fe = 60 Hz), -1 unless
  the last peak exceeds 50 N;
* ``m6``, ``m8``, ``m3`` how much the harmonic nearest the active 2nd, passive 2nd and passive
  3rd flexural frequency exceeds the largest other one in its band (4-9 fe; k3-4 ... k3+4),
  worst gap.

Rigs are generated in the family of two identical clamped steel blades with a tip mass: the
dimensionless tip mass ``mu = m1/(rho A L)`` and rotary inertia ``j = J1/(rho A L^3)`` set the
passive frequency ratios and how much the tip moves in each mode; the passive 3rd flexural
frequency ``f3`` and the shroud mass ``m1`` then fix L and t (width given); the force sensor mass
m2 is solved at the antinode of the active 2nd mode for 361.9 Hz (exact Euler-Bernoulli model).

    .venv/bin/python docs/rig_search.py                      # the shipped default rig
    .venv/bin/python docs/rig_search.py --candidate          # the best rig found, +-5 % probes
    .venv/bin/python docs/rig_search.py --search 300 --seed 11 --out /tmp/search.jsonl

Each evaluation takes about 1 s (one core, after the numba warm-up).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import replace

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.optimize import brentq  # noqa: E402

from analysis.harmonics import derivative_harmonics, harmonic_amplitudes  # noqa: E402
from rigtools.config import load_rig  # noqa: E402
from sim.analytical import assumed_modes_blade, exact_flexural_frequencies, tip_mass_lambdas  # noqa: E402
from sim.modal import flexural_frequencies  # noqa: E402
from sim.params import BladeParams, DampingParams, LumpedMass, RigParams  # noqa: E402
from sim.reduction import reduced_system  # noqa: E402
from sim.rig_model import build_rig_model  # noqa: E402
from sim.studies import run_study  # noqa: E402
from sim.vibro_impact import run_harmonic  # noqa: E402

E, RHO = 200e9, 7850.0
GAPS = [0.3e-3, 0.5e-3, 0.7e-3, 0.9e-3]
FORCES = [5.0, 10.0, 15.0, 20.0, 25.0]
FREQS = [60.0, 62.0, 64.0, 66.0, 68.0, 70.0, 72.0, 74.0, 76.0]

# best rig of the search (seed 5 around seed 11's best; see docs/calibration.md)
CANDIDATE = dict(mu=1.8977934707584114, j=0.0011740489902218332, m1=0.046227648287560666, width=0.020,
                 f3=1380.0, sensor_j=2e-6, contact_stiffness=700536.340119412, contact_damping=278.6801111010539,
                 zeta_low=0.02227189579437258, zeta_high=0.007533954829149261)


def rayleigh(f_low: float, zeta_low: float, f_high: float, zeta_high: float) -> DampingParams:
    """Rayleigh damping with the given ratios at two frequencies (Hz)."""
    w1, w2 = 2 * np.pi * f_low, 2 * np.pi * f_high
    a, b = np.linalg.solve([[1 / (2 * w1), w1 / 2], [1 / (2 * w2), w2 / 2]], [zeta_low, zeta_high])
    return DampingParams(ratio=None, alpha=float(a), beta=float(b))


def family_rig(mu: float, j: float, m1: float, width: float, f3: float = 1320.0, *,
               sensor_j: float = 2e-7, base: RigParams | None = None, **contact) -> RigParams | None:
    """Two identical clamped steel blades with tip mass ``m1`` (``mu``, ``j`` dimensionless), the
    passive 3rd flexural frequency at ``f3`` and the sensor at the active 2nd-mode antinode with the
    mass giving 361.9 Hz. Contact/damping from ``base`` (default: the shipped rig), contact fields
    overridden by ``contact`` (``stiffness=``, ``damping=``). None if no sensor mass fits."""
    base = base or load_rig().to_params()
    lam3 = tip_mass_lambdas(mu, j, 3)[2]
    c = 2 * np.pi * f3 * np.sqrt(12 * RHO / E) / lam3**2        # t / L^2 from the 3rd root
    length = (m1 / (mu * RHO * width * c)) ** (1 / 3)
    t = c * length**2
    j1 = j * RHO * width * t * length**3
    blade = BladeParams(length, width, t, E, RHO)
    tip = LumpedMass(m1, j1, length)
    s, m2 = 0.53, None
    for _ in range(3):                                        # sensor mass <-> antinode
        def f2(m):
            return exact_flexural_frequencies(blade, [LumpedMass(m, sensor_j, s * length), tip], 2)[1] - 361.9
        try:
            m2 = brentq(f2, 1e-4, 2.0, xtol=1e-8)
        except ValueError:
            return None
        am = assumed_modes_blade(blade, [LumpedMass(m2, sensor_j, s * length), tip], None, 3)
        x = np.linspace(0, length, 1801)
        s = x[np.argmax(np.abs(am.evaluate(x)[0][:, 1]))] / length
    fe_blade = replace(base.active, length=length, width=width, thickness=t, youngs_modulus=E, density=RHO)
    return replace(base, active=fe_blade, passive=fe_blade, shroud=tip,
                   force_sensor=LumpedMass(m2, sensor_j, s * length), contact=replace(base.contact, **contact))


def linear_tip_amplitude(params: RigParams, fe: float = 60.0, force: float = 15.0) -> float:
    """Active shroud amplitude without impacts (m)."""
    run = run_harmonic(reduced_system(params).with_contact(gap=1.0), fe, force, record_periods=2)
    return float(np.ptp(run.outputs["active_tip_displacement"]) / 2)


def _accel(run, tip):
    return derivative_harmonics(harmonic_amplitudes(run.outputs[f"{tip}_velocity"], run.sample_rate, run.fe, 30)).amplitude


def _band_margin(h, k, lo, hi):
    return float(h[k - 1] / max(h[i - 1] for i in range(lo, hi + 1) if i != k) - 1)


def paper_findings(params: RigParams) -> dict:
    """Frequencies, study results and margins of the paper's findings (see module docstring)."""
    model = build_rig_model(params)
    fa, fp = flexural_frequencies(model.active, 3), flexural_frequencies(model.passive, 3)
    system = reduced_system(params, rig_model=model)
    r = {"active_hz": fa.round(2).tolist(), "passive_hz": fp.round(2).tolist()}
    gap = run_study(system, "gap", GAPS, carry_state=False)
    pk = gap.peak_contact_force()
    r["gap_peaks"] = pk.round(2).tolist()
    r["gap"] = float(np.min(-np.diff(pk) / pk[:-1])) if pk[0] > 0 else -1.0
    k2a, k2p, k3 = (int(round(f / 60.0)) for f in (fa[1], fp[1], fp[2]))
    r["k3"] = k3
    r["m6"] = min(_band_margin(_accel(p.run, "active_tip"), 6, 4, 9) if k2a == 6 else -1 for p in gap.points)
    r["m8"] = min(_band_margin(_accel(p.run, "passive_tip"), 8, 4, 9) if k2p == 8 else -1 for p in gap.points)
    r["m3"] = min(_band_margin(_accel(p.run, "passive_tip"), k3, k3 - 4, k3 + 4) for p in gap.points)
    freq = run_study(system, "frequency", FREQS, direction="both")
    up, down = freq.peak_contact_force("up"), freq.peak_contact_force("down")
    r["freq_up_peaks"], r["freq_down_peaks"] = up.round(2).tolist(), down.round(2).tolist()
    stops = up[0] > 0 and up[-1] == 0 and np.all(up[np.argmax(up == 0):] == 0)
    imp = up[up > 0]
    r["freq"] = float(np.min(-np.diff(imp) / imp[:-1])) if stops and imp.size > 1 else -1.0
    r["hysteresis"] = bool(np.any((up[-2::-1] > 0) != (down > 0)))
    fo = run_study(system, "force", FORCES).peak_contact_force()
    r["force_peaks"] = fo.round(2).tolist()
    r["force"] = float(np.min(np.diff(fo) / np.maximum(fo[1:], 1.0))) if fo[-1] > 50 else -1.0
    r["min_margin"] = min(r[k] for k in ("gap", "freq", "force", "m6", "m8", "m3"))
    return r


def candidate(cc_factor: float = 1.0, kc_factor: float = 1.0, zeta_factor: float = 1.0,
              sensor_j: float | None = None) -> RigParams:
    """The best rig of the search, optionally perturbed."""
    c = CANDIDATE
    p = family_rig(c["mu"], c["j"], c["m1"], c["width"], c["f3"],
                   sensor_j=c["sensor_j"] if sensor_j is None else sensor_j,
                   stiffness=c["contact_stiffness"] * kc_factor, damping=c["contact_damping"] * cc_factor)
    f1 = flexural_frequencies(build_rig_model(p).active, 1)[0]   # Rayleigh anchored at the active f1
    return replace(p, damping=rayleigh(f1, c["zeta_low"] * zeta_factor, c["f3"], c["zeta_high"]))


def describe(p: RigParams) -> str:
    b = p.active
    return (f"L {b.length * 1e3:.1f} mm, t {b.thickness * 1e3:.3f} mm, w {b.width * 1e3:.0f} mm, "
            f"blade {RHO * b.area * b.length * 1e3:.1f} g, m1 {p.shroud.mass * 1e3:.1f} g, "
            f"J1 {p.shroud.rotary_inertia:.3g} kg m^2, m2 {p.force_sensor.mass * 1e3:.2f} g at "
            f"{p.force_sensor.position * 1e3:.1f} mm, contact {p.contact.stiffness:.3g} N/m {p.contact.damping:.0f} N s/m, "
            f"damping {p.damping}")


def search(n: int, seed: int, out: str) -> None:
    """Random search over the family (ranges from the exploration in docs/calibration.md)."""
    rng = np.random.default_rng(seed)
    with open(out, "a") as fh:
        for _ in range(n):
            q = dict(mu=rng.uniform(1.9, 2.8), j=rng.uniform(5e-4, 2.2e-3), f3=float(rng.choice([1325.0, 1340.0, 1380.0])),
                     cc=rng.uniform(100, 300), kc=float(rng.choice([7e5, 1e6, 1.5e6])), amp=rng.uniform(1.0e-3, 1.25e-3),
                     zl=rng.uniform(0.01, 0.03), zh=rng.uniform(0.003, 0.01), rayleigh=bool(rng.random() < 0.6))
            t0 = time.perf_counter()
            p = family_rig(q["mu"], q["j"], 0.05, 0.02, q["f3"], stiffness=q["kc"], damping=q["cc"])
            if p is None:
                continue
            # amplitude ~ 1 / mass scale at fixed frequencies: rescale m1 to the wanted amplitude
            m1 = 0.05 * linear_tip_amplitude(p) / q["amp"]
            p = family_rig(q["mu"], q["j"], m1, 0.02, q["f3"], stiffness=q["kc"], damping=q["cc"])
            f1 = flexural_frequencies(build_rig_model(p).active, 1)[0]   # Rayleigh anchored at the active f1
            p = replace(p, damping=rayleigh(f1, q["zl"], q["f3"], q["zh"]) if q["rayleigh"] else DampingParams(q["zl"]))
            r = paper_findings(p) | q | {"m1": m1, "m2": p.force_sensor.mass}
            fh.write(json.dumps(r) + "\n")
            fh.flush()
            print(f"min {r['min_margin']:+.3f}  gap {r['gap']:+.3f} freq {r['freq']:+.3f} force {r['force']:+.3f} "
                  f"m6 {r['m6']:+.2f} m8 {r['m8']:+.2f} m3 {r['m3']:+.3f}  m2 {p.force_sensor.mass * 1e3:.1f} g "
                  f"({time.perf_counter() - t0:.1f} s)", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--candidate", action="store_true", help="the best rig found and +-5 %% probes")
    ap.add_argument("--search", type=int, default=0, metavar="N", help="random samples")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--out", default="rig_search.jsonl")
    args = ap.parse_args()
    if args.search:
        search(args.search, args.seed, args.out)
        return
    if args.candidate:
        probes = [{}, {"sensor_j": 2e-7}, {"cc_factor": 0.95}, {"cc_factor": 1.05}, {"kc_factor": 0.95},
                  {"kc_factor": 1.05}, {"zeta_factor": 0.95}, {"zeta_factor": 1.05}]
        print(describe(candidate()))
        for probe in probes:
            r = paper_findings(candidate(**probe))
            print(probe or "candidate", {k: r[k] for k in ("min_margin", "gap", "freq", "force", "m6", "m8", "m3")})
            if not probe:
                print(json.dumps(r))
        return
    p = load_rig().to_params()
    print(describe(p))
    print(json.dumps(paper_findings(p), indent=1))


if __name__ == "__main__":
    main()
