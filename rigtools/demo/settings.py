"""How much the demo runs: the full resolution and ``--quick``, and the two operating points.

The paper's point is fe = 60 Hz (1.13 f1 on the calibrated rig), F0 = 15 N. The equivalent
impact-oscillator point is fe = 1.8 f1 with F0 scaled so the linear (free) amplitude of the
active shroud stays what it is at the paper's point (docs/calibration.md: there the paper's
gap and frequency trends appear on the same, unchanged rig).
"""

from __future__ import annotations

from dataclasses import dataclass, field

#: Offsets of each simulated-rig step's seed from DemoSettings.seed (each step its own noise).
SEED_OFFSETS = {"frf": 0, "dwell": 100, "study": 200, "sweep": 300}

EQUIVALENT_RATIO = 1.8  # fe / f1 of the equivalent impact-oscillator point
PAPER_FE, PAPER_FORCE = 60.0, 15.0
DWELL_GAP = 0.5e-3  # m: the dwell of Figures 8-9
STUDY_GAP = 0.7e-3  # m: the fixed gap of the force and frequency studies
# m: the gap branch runs from the gap study's first gap to here, past the period doublings at
# 1.53 and 2.39 mm of the paper's point (tests/sim/test_continuation.py)
BRANCH_GAP_MAX = 2.5e-3


@dataclass(frozen=True)
class DemoSettings:
    """Resolution of every step (SI). :func:`quick` and :func:`full` are the two shipped sets."""

    name: str
    frf_frame: float  # s: FRF resolution 1/frame
    frf_averages: int
    frf_band: tuple[float, float] = (20.0, 1500.0)
    harmonic_points: int = 3000
    dwell_periods: int = 120
    study_periods: int = 30
    gap_values: tuple[float, ...] = (0.3e-3, 0.4e-3, 0.5e-3, 0.6e-3, 0.7e-3, 0.8e-3, 0.9e-3)
    force_ratios: tuple[float, ...] = (1 / 3, 2 / 3, 1.0, 4 / 3, 5 / 3)  # of F0 (5..25 N at 15 N)
    frequency_ratios: tuple[float, ...] = field(  # of the point's fe
        default=(1.0, 62 / 60, 64 / 60, 66 / 60, 68 / 60, 70 / 60, 72 / 60, 74 / 60, 76 / 60)
    )
    # the equivalent point's F0 (~118 N) already needs ~8 V of the DAQ's 10 V output: its force
    # study goes up to F0, not beyond
    equivalent_force_ratios: tuple[float, ...] = (0.2, 0.4, 0.6, 0.8, 1.0)
    model_settle_time: float = 20.0  # s: a model run that has not settled by then is recorded anyway
    # the FEM's branches at the paper's point (frequency study with its fold, gap study with its
    # period doubling) and the simulated rig's stepped sine up and down over the frequency
    # study's range in ``sweep_step`` steps beside them; ``tiny`` leaves them out
    branches: bool = True
    sweep_step: float = 1.0  # Hz
    # the simulated rig's sensor noise and the FRF test's excitation: fixed by default, so two demos
    # give the same recordings and the same findings (``rig demo --seed`` changes it)
    seed: int = 0


def full() -> DemoSettings:
    """The demo at full resolution (measured: 64 s of CPU on a 2-core machine, kernels compiled)."""
    return DemoSettings(name="full", frf_frame=1.0, frf_averages=10)


def quick() -> DemoSettings:
    """``--quick``: the same steps at reduced resolution (measured: 50 s of CPU on a 2-core machine,
    kernels compiled; most of it the FEM's branches, which the full demo traces alike)."""
    return DemoSettings(
        name="quick",
        frf_frame=0.5,
        frf_averages=4,
        harmonic_points=600,
        dwell_periods=30,
        study_periods=10,
        gap_values=(0.3e-3, 0.6e-3, 0.9e-3),
        force_ratios=(1 / 3, 1.0, 5 / 3),
        frequency_ratios=(1.0, 64 / 60, 68 / 60, 72 / 60, 76 / 60),
        equivalent_force_ratios=(0.2, 0.6, 1.0),
        model_settle_time=8.0,
        sweep_step=2.0,
    )


def tiny() -> DemoSettings:
    """Smallest useful set (tests): two or three points per study."""
    return DemoSettings(
        name="tiny",
        frf_frame=0.5,
        frf_averages=2,
        harmonic_points=200,
        dwell_periods=12,
        study_periods=6,
        gap_values=(0.3e-3, 0.9e-3),
        force_ratios=(1 / 3, 5 / 3),
        frequency_ratios=(1.0, 68 / 60, 76 / 60),
        equivalent_force_ratios=(0.2, 1.0),
        model_settle_time=5.0,
        branches=False,
    )


@dataclass(frozen=True)
class OperatingPoint:
    """Where the studies are centred: ``fe`` (Hz), ``force`` (N); ``label`` for tables."""

    key: str
    label: str
    fe: float
    force: float
