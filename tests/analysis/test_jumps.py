"""Jumps of a stepped sine (rigtools.analysis.jumps): a linear rig never jumps, whatever its steps;
a hardening (Duffing) resonance jumps where its closed-form folds say; the contact across a step
is told from the shroud harmonics."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from rigtools.analysis.jumps import contact_seen, find_jumps

# the active blade's flexural modes (Hz) as the simulated rig's FRF test identifies them, and
# unit modal constants of similar size: a linear accelerance with its resonances and antiresonances
MODES_HZ = np.array([52.0, 355.6, 1252.9, 2131.0])
PHI2 = np.array([1.0, 1.2, 0.8, 0.7])


def accelerance(f: np.ndarray, zeta: float) -> np.ndarray:
    w, wn = 2 * np.pi * f[:, None], 2 * np.pi * MODES_HZ[None, :]
    return np.abs(np.sum(PHI2 * w**2 / (wn**2 - w**2 + 2j * zeta * wn * w), axis=1))


@settings(max_examples=60, deadline=None)
@given(
    start=st.floats(20.0, 2000.0),
    step=st.floats(0.05, 80.0),
    n=st.integers(2, 40),
    zeta=st.floats(0.002, 0.05),
    seed=st.integers(0, 2**16),
)
@example(start=340.0, step=10.0, n=5, zeta=0.012, seed=0)  # the issue's 340 -> 350 Hz "jump"
def test_a_linear_sweep_never_jumps_whatever_its_band_and_step(start, step, n, zeta, seed):
    """A linear rig (no contact on any step) swept up and down over any band in any step, with
    0.1 % noise: no jump in either direction, with or without the contact of the steps known.
    Without it the only evidence left is hysteresis, and up and down agree within the noise
    (0.1 %, far below the 30 % threshold); with it, no step has contact on either side."""
    rng = np.random.default_rng(seed)
    f = start + step * np.arange(n)
    up = accelerance(f, zeta) * (1 + 1e-3 * rng.standard_normal(n))
    down = accelerance(f[::-1], zeta) * (1 + 1e-3 * rng.standard_normal(n))
    assert find_jumps(f, up, 0.3, contact=[False] * n) == []
    assert find_jumps(f, up, 0.3, other=(f[::-1], down)) == []
    assert find_jumps(f[::-1], down, 0.3, other=(f, up), contact=[False] * n) == []


def test_the_issues_linear_steps_are_big_changes():
    """The example above is no empty case: 340 -> 350 Hz more than doubles the response (the
    resonance at 355.6 Hz passes between steps), well above the threshold."""
    f = np.arange(340.0, 381.0, 10.0)
    a = accelerance(f, 0.012)
    assert a[1] / a[0] > 2.0 and a[2] / a[3] > 2.0


def duffing_sweeps(f: np.ndarray, zeta=0.01, gamma=0.02, force=1.0):
    """Up and down sweeps of x'' + 2 zeta x' + x + gamma x^3 = F cos(w t) (w0 = 1, f in units of
    f0) by harmonic balance: on the way up the largest amplitude while it exists, on the way
    down the smallest (the root of the cubic in A^2 continued from where each sweep came)."""
    up, down = [], []
    for w in f:
        # (9/16 g^2) s^3 + (3/2 g (1 - w^2)) s^2 + ((1 - w^2)^2 + (2 zeta w)^2) s - F^2 = 0, s = A^2
        c = [9 / 16 * gamma**2, 1.5 * gamma * (1 - w**2), (1 - w**2) ** 2 + (2 * zeta * w) ** 2, -(force**2)]
        s = np.sort([r.real for r in np.roots(c) if abs(r.imag) < 1e-9 and r.real > 0])
        up.append(np.sqrt(s[-1]))
        down.append(np.sqrt(s[0]))
    return np.array(up), np.array(down)


def duffing_folds(zeta=0.01, gamma=0.02, force=1.0):
    """The two folds (where the cubic has a double root) on a fine grid: the up sweep falls at
    the upper, the down sweep rises at the lower."""
    w = np.linspace(0.8, 3.5, 270001)
    n = []
    for wi in w[::100]:
        c = [
            9 / 16 * gamma**2,
            1.5 * gamma * (1 - wi**2),
            (1 - wi**2) ** 2 + (2 * zeta * wi) ** 2,
            -(force**2),
        ]
        n.append(sum(1 for r in np.roots(c) if abs(r.imag) < 1e-9 and r.real > 0))
    n = np.array(n)
    three = w[::100][n == 3]
    return float(three.min()), float(three.max())


def test_a_hardening_resonance_jumps_at_its_folds_by_hysteresis():
    """Without the contact known, up and down sweeps of a Duffing oscillator in 0.05 f0 steps:
    one jump each way, found by the hysteresis between them, bracketing the closed-form folds
    (the upper fold for the way up, the lower for the way down)."""
    f = np.arange(0.8, 3.5, 0.05)
    up, down = duffing_sweeps(f)
    low, high = duffing_folds()
    (j_up,) = find_jumps(f, up, 0.3, other=(f[::-1], down[::-1]))
    (j_down,) = find_jumps(f[::-1], down[::-1], 0.3, other=(f, up))
    assert j_up.evidence == j_down.evidence == "hysteresis"
    assert j_up.start <= high <= j_up.stop and j_up.kind == "down"
    assert j_down.stop <= low <= j_down.start and j_down.kind == "up"
    # one direction alone, contact unknown: a step cannot be told from a linear resonance
    assert find_jumps(f, up, 0.3) == []


# the FEM's frequency study at gap 0.5 mm, 15 N (rig study frequency, up): peak contact force (N)
# and impacts per period; quasi-periodic past the Neimark-Sacker point at 72.61 Hz, no contact
# from 73.1 Hz
STUDY_HZ = [70.0, 71.0, 72.0, 72.2, 72.4, 72.6, 72.8, 72.9, 73.0, 73.1, 73.2, 73.4, 73.6, 74.0]
STUDY_N = [89.59, 88.19, 71.23, 69.23, 54.65, 55.08, 92.49, 92.63, 92.10, 0.0, 0.0, 0.0, 0.0, 0.0]


def test_the_fem_study_leaves_contact_after_the_torus():
    """The study's response leaves the periodic orbit into the torus between 72.6 and 72.8 Hz
    (in contact on both sides, a step three times its neighbours') and leaves contact between
    73.0 and 73.1 Hz; the fall from 72 to 72.4 Hz (-23 %, in contact) is below the threshold."""
    jumps = find_jumps(STUDY_HZ, STUDY_N, 0.3, contact=[n > 0 for n in STUDY_N])
    assert [(j.start, j.stop, j.evidence) for j in jumps] == [
        (72.6, 72.8, "discontinuity in contact"),
        (73.0, 73.1, "contact vanishes"),
    ]


@pytest.mark.parametrize(
    ("active", "passive", "seen"),
    [
        ([61.06, 2e-3, 1e-3], [6e-4, 1e-4], False),  # 340 Hz at gap 5 mm (simulated rig): noise only
        ([101.6, 60.0, 40.0], [55.0, 30.0], True),  # 74 Hz at gap 0.5 mm: impacts
        ([100.0, 3.0, 2.0], None, False),  # 3.6 % distortion and no passive shroud: below 5 %
        ([100.0], [8.0], True),  # the passive shroud moves: only the contact drives it
    ],
)
def test_contact_seen_from_the_shroud_harmonics(active, passive, seen):
    assert contact_seen(active, passive) is seen
