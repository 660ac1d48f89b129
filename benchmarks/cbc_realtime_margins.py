"""The real-time CBC law's margins in closed form (issue 33): the loop's gain on a sinusoid
(``rigtools.sim.delayed_feedback.loop_gain``: the PD, the 1.04 ms delay, the zero-order hold and
the output low-pass) times the simulated rig's LINEAR plant, drive volts to the active shroud's
displacement (the reduced model's active-blade modes through the shaker: armature, suspension,
coil and back-EMF), the blades apart (free) or stuck together through the contact's stiffness
(in contact). Per law: the gain margins (the factor on the whole law before the closed loop's
Nyquist plot reaches -1, upwards and downwards), the law's gain at fe = 64 Hz (stiffness, V/m,
and damping part) and at the sidebands 56/72 Hz, and its gain at 1 kHz (the impacts' content).

Run: ``PYTHONPATH=. python benchmarks/cbc_realtime_margins.py`` (a few seconds; ``--scan`` adds the
best margins of the PD and low-pass family with the law at fe near pure stiffness, a minute).
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from scipy.signal import butter

from rigtools.branches import simulated_rig_model

DELAY, RATE, FE = 1.04e-3, 10_000.0, 64.0
F = np.concatenate([np.linspace(1.0, 1000.0, 40_000), np.linspace(1000.0, 4999.0, 20_000)])
LAWS = [  # (Kp V/m, Kd V s/m, low-pass Hz or None): the schedule's and their neighbours
    (1000.0, 1.0, None),
    (2000.0, 2.0, None),
    (2000.0, 3.5, None),
    (2000.0, 4.0, 350.0),
    (1800.0, 4.0, 350.0),
    (2200.0, 4.0, 350.0),
    (2000.0, 3.75, 350.0),
    (2000.0, 4.25, 350.0),
    (2000.0, 4.0, 300.0),
    (2000.0, 4.0, 400.0),
    (2000.0, 4.5, 350.0),
    (2000.0, 5.0, 400.0),
    (2000.0, 4.0, 500.0),
    (1500.0, 4.0, 500.0),
    (2000.0, 6.0, 400.0),
]


def plant(f: np.ndarray, contact: float | None = None) -> np.ndarray:
    """Drive V -> active shroud displacement m (complex, e^{i w t}), blades free or, with
    ``contact`` (N/m), joined at the shrouds by that stiffness."""
    _cfg, system, drive = simulated_rig_model(None)
    c, gain = drive.coupling, drive.amplifier_gain
    w = 2 * np.pi * f
    den = system.omega**2 - w[:, None] ** 2 + 2j * system.zeta * system.omega * w[:, None]
    h = np.einsum("in,jn,fn->fij", system.shapes, system.shapes, 1 / den)  # rows: tips, force point
    if contact is not None:  # the contact force k (x_passive - x_active) on both shrouds
        a = 1 - contact * ((h[:, 1, 0] - h[:, 1, 1]) - (h[:, 0, 0] - h[:, 0, 1]))
        per_force = contact * (h[:, 1, 2] - h[:, 0, 2]) / a
        h_tf = h[:, 0, 0] * per_force - h[:, 0, 1] * per_force + h[:, 0, 2]
        h_ff = h[:, 2, 0] * per_force - h[:, 2, 1] * per_force + h[:, 2, 2]
    else:
        h_tf, h_ff = h[:, 0, 2], h[:, 2, 2]
    z_arm = -c.armature_mass * w**2 + 1j * w * c.suspension_damping + c.suspension_stiffness
    d = 1 + h_ff * z_arm
    coil = 1j * w * c.coil_inductance + c.coil_resistance
    return h_tf * c.force_factor * gain / (d * coil + c.force_factor**2 * 1j * w * h_ff)


def law_gain(kp: float, kd: float, lowpass: float | None, f: np.ndarray) -> np.ndarray:
    """``loop_gain`` vectorised over ``f`` (the same closed form)."""
    w = 2 * np.pi * f
    g = (kp + 1j * w * kd) * np.exp(-1j * w * DELAY) * (1 - np.exp(-1j * w / RATE)) / (1j * w / RATE)
    if lowpass is not None:
        b, a = butter(2, lowpass, fs=RATE)
        z = np.exp(-1j * w / RATE)
        g = g * (b[0] + b[1] * z + b[2] * z * z) / (a[0] + a[1] * z + a[2] * z * z)
    return g


def margins(loop: np.ndarray) -> tuple[float, float]:
    """``(up, down)``: the factors on the law at which the closed loop turns unstable (inf / 0:
    none); ``(0, inf)`` if it is unstable as it is (the plant is stable: Nyquist's count of
    the encirclements of -1 over 0..5 kHz, where the loop has rolled off)."""
    winding = (np.unwrap(np.angle(1 + loop))[-1] - np.angle(1 + loop[0])) / np.pi
    if abs(winding) > 0.5:
        return 0.0, math.inf
    i = np.flatnonzero((loop.imag[:-1] > 0) != (loop.imag[1:] > 0))
    k = [-1 / loop.real[j] for j in i if loop.real[j] < 0]
    return min([v for v in k if v > 1], default=math.inf), max([v for v in k if v < 1], default=0.0)


def row(kp: float, kd: float, lowpass: float | None, free: np.ndarray, stuck: np.ndarray) -> str:
    c = law_gain(kp, kd, lowpass, F)
    mf, ms = margins(free * c), margins(stuck * c)
    at = law_gain(kp, kd, lowpass, np.array([56.0, FE, 72.0, 1000.0]))
    corner = "none" if lowpass is None else f"{lowpass:.0f} Hz"
    return (
        f"Kp {kp:6.0f} Kd {kd:5.2f} low-pass {corner:>7}: gain margin free {mf[0]:5.2f} (down {mf[1]:4.2f}), "
        f"in contact {ms[0]:5.2f} (down {ms[1]:4.2f}); C(64 Hz) {at[1].real:6.0f} {at[1].imag:+5.0f}i V/m, "
        f"Im C(56, 72 Hz) {at[0].imag:+5.0f} {at[2].imag:+5.0f}; |C(1 kHz)| {abs(at[3]):6.0f} V/m"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scan", action="store_true", help="the family's best margins near pure stiffness")
    args = parser.parse_args()
    _cfg, system, _drive = simulated_rig_model(None)
    free, stuck = plant(F), plant(F, system.contact.stiffness)
    for kp, kd, lowpass in LAWS:
        print(row(kp, kd, lowpass, free, stuck))
    if args.scan:  # Re C(fe) 2550-3300 V/m, Im C(fe) -200..+20 V/m: the sheet's sector
        best = []
        for kp in np.arange(1800.0, 4001.0, 200.0):
            for kd in np.arange(1.0, 9.01, 0.5):
                for lowpass in (None, 120.0, 150.0, 200.0, 250.0, 300.0, 350.0, 400.0, 500.0, 700.0):
                    c = complex(law_gain(kp, kd, lowpass, np.array([FE]))[0])
                    if 2550 <= c.real <= 3300 and -200 <= c.imag <= 20:
                        g = law_gain(kp, kd, lowpass, F)
                        up = min(margins(free * g)[0], margins(stuck * g)[0])
                        best.append((up, kp, kd, lowpass))
        best.sort(key=lambda t: -t[0])
        print("the family near pure stiffness at fe, best upward gain margins:")
        for _up, kp, kd, lowpass in best[:6]:
            print(" ", row(kp, kd, lowpass, free, stuck))


if __name__ == "__main__":
    main()
