"""The paper's findings C1-C7, each judged from data by a small evaluator.

Every evaluator takes plain data (lists of the per-point lab quantities of
:func:`rigtools.demo.steps.lab_quantities`, frequency lists, curves) and returns a
:class:`Verdict`: holds or not (``None``: does not apply here) and one sentence saying why, with
the numbers. Impact strength on the rig is the *impact level*: the impulsive (high-passed) part
of the passive shroud's acceleration at the impacts (:func:`rigtools.analysis.impacts.detect_impacts`).
A penalty contact closes with a force jump proportional to the impact velocity, which is what
the impulsive part sees, so it follows the contact force; the peak acceleration instead mixes in
the blade's forced response, which falls above resonance whatever the impacts do. Impacts per
period come from the accelerations too. The model's peak contact force is quoted beside them,
never used for the verdict.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from rigtools.demo.steps import flexural

NO_IMPACT = 0.1  # impacts per period below this: no impacts
STRENGTH = "impulse_level"  # lab measure of impact strength (m/s²)
FEM_AM_TOL = 0.01  # C1: FEM and AM natural frequencies within 1 %
EM_TOL = 0.05  # C1: identified (EM) frequencies within 5 % of the FEM, and lower
HARMONIC_TOL = 0.05  # C2: median |ln(FEM/AM)| of the linear curves
WAVE_TOL = 0.15  # C3: relative difference of the harmonic spectra, FEM vs AM
NEAR_MODE = 0.1  # C7: 6 fe within 10 % of the active 2nd flexural frequency

CLAIMS = {
    "C1": "FEM ≈ AM ≈ EM natural frequencies, EM a little lower",
    "C2": "FEM ≈ AM harmonic (linear) response",
    "C3": "FEM ≈ AM vibro-impact waveforms and spectra",
    "C4": "impacts weaken as the gap grows",
    "C5": "impacts strengthen as F0 grows",
    "C6": "impacts weaken and vanish as fe rises",
    "C7": "super-harmonic peaks at 6fe (active), 8fe and 22fe (passive); the active one strongest, near its 2nd flexural frequency",
}


@dataclass
class Verdict:
    """``holds``: True, False, or None (does not apply at this point); ``why``: one sentence."""

    holds: bool | None
    why: str


@dataclass
class Finding:
    """One finding judged at the paper's point and at the equivalent point."""

    id: str
    claim: str
    verdicts: dict[str, Verdict] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {
            "id": self.id,
            "claim": self.claim,
            "verdicts": {k: asdict(v) for k, v in self.verdicts.items()},
        }


def mark(holds: bool | None) -> str:
    """✓, ✗ or – for a verdict."""
    return {True: "✓", False: "✗", None: "–"}[holds]


def _kendall(x, y) -> float:
    from scipy.stats import kendalltau

    if len(x) < 2 or np.allclose(y, y[0]):
        return 0.0
    return float(kendalltau(x, y).statistic)


def _series(points: list[dict]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    pts = sorted(points, key=lambda p: p["value"])
    return (
        np.array([p["value"] for p in pts]),
        np.array([p[STRENGTH] if p["impacts_per_period"] >= NO_IMPACT else 0.0 for p in pts]),
        np.array([p["impacts_per_period"] for p in pts]),
    )


def _fmt(values, unit: str, scale: float = 1.0, digits: int = 3) -> str:
    return " / ".join(f"{v * scale:.{digits}g}" for v in values) + f" {unit}"


def _contact(model_points: list[dict] | None) -> str:
    if not model_points:
        return ""
    pts = sorted(model_points, key=lambda p: p["value"])
    return f" (FEM peak contact force {_fmt([p['peak_contact_force_n'] for p in pts], 'N')})"


def em_to_fem_ratios(fem_active: list[float], em_active: list[float]) -> list[float]:
    """Each identified (EM) active frequency over the FEM flexural frequency nearest to it."""
    return [e / min(fem_active, key=lambda f: abs(np.log(f / e))) for e in em_active]


def c1_frequencies(fem: dict, am: dict, em_active: list[float]) -> Verdict:
    """FEM vs AM flexural frequencies (both blades, first three) and the identified EM ones of the
    active blade (each paired with the nearest FEM mode)."""
    worst_am = 0.0
    for blade in ("active", "passive"):
        for f, a in zip(fem[blade][:3], am[blade][:3], strict=False):  # the shorter list decides
            worst_am = max(worst_am, abs(f / a - 1))
    if not em_active:
        return Verdict(False, "no mode identified in the FRF test of the simulated rig")
    rel = [r - 1 for r in em_to_fem_ratios(fem["active"], em_active)]
    lower = all(r < 0 for r in rel)
    close = all(abs(r) <= EM_TOL for r in rel)
    holds = worst_am <= FEM_AM_TOL and lower and close
    why = (
        f"FEM and AM differ by at most {worst_am * 100:.2f} %; the rig's identified active modes are "
        f"{', '.join(f'{r * 100:+.1f} %' for r in rel)} from the FEM"
        + ("" if lower else " (not all lower)")
        + ("" if close else f" (beyond {EM_TOL * 100:g} %)")
    )
    return Verdict(holds, why)


def c2_harmonic(fem: dict, am: dict) -> Verdict:
    """Median ``|ln(FEM/AM)|`` of the linear shroud acceleration curves."""
    worst = 0.0
    for loc, fem_curve in fem.items():
        r = np.abs(np.log(np.asarray(fem_curve) / np.asarray(am[loc])))
        worst = max(worst, float(np.median(r)))
    return Verdict(
        worst <= HARMONIC_TOL,
        f"the shroud curves differ by a median {worst * 100:.2f} % (limit {HARMONIC_TOL * 100:g} %)",
    )


def spectrum_difference(a: dict, b: dict) -> float:
    """Relative L2 difference of the shroud acceleration harmonics of two runs."""
    num = den = 0.0
    for ch in ("active_shroud_accel", "passive_shroud_accel"):
        x, y = np.asarray(a["harmonics"][ch]), np.asarray(b["harmonics"][ch])
        n = min(x.size, y.size)
        num += float(np.sum((x[:n] - y[:n]) ** 2))
        den += float(np.sum(x[:n] ** 2))
    return float(np.sqrt(num / den)) if den > 0 else 0.0


def c3_waveforms(fem: dict, am: dict) -> Verdict:
    """FEM vs AM vibro-impact run at one point: spectra and impacts per period."""
    d = spectrum_difference(fem, am)
    same = abs(fem["impacts_per_period"] - am["impacts_per_period"]) < 0.25
    return Verdict(
        d <= WAVE_TOL and same,
        f"shroud spectra differ by {d * 100:.1f} % (limit {WAVE_TOL * 100:g} %), impacts per period "
        f"{fem['impacts_per_period']:.2f} (FEM) and {am['impacts_per_period']:.2f} (AM), peak contact force "
        f"{fem['peak_contact_force_n']:.3g} and {am['peak_contact_force_n']:.3g} N",
    )


def _trend(points, model_points, sign: int, what: str, unit: str, scale: float) -> Verdict:
    v, s, n = _series(points)
    if not np.any(n >= NO_IMPACT):
        return Verdict(
            False,
            f"no impacts at any {what} ({_fmt(v, unit, scale)}): nothing to "
            + ("weaken" if sign < 0 else "strengthen"),
        )
    tau = _kendall(v, s)
    holds = bool(sign * tau > 0 and sign * (s[-1] - s[0]) > 0)
    word = "falls" if tau < 0 else "grows" if tau > 0 else "stays"
    return Verdict(
        holds,
        f"impact level {word} over {what} {_fmt(v, unit, scale)}: "
        f"{_fmt(s, 'm/s²')}, impacts/period {_fmt(n, '', digits=2).strip()}" + _contact(model_points),
    )


def c4_gap(points: list[dict], model_points: list[dict] | None = None) -> Verdict:
    """Impacts weaken as the gap grows (rig study points)."""
    return _trend(points, model_points, -1, "gap", "mm", 1e3)


def c5_force(points: list[dict], model_points: list[dict] | None = None) -> Verdict:
    """Impacts strengthen as F0 grows."""
    return _trend(points, model_points, +1, "F0", "N", 1.0)


def c6_frequency(points: list[dict], model_points: list[dict] | None = None) -> Verdict:
    """Impacts weaken while they last and vanish by the top of the sweep (up)."""
    v, s, n = _series(points)
    if not np.any(n >= NO_IMPACT):
        return Verdict(False, f"no impacts at any fe ({_fmt(v, 'Hz')}): nothing to weaken")
    hit = n >= NO_IMPACT
    last = int(np.flatnonzero(hit)[-1])
    vanish = not hit[-1]
    tau = _kendall(v[: last + 1], s[: last + 1]) if last >= 1 else 0.0
    weaken = tau < 0 and s[last] < s[0]
    word = "fall" if tau < 0 else "grow" if tau > 0 else "stay"
    tail = f"and vanish above {v[last]:.4g} Hz" if vanish else f"and do not vanish by {v[-1]:.4g} Hz"
    return Verdict(
        bool(weaken and vanish),
        f"impact levels {word} over {_fmt(v[: last + 1], 'Hz', digits=4)} "
        f"({_fmt(s[: last + 1], 'm/s²')}) {tail}" + _contact(model_points),
    )


def c7_harmonics(q: dict, fe: float, active_f2: float, coupled_f2: float | None = None) -> Verdict:
    """Super-harmonics of one steady record: the largest active-shroud harmonic in 4-9 fe is 6 fe,
    the largest passive ones in 4-9 fe and 18-26 fe are 8 fe and 22 fe, the active 6 fe is the
    strongest of the three and 6 fe lies within 10 % of the active 2nd flexural frequency."""
    a = np.asarray(q["harmonics"]["active_shroud_accel"])
    p = np.asarray(q["harmonics"]["passive_shroud_accel"])
    if q["impacts_per_period"] < NO_IMPACT:
        return Verdict(False, "no impacts at this point: no super-harmonics")
    ka = 4 + int(np.argmax(a[3:9]))
    kp = 4 + int(np.argmax(p[3:9]))
    kp2 = 18 + int(np.argmax(p[17:26])) if p.size >= 26 else None
    strongest = a[5] > p[7] and (p.size < 22 or a[5] > p[21])
    near = abs(6 * fe / active_f2 - 1) <= NEAR_MODE
    holds = ka == 6 and kp == 8 and kp2 == 22 and strongest and near
    parts = [
        f"largest active harmonic in 4-9 fe is {ka} fe",
        f"passive {kp} fe and {kp2} fe (in 18-26 fe)",
        f"active 6 fe {a[5]:.3g} m/s² vs passive 8 fe {p[7]:.3g} m/s²",
        f"6 fe = {6 * fe:.0f} Hz is {(6 * fe / active_f2 - 1) * 100:+.0f} % from the active f2 {active_f2:.0f} Hz",
    ]
    if coupled_f2 is not None and ka != 6 and abs(coupled_f2 / fe - ka) < 0.5:
        parts.append(
            f"the shaker armature riding on the force sensor puts the coupled active f2 at "
            f"{coupled_f2:.0f} Hz = {coupled_f2 / fe:.1f} fe, next to {ka} fe"
        )
    return Verdict(bool(holds), "; ".join(parts))


def evaluate(data: dict) -> list[Finding]:
    """All findings from the demo's data (see :func:`rigtools.demo.run.run_demo`)."""
    m = data["modal"]
    fem = {b: flexural(m["fem"][b]) for b in ("active", "passive")}
    am = {b: flexural(m["am"][b]) for b in ("active", "passive")}
    em = [x["frequency_hz"] for x in m["em"]["active"]]
    na = Verdict(None, "a linear property: the same at every operating point")
    out = [
        Finding("C1", CLAIMS["C1"], {"paper": c1_frequencies(fem, am, em), "equivalent": na}),
        Finding(
            "C2",
            CLAIMS["C2"],
            {"paper": c2_harmonic(data["harmonic"]["fem"], data["harmonic"]["am"]), "equivalent": na},
        ),
    ]
    f2 = em[1] if len(em) > 1 else fem["active"][1]
    c3, c7 = {}, {}
    for key, d in data["dwell"].items():
        c3[key] = c3_waveforms(d["fem"], d["am"])
        v = c7_harmonics(d["em"], d["fe"], f2, data["info"].get("coupled_f2_hz"))
        fem_v = c7_harmonics(d["fem"], d["fe"], fem["active"][1])
        v.why += (
            f" (FEM: {'holds' if fem_v.holds else 'does not hold'}: {'; '.join(fem_v.why.split('; ')[:2])})"
        )
        c7[key] = v
    out.append(Finding("C3", CLAIMS["C3"], c3))
    for fid, kind, fn in (
        ("C4", "gap", c4_gap),
        ("C5", "force", c5_force),
        ("C6", "frequency", c6_frequency),
    ):
        verdicts = {}
        for key in data["dwell"]:
            s = data["studies"].get((kind, key))
            if s is not None:
                verdicts[key] = fn(s["rig"]["points"], s["fem"]["points"])
        out.append(Finding(fid, CLAIMS[fid], verdicts))
    out.append(Finding("C7", CLAIMS["C7"], c7))
    return out
