"""Phase-locked loop, control-based continuation and a stepped sine over the model's branches
==========================================================================================

The figure a lab shows of a nonlinear test, on the simulated rig at gap 0.5 mm with the force
fundamental F1 at 5 N. A stepped sine up and down follows the stable orbits and jumps where they
end; a phase-locked loop (PLL) holds the response at a set phase lag to the force; control-based
continuation (CBC) holds the response at a set amplitude A at 64 Hz and measures the force it
takes, through the fold and onto the orbits the stepped sine cannot hold (unstable without the
controller). Left: A (the active shroud's displacement fundamental) against fe, over the model's
orbits continued in frequency; right: F1 against A at 64 Hz, the S-curve, over the model's orbits
continued in force. Stable solid, unstable dashed. On the NI rig, give ``backend="nidaq"`` and
``rig="lab.toml"`` (the buffered CBC holds only the mildly unstable orbits there).
"""

# %%
# The measurements: a stepped sine up and down, four PLL points at 5 N (phase of A to F1: at
# -152 deg and beyond the orbits are unstable at a fixed drive; the simulated rig runs the PLL per
# sample, as a real-time target would) and the CBC at 64 Hz over A from 0.320 to 0.350 mm.
import tempfile
from pathlib import Path

import numpy as np

import rigtools

folder = Path(tempfile.mkdtemp())
sweep = rigtools.stepped_sine(
    "56 Hz:67 Hz:1 Hz", "5 N", folder / "sweep.h5", gap="0.5 mm", direction="both", backend="sim"
)
pll = rigtools.phase_locked_loop(
    "5 N", folder / "pll.h5", phases="-90 deg,-140 deg,-152 deg,-165 deg", gap="0.5 mm", backend="sim"
)
cbc = rigtools.control_based_continuation(
    "64 Hz", "0.320 mm:0.350 mm:0.005 mm", folder / "cbc.h5", gap="0.5 mm", backend="sim"
)
for name, run in (("stepped sine", sweep), ("PLL", pll), ("CBC", cbc)):
    print(f"{name}: {run.status}, {len(run.points)} points")

# %%
# The model's orbits: continued in frequency at F1 = 5 N, and in force at 64 Hz from 12 N down
# (where the only orbit impacts) through the fold, the unstable orbits and grazing.
in_fe = rigtools.continuation("fe", "51 Hz", "67 Hz", force="5 N", gap="0.5 mm", model="rig", switch=False)
in_force = rigtools.continuation("force", "12 N", "4 N", fe="64 Hz", gap="0.5 mm", model="rig", switch=False)


def amplitude_mm(branch, fe):
    """A of each orbit, mm: its acceleration fundamental over (2 pi fe)^2."""
    return branch.measure("accel_harmonics_active")[:, 0] / (2 * np.pi * fe) ** 2 * 1e3


fold = min((p for b in in_force for p in b.labelled("fold")), key=lambda p: p.value)
print(f"model at 64 Hz: F1 minimum (fold) {fold.value:.3f} N")
for b in in_fe:
    for p in b.labelled():
        print(f"model at 5 N: {', '.join(p.labels)} at {p.value:.2f} Hz")

# %%
# The numbers against the model: the CBC's F1 minimum beside the fold, each PLL point's phase,
# and where each direction of the stepped sine jumps.
x = [p.extra for p in cbc.points if p.extra["converged"]]
low = min(x, key=lambda r: r["force_fundamental_n"])
print(
    f"CBC: F1 minimum {low['force_fundamental_n']:.3f} N at A {low['amplitude_m'] * 1e3:.4f} mm "
    f"({(low['force_fundamental_n'] / fold.value - 1) * 100:+.2f} % from the model's fold)"
)
for p in pll.points:
    r = p.extra
    print(f"PLL: {r['phase_deg']:.1f} deg at {r['fe_hz']:.3f} Hz, A {r['amplitude_m'] * 1e3:.3f} mm")
curves = {}
for direction in ("up", "down"):
    points = [p for p in sweep.points if p.extra.get("direction") == direction]
    fe = np.array([p.fe for p in points])
    a = np.array([p.harmonics["active_shroud_accel"][0] for p in points]) / (2 * np.pi * fe) ** 2 * 1e3
    curves[direction] = (fe, a)
    i = int(np.argmax(np.abs(np.diff(a)) / a[:-1]))
    print(f"stepped sine {direction}: largest step between {fe[i]:g} Hz and {fe[i + 1]:g} Hz")

# %%
# The figure.
import matplotlib.pyplot as plt

fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.6), layout="constrained")
for ax, branches, x_of, y_of in (
    (left, in_fe, lambda b: b.values(), lambda b: amplitude_mm(b, b.values())),
    (right, in_force, lambda b: amplitude_mm(b, 64.0), lambda b: b.values()),
):
    for b in branches:
        bx, by, stable = x_of(b), y_of(b), b.stable()
        ax.plot(bx, np.where(stable, by, np.nan), "-", color="0.3", label="model, stable")
        ax.plot(bx, np.where(stable, np.nan, by), "--", color="0.3", label="model, unstable")
for direction, marker, colour in (("up", "^-", "C0"), ("down", "v-", "C1")):
    left.plot(*curves[direction], marker, color=colour, lw=0.8, ms=5, label=f"stepped sine, {direction}")
for p in pll.points:
    r = p.extra
    left.plot(r["fe_hz"], r["amplitude_m"] * 1e3, "o", color="C3", label="PLL")
    left.annotate(
        f"{r['phase_deg']:.0f}°",
        (r["fe_hz"], r["amplitude_m"] * 1e3),
        xytext=(4, 4),
        textcoords="offset points",
        fontsize=7,
    )
for p in cbc.points:
    r = p.extra
    face = "C2" if r["converged"] else "none"
    left.plot(r["fe_hz"], r["amplitude_m"] * 1e3, "D", color="C2", mfc=face, label="CBC")
    right.plot(r["amplitude_m"] * 1e3, r["force_fundamental_n"], "D", color="C2", mfc=face, label="CBC")
right.axhline(5.0, color="0.5", ls=":", lw=0.8, label="F1 of the left panel")
left.set(xlabel="excitation frequency fe (Hz)", ylabel="A: active shroud displacement, fundamental (mm)")
left.set_title("frequency plane, F1 = 5 N, gap 0.5 mm", fontsize=9)
right.set(xlabel="A: active shroud displacement, fundamental (mm)", ylabel="F1: force fundamental (N)")
right.set_title("force plane at fe = 64 Hz: the CBC's S-curve", fontsize=9)
for ax in (left, right):
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles, strict=True))
    ax.legend(unique.values(), unique.keys(), fontsize=7)
    ax.grid(True, alpha=0.3)
plt.show()
