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
    .venv/bin/python docs/rig_search.py --branches           # tip share of modes 2/3 vs (mu, j)
    .venv/bin/python docs/rig_search.py --pairs 300 --seed 6 --out /tmp/pairs.jsonl   # non-identical blades
    .venv/bin/python docs/rig_search.py --pair-best 22fe     # best pair and its robustness probes (~20 s)

Non-identical blades (``--pairs``): the passive blade gets its own length, width and thickness
(``[passive_blade]``) from its (mu_p, j_p), the shared shroud m1 and its 3rd flexural frequency;
the active blade (length, width given) gets the thickness that puts its 2nd flexural at 361.9 Hz
with the sensor (m2 >= 10 g) at the 2nd-mode antinode. ``RANGES`` holds the sampled ranges.

Each evaluation takes about 1 s (one core, after the numba warm-up).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import replace

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from scipy.optimize import brentq

from rigtools.analysis.harmonics import derivative_harmonics, harmonic_amplitudes
from rigtools.config import load_rig
from rigtools.sim.analytical import assumed_modes_blade, exact_flexural_frequencies, tip_mass_lambdas
from rigtools.sim.modal import flexural_frequencies
from rigtools.sim.params import BladeParams, DampingParams, LumpedMass, RigParams
from rigtools.sim.reduction import reduced_system
from rigtools.sim.rig_model import build_rig_model
from rigtools.sim.studies import run_study
from rigtools.sim.vibro_impact import run_harmonic

E, RHO = 200e9, 7850.0
GAPS = [0.3e-3, 0.5e-3, 0.7e-3, 0.9e-3]
FORCES = [5.0, 10.0, 15.0, 20.0, 25.0]
FREQS = [60.0, 62.0, 64.0, 66.0, 68.0, 70.0, 72.0, 74.0, 76.0]

# best rig of the search (seed 5 around seed 11's best; see docs/calibration.md)
CANDIDATE = dict(
    mu=1.8977934707584114,
    j=0.0011740489902218332,
    m1=0.046227648287560666,
    width=0.020,
    f3=1380.0,
    sensor_j=2e-6,
    contact_stiffness=700536.340119412,
    contact_damping=278.6801111010539,
    zeta_low=0.02227189579437258,
    zeta_high=0.007533954829149261,
)


def rayleigh(f_low: float, zeta_low: float, f_high: float, zeta_high: float) -> DampingParams:
    """Rayleigh damping with the given ratios at two frequencies (Hz)."""
    w1, w2 = 2 * np.pi * f_low, 2 * np.pi * f_high
    a, b = np.linalg.solve([[1 / (2 * w1), w1 / 2], [1 / (2 * w2), w2 / 2]], [zeta_low, zeta_high])
    return DampingParams(ratio=None, alpha=float(a), beta=float(b))


def family_rig(
    mu: float,
    j: float,
    m1: float,
    width: float,
    f3: float = 1320.0,
    *,
    sensor_j: float = 2e-7,
    base: RigParams | None = None,
    **contact,
) -> RigParams | None:
    """Two identical clamped steel blades with tip mass ``m1`` (``mu``, ``j`` dimensionless), the
    passive 3rd flexural frequency at ``f3`` and the sensor at the active 2nd-mode antinode with the
    mass giving 361.9 Hz. Contact/damping from ``base`` (default: the shipped rig), contact fields
    overridden by ``contact`` (``stiffness=``, ``damping=``). None if no sensor mass fits."""
    base = base or load_rig().to_params()
    lam3 = tip_mass_lambdas(mu, j, 3)[2]
    c = 2 * np.pi * f3 * np.sqrt(12 * RHO / E) / lam3**2  # t / L^2 from the 3rd root
    length = (m1 / (mu * RHO * width * c)) ** (1 / 3)
    t = c * length**2
    j1 = j * RHO * width * t * length**3
    blade = BladeParams(length, width, t, E, RHO)
    tip = LumpedMass(m1, j1, length)
    s, m2 = 0.53, None
    for _ in range(3):  # sensor mass <-> antinode

        def f2(m, s):
            return exact_flexural_frequencies(blade, [LumpedMass(m, sensor_j, s * length), tip], 2)[1] - 361.9

        try:
            m2 = brentq(f2, 1e-4, 2.0, args=(s,), xtol=1e-8)
        except ValueError:
            return None
        am = assumed_modes_blade(blade, [LumpedMass(m2, sensor_j, s * length), tip], None, 3)
        x = np.linspace(0, length, 1801)
        s = x[np.argmax(np.abs(am.evaluate(x)[0][:, 1]))] / length
    fe_blade = replace(base.active, length=length, width=width, thickness=t, youngs_modulus=E, density=RHO)
    return replace(
        base,
        active=fe_blade,
        passive=fe_blade,
        shroud=tip,
        force_sensor=LumpedMass(m2, sensor_j, s * length),
        contact=replace(base.contact, **contact),
    )


def linear_tip_amplitude(params: RigParams, fe: float = 60.0, force: float = 15.0) -> float:
    """Active shroud amplitude without impacts (m)."""
    run = run_harmonic(reduced_system(params).with_contact(gap=1.0), fe, force, record_periods=2)
    return float(np.ptp(run.outputs["active_tip_displacement"]) / 2)


def _accel(run, tip):
    return derivative_harmonics(
        harmonic_amplitudes(run.outputs[f"{tip}_velocity"], run.sample_rate, run.fe, 30)
    ).amplitude


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
    k2a, k2p, k3 = (round(f / 60.0) for f in (fa[1], fp[1], fp[2]))
    r["k3"] = k3
    r["m6"] = min(_band_margin(_accel(p.run, "active_tip"), 6, 4, 9) if k2a == 6 else -1 for p in gap.points)
    r["m8"] = min(_band_margin(_accel(p.run, "passive_tip"), 8, 4, 9) if k2p == 8 else -1 for p in gap.points)
    r["m3"] = min(_band_margin(_accel(p.run, "passive_tip"), k3, k3 - 4, k3 + 4) for p in gap.points)
    freq = run_study(system, "frequency", FREQS, direction="both")
    up, down = freq.peak_contact_force("up"), freq.peak_contact_force("down")
    r["freq_up_peaks"], r["freq_down_peaks"] = up.round(2).tolist(), down.round(2).tolist()
    stops = up[0] > 0 and up[-1] == 0 and np.all(up[np.argmax(up == 0) :] == 0)
    imp = up[up > 0]
    r["freq"] = float(np.min(-np.diff(imp) / imp[:-1])) if stops and imp.size > 1 else -1.0
    r["hysteresis"] = bool(np.any((up[-2::-1] > 0) != (down > 0)))
    fo = run_study(system, "force", FORCES).peak_contact_force()
    r["force_peaks"] = fo.round(2).tolist()
    r["force"] = float(np.min(np.diff(fo) / np.maximum(fo[1:], 1.0))) if fo[-1] > 50 else -1.0
    r["min_margin"] = min(r[k] for k in ("gap", "freq", "force", "m6", "m8", "m3"))
    return r


def candidate(
    cc_factor: float = 1.0, kc_factor: float = 1.0, zeta_factor: float = 1.0, sensor_j: float | None = None
) -> RigParams:
    """The best rig of the search, optionally perturbed."""
    c = CANDIDATE
    p = family_rig(
        c["mu"],
        c["j"],
        c["m1"],
        c["width"],
        c["f3"],
        sensor_j=c["sensor_j"] if sensor_j is None else sensor_j,
        stiffness=c["contact_stiffness"] * kc_factor,
        damping=c["contact_damping"] * cc_factor,
    )
    f1 = flexural_frequencies(build_rig_model(p).active, 1)[0]  # Rayleigh anchored at the active f1
    return replace(p, damping=rayleigh(f1, c["zeta_low"] * zeta_factor, c["f3"], c["zeta_high"]))


def describe(p: RigParams) -> str:
    b = p.active
    return (
        f"L {b.length * 1e3:.1f} mm, t {b.thickness * 1e3:.3f} mm, w {b.width * 1e3:.0f} mm, "
        f"blade {RHO * b.area * b.length * 1e3:.1f} g, m1 {p.shroud.mass * 1e3:.1f} g, "
        f"J1 {p.shroud.rotary_inertia:.3g} kg m^2, m2 {p.force_sensor.mass * 1e3:.2f} g at "
        f"{p.force_sensor.position * 1e3:.1f} mm, contact {p.contact.stiffness:.3g} N/m {p.contact.damping:.0f} N s/m, "
        f"damping {p.damping}"
    )


def search(n: int, seed: int, out: str) -> None:
    """Random search over the family (ranges from the exploration in docs/calibration.md)."""
    rng = np.random.default_rng(seed)
    with open(out, "a") as fh:
        for _ in range(n):
            q = dict(
                mu=rng.uniform(1.9, 2.8),
                j=rng.uniform(5e-4, 2.2e-3),
                f3=float(rng.choice([1325.0, 1340.0, 1380.0])),
                cc=rng.uniform(100, 300),
                kc=float(rng.choice([7e5, 1e6, 1.5e6])),
                amp=rng.uniform(1.0e-3, 1.25e-3),
                zl=rng.uniform(0.01, 0.03),
                zh=rng.uniform(0.003, 0.01),
                rayleigh=bool(rng.random() < 0.6),
            )
            t0 = time.perf_counter()
            p = family_rig(q["mu"], q["j"], 0.05, 0.02, q["f3"], stiffness=q["kc"], damping=q["cc"])
            if p is None:
                continue
            # amplitude ~ 1 / mass scale at fixed frequencies: rescale m1 to the wanted amplitude
            m1 = 0.05 * linear_tip_amplitude(p) / q["amp"]
            p = family_rig(q["mu"], q["j"], m1, 0.02, q["f3"], stiffness=q["kc"], damping=q["cc"])
            f1 = flexural_frequencies(build_rig_model(p).active, 1)[0]  # Rayleigh anchored at the active f1
            p = replace(
                p,
                damping=rayleigh(f1, q["zl"], q["f3"], q["zh"]) if q["rayleigh"] else DampingParams(q["zl"]),
            )
            r = paper_findings(p) | q | {"m1": m1, "m2": p.force_sensor.mass}
            fh.write(json.dumps(r) + "\n")
            fh.flush()
            print(
                f"min {r['min_margin']:+.3f}  gap {r['gap']:+.3f} freq {r['freq']:+.3f} force {r['force']:+.3f} "
                f"m6 {r['m6']:+.2f} m8 {r['m8']:+.2f} m3 {r['m3']:+.3f}  m2 {p.force_sensor.mass * 1e3:.1f} g "
                f"({time.perf_counter() - t0:.1f} s)",
                flush=True,
            )


# ------------------------------------------------------------------ non-identical blades
# The gap and frequency trends are those of the ACTIVE blade's impact oscillator (fe/f1 ~ 1.7),
# the 8 fe and 22 fe peaks those of the PASSIVE blade (driven only through the contact). So the
# active blade is light (low f1, f2 = 361.9 Hz with the sensor) and the passive blade, with the
# same shroud, has its own geometry ([passive_blade] overrides): mu_p = m1/(rho A_p L_p) and
# j_p = J1/(rho A_p L_p^3) near 2-3 and 0.035 put f3/f2 at 2.75 with f2/f1 > 8 on the branch where
# the shroud rocks in mode 3 (3-5 % of the tip's accelerance, against 0.5 % on the shipped rig).


def passive_blade(mu_p: float, j_p: float, m1: float, width: float, f3: float) -> tuple[BladeParams, float]:
    """Passive blade with tip mass ``m1`` whose 3rd flexural frequency is ``f3``; returns the
    blade and the shroud rotary inertia ``J1 = j_p rho A_p L_p^3``."""
    lam3 = tip_mass_lambdas(mu_p, j_p, 3)[2]
    c = 2 * np.pi * f3 * np.sqrt(12 * RHO / E) / lam3**2
    length = (m1 / (mu_p * RHO * width * c)) ** (1 / 3)
    t = c * length**2
    return BladeParams(length, width, t, E, RHO), j_p * RHO * width * t * length**3


def active_blade(
    m1: float, j1: float, m2: float, width: float, length: float, *, sensor_j: float = 2e-7
) -> tuple[BladeParams, float] | None:
    """Active blade of given length and width (shroud ``m1``, ``j1``; sensor ``m2`` at the
    2nd-mode antinode) whose thickness gives the second flexural frequency 361.9 Hz (exact
    model); returns the blade and the sensor position. None if no thickness fits."""
    s = 0.55
    for _ in range(4):

        def f2(t, s):
            b = BladeParams(length, width, t, E, RHO)
            masses = [LumpedMass(m2, sensor_j, s * length), LumpedMass(m1, j1, length)]
            return exact_flexural_frequencies(b, masses, 2)[1] - 361.9

        try:
            t = brentq(f2, 2e-4, 1e-2, args=(s,), xtol=1e-9)
        except ValueError:
            return None
        b = BladeParams(length, width, t, E, RHO)
        am = assumed_modes_blade(
            b, [LumpedMass(m2, sensor_j, s * length), LumpedMass(m1, j1, length)], None, 3
        )
        x = np.linspace(0, length, 1801)
        s_new = x[np.argmax(np.abs(am.evaluate(x)[0][:, 1]))] / length
        done = abs(s_new - s) < 2e-4
        s = s_new
        if done:
            break
    return b, s * length


def pair_rig(q: dict, base: RigParams | None = None) -> RigParams | None:
    """Rig of non-identical blades from the sample ``q`` (keys: mu_p, j_p, f3, m1, w_p, w_a, L_a,
    m2, zeta, kc, cc; see :func:`pair_search`)."""
    base = base or load_rig().to_params()
    pb, j1 = passive_blade(q["mu_p"], q["j_p"], q["m1"], q["w_p"], q["f3"])
    fit = active_blade(q["m1"], j1, q["m2"], q["w_a"], q["L_a"], sensor_j=q.get("sensor_j", 2e-7))
    if fit is None:
        return None
    ab, x2 = fit
    rig = replace(
        base,
        active=replace(base.active, length=ab.length, width=ab.width, thickness=ab.thickness),
        passive=replace(base.passive, length=pb.length, width=pb.width, thickness=pb.thickness),
        shroud=LumpedMass(q["m1"], j1, ab.length),
        force_sensor=LumpedMass(q["m2"], q.get("sensor_j", 2e-7), x2),
        contact=replace(base.contact, stiffness=q["kc"], damping=q["cc"]),
        damping=DampingParams(q["zeta"]),
    )
    if "zeta_high" in q:  # Rayleigh: zeta at the active f1, zeta_high at the passive f3 (FEM)
        model = build_rig_model(rig)
        f1a, f3p = flexural_frequencies(model.active, 1)[0], flexural_frequencies(model.passive, 3)[2]
        rig = replace(rig, damping=rayleigh(f1a, q["zeta"], f3p, q["zeta_high"]))
    return rig


def describe_pair(p: RigParams) -> str:
    a, b = p.active, p.passive
    return (
        f"active L {a.length * 1e3:.2f} t {a.thickness * 1e3:.3f} w {a.width * 1e3:.1f} mm ({RHO * a.area * a.length * 1e3:.1f} g); "
        f"passive L {b.length * 1e3:.2f} t {b.thickness * 1e3:.3f} w {b.width * 1e3:.1f} mm ({RHO * b.area * b.length * 1e3:.1f} g); "
        f"m1 {p.shroud.mass * 1e3:.2f} g J1 {p.shroud.rotary_inertia:.3g}; m2 {p.force_sensor.mass * 1e3:.2f} g at "
        f"{p.force_sensor.position * 1e3:.2f} mm; contact {p.contact.stiffness:.3g} N/m {p.contact.damping:.3g} N s/m; "
        f"damping {p.damping}"
    )


def perturbed(p: RigParams, what: str, factor: float) -> RigParams:
    """``p`` with one of kc, cc, zeta, m1, m2 scaled by ``factor``."""
    if what == "kc":
        return replace(p, contact=replace(p.contact, stiffness=p.contact.stiffness * factor))
    if what == "cc":
        return replace(p, contact=replace(p.contact, damping=p.contact.damping * factor))
    if what == "zeta":
        d = p.damping
        if d.ratio is not None:
            return replace(p, damping=replace(d, ratio=d.ratio * factor))
        return replace(p, damping=replace(d, alpha=d.alpha * factor, beta=d.beta * factor))
    if what == "m1":
        return replace(p, shroud=replace(p.shroud, mass=p.shroud.mass * factor))
    if what == "m2":
        return replace(p, force_sensor=replace(p.force_sensor, mass=p.force_sensor.mass * factor))
    raise ValueError(what)


def _sig(x: float, n: int = 3) -> float:
    return float(f"{x:.{n - 1}e}")


def rounded(p: RigParams, n: int = 3) -> RigParams:
    """Every rig value that the TOML carries rounded to ``n`` significant digits."""

    def blade(b):
        return replace(b, length=_sig(b.length, n), width=_sig(b.width, n), thickness=_sig(b.thickness, n))

    return replace(
        p,
        active=blade(p.active),
        passive=blade(p.passive),
        shroud=LumpedMass(_sig(p.shroud.mass, n), _sig(p.shroud.rotary_inertia, n), _sig(p.active.length, n)),
        force_sensor=LumpedMass(
            _sig(p.force_sensor.mass, n),
            _sig(p.force_sensor.rotary_inertia, n),
            _sig(p.force_sensor.position, n),
        ),
        contact=replace(
            p.contact, stiffness=_sig(p.contact.stiffness, n), damping=_sig(p.contact.damping, n)
        ),
        damping=replace(
            p.damping,
            **{
                k: _sig(getattr(p.damping, k), n) for k in ("ratio", "alpha", "beta") if getattr(p.damping, k)
            },
        ),
    )


KEYS = ("gap", "freq", "force", "m6", "m8", "m3")


def robustness(p: RigParams, stop_below: float | None = None) -> list[tuple[str, dict]]:
    """Findings of ``p``, of +-5 % on kc, cc, zeta, m1, m2 (one at a time) and of ``p`` rounded to
    3 significant digits. Stops early once a probe's smallest margin is below ``stop_below``."""
    probes = [("nominal", p), ("rounded", rounded(p))]
    probes += [
        (f"{w} {f:+.0%}", perturbed(p, w, 1 + f))
        for w in ("kc", "cc", "zeta", "m1", "m2")
        for f in (-0.05, 0.05)
    ]
    out = []
    for name, q in probes:
        r = paper_findings(q)
        out.append((name, r))
        if stop_below is not None and r["min_margin"] < stop_below:
            break
    return out


# best non-identical pairs of the second search (docs/calibration.md), one per passive 3rd-mode target
PAIR_BEST = {
    "22fe": dict(
        mu_p=1.9424485631937043,
        j_p=0.0023983211462234267,
        f3=1296.024159346868,
        m1=0.05353462531091741,
        w_p=0.03143441839006835,
        w_a=0.011078026185303253,
        L_a=0.09071935689538711,
        m2=0.010844638049898693,
        zeta=0.01648541392808541,
        kc=1745532.5058767996,
        cc=330.49741694719825,
    ),
    "f3high": dict(
        mu_p=1.6652535929995373,
        j_p=0.0012016893530808687,
        f3=1417.1427321529648,
        m1=0.05825719781540899,
        w_p=0.020831250360284572,
        w_a=0.01262620314538841,
        L_a=0.060572744167884336,
        m2=0.01203215200628172,
        zeta=0.026574550803011396,
        kc=913720.823502239,
        cc=195.24616397953335,
        zeta_high=0.02300981383946891,
    ),
}

RANGES = dict(
    mu_p=(1.5, 3.0),
    j_p=(0.0005, 0.003),
    f3=(1300.0, 1350.0),
    m1=(0.035, 0.060),
    w_p=(0.015, 0.040),
    w_a=(0.004, 0.020),
    L_a=(0.04, 0.14),
    m2=(0.010, 0.015),
    zeta=(0.005, 0.03),
    f1a=(28.0, 38.0),
    f1p_max=42.0,
    f2p=(452.0, 508.0),
    rayleigh=0.5,
)
# also searched (docs/calibration.md): f3 = (1365, 1420) with j_p = (0, 0.0015) (3rd mode at 23 fe);
# mu_p = (4.5, 7), j_p = (0.028, 0.04) (the branch where the tip takes part in mode 3 but not mode 2);
# mu_p = (0.4, 0.7), j_p = (0.0008, 0.0022) (heavy passive blade, f1p 50-59 Hz)


def pair_search(n: int, seed: int, out: str) -> None:
    """Random search over non-identical blade pairs; the robust probes run for rigs whose own
    smallest margin is >= 5 %."""
    rng = np.random.default_rng(seed)
    base = load_rig().to_params()
    with open(out, "a") as fh:
        for _ in range(n):
            q = dict(
                mu_p=rng.uniform(*RANGES["mu_p"]),
                j_p=rng.uniform(*RANGES["j_p"]),
                f3=rng.uniform(*RANGES["f3"]),
                m1=rng.uniform(*RANGES["m1"]),
                w_p=rng.uniform(*RANGES["w_p"]),
                w_a=rng.uniform(*RANGES["w_a"]),
                L_a=rng.uniform(*RANGES["L_a"]),
                m2=rng.uniform(*RANGES["m2"]),
                zeta=rng.uniform(*RANGES["zeta"]),
                kc=float(np.exp(rng.uniform(np.log(3e5), np.log(3e6)))),
                cc=rng.uniform(80.0, 400.0),
            )
            t0 = time.perf_counter()
            p = pair_rig(q, base)
            if p is None:
                continue
            model = build_rig_model(p)
            f1a = flexural_frequencies(model.active, 1)[0]
            fp = flexural_frequencies(model.passive, 3)
            if not (
                RANGES["f1a"][0] <= f1a <= RANGES["f1a"][1]
                and fp[0] <= RANGES["f1p_max"]
                and RANGES["f2p"][0] <= fp[1] <= RANGES["f2p"][1]
            ):
                continue
            if (
                rng.random() < RANGES["rayleigh"]
            ):  # Rayleigh: zeta at the active f1, zeta_high at the passive f3
                q["zeta_high"] = rng.uniform(0.005, q["zeta"])
                p = replace(p, damping=rayleigh(f1a, q["zeta"], fp[2], q["zeta_high"]))
            amp = linear_tip_amplitude(p)
            rec = dict(q=q, amp=amp)
            if amp > 0.9e-3:
                r = paper_findings(p)
                rec |= r
                if r["min_margin"] >= 0.05:
                    probes = robustness(p, stop_below=0.05)
                    rec["probes"] = [
                        (name, {k: pr[k] for k in KEYS + ("min_margin",)}) for name, pr in probes
                    ]
                    rec["robust_min"] = min(pr["min_margin"] for _, pr in probes)
                    rec["robust"] = len(probes) == 12 and rec["robust_min"] >= 0.05
            fh.write(json.dumps(rec) + "\n")
            fh.flush()
            if "min_margin" in rec:
                print(
                    f"min {rec['min_margin']:+.3f} "
                    + " ".join(f"{k} {rec[k]:+.3f}" for k in KEYS)
                    + f" amp {amp * 1e3:.2f} mm f {rec['active_hz']} {rec['passive_hz']}"
                    + (
                        f" ROBUST-min {rec['robust_min']:+.3f} ({len(rec['probes'])} probes)"
                        if "probes" in rec
                        else ""
                    )
                    + f" ({time.perf_counter() - t0:.1f} s)",
                    flush=True,
                )
            else:
                print(f"amp {amp * 1e3:.2f} mm - skipped", flush=True)


def tip_shares(mu: float, j: float, n_terms: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Frequency ratios f_k/f_1 and the share of the tip's accelerance at high frequency carried
    by each mode, phi_k(L)^2 / sum phi(L)^2 (mass-normalised exact modes), of a clamped blade with
    tip mass ``mu`` and tip rotary inertia ``j`` (dimensionless; independent of the blade's size)."""
    blade = BladeParams(0.15, 0.03, 0.003, E, RHO)
    mb = RHO * blade.area * blade.length
    am = assumed_modes_blade(
        blade, [LumpedMass(mu * mb, j * mb * blade.length**2, blade.length)], None, n_terms
    )
    f, vec = am.modes()
    phi = am.shape(blade.length) @ vec
    return f / f[0], phi**2 / np.sum(phi**2)


def branch_table() -> None:
    """Where the tip takes part in modes 2 and 3 when f3/f2 is near 22/8 = 2.75."""
    print("   mu      j   f2/f1  f3/f2  tip share mode 2  mode 3")
    for mu in (0.5, 1.0, 2.0, 3.0, 6.0):
        for j in (0.0, 0.001, 0.002, 0.003, 0.004, 0.03, 0.035, 0.04):
            ratio, share = tip_shares(mu, j)
            if 2.55 <= ratio[2] / ratio[1] <= 3.2:
                print(
                    f"{mu:5.1f} {j:6.3f} {ratio[1]:7.2f} {ratio[2] / ratio[1]:6.2f} {100 * share[1]:12.2f} % {100 * share[2]:6.2f} %"
                )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--candidate", action="store_true", help="the best rig found and +-5 %% probes")
    ap.add_argument("--search", type=int, default=0, metavar="N", help="random samples")
    ap.add_argument(
        "--pairs", type=int, default=0, metavar="N", help="random samples of non-identical blade pairs"
    )
    ap.add_argument(
        "--pair-best", choices=sorted(PAIR_BEST), help="a best non-identical pair and its robustness probes"
    )
    ap.add_argument(
        "--branches", action="store_true", help="tip participation of modes 2 and 3 (tip-mass family)"
    )
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--out", default="rig_search.jsonl")
    args = ap.parse_args()
    if args.branches:
        branch_table()
        return
    if args.pair_best:
        p = pair_rig(PAIR_BEST[args.pair_best])
        print(describe_pair(p))
        for name, r in robustness(p):
            print(
                f"{name:10s} min {r['min_margin']:+.3f} " + " ".join(f"{k} {r[k]:+.3f}" for k in KEYS),
                r["active_hz"],
                r["passive_hz"],
                flush=True,
            )
        return
    if args.pairs:
        pair_search(args.pairs, args.seed, args.out)
        return
    if args.search:
        search(args.search, args.seed, args.out)
        return
    if args.candidate:
        probes = [
            {},
            {"sensor_j": 2e-7},
            {"cc_factor": 0.95},
            {"cc_factor": 1.05},
            {"kc_factor": 0.95},
            {"kc_factor": 1.05},
            {"zeta_factor": 0.95},
            {"zeta_factor": 1.05},
        ]
        print(describe(candidate()))
        for probe in probes:
            r = paper_findings(candidate(**probe))
            print(
                probe or "candidate",
                {k: r[k] for k in ("min_margin", "gap", "freq", "force", "m6", "m8", "m3")},
            )
            if not probe:
                print(json.dumps(r))
        return
    p = load_rig().to_params()
    print(describe(p))
    print(json.dumps(paper_findings(p), indent=1))


if __name__ == "__main__":
    main()
