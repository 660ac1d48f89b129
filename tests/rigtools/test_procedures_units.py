"""Fast checks of the procedure layer's pieces: parameter validation, the multi-channel
harmonic fit against rigtools.analysis.harmonics, the sample ring, the force controller's secant step."""

import numpy as np
import pytest

from rigtools.errors import UserError
from rigtools.procedures import DwellParameters, StudyParameters, SweepParameters
from rigtools.procedures.base import validate
from rigtools.procedures.session import PointSink, SineSession, phasor, phasors, whole_periods


@pytest.mark.parametrize(
    "model, values, needle",
    [
        (DwellParameters, {"fe": -1.0, "force": 15.0}, "fe = -1.0"),
        (DwellParameters, {"fe": 60.0, "force": 0.0}, "force = 0.0"),
        (DwellParameters, {"fe": 60.0, "force": 15.0, "gap": 0.5}, "gap = 0.5"),
        (
            DwellParameters,
            {"fe": 60.0, "force": 15.0, "control": {"max_updates": 0}},
            "control.max_updates = 0",
        ),
        (DwellParameters, {"fe": 60.0, "force": 15.0, "colour": "red"}, "colour"),
        (SweepParameters, {"frequencies": [60.0], "force": 1.0}, "frequencies"),
        (SweepParameters, {"frequencies": [60.0, -5.0], "force": 1.0}, "every frequency must be > 0 Hz"),
        (StudyParameters, {"kind": "mass", "values": [1.0]}, "kind = 'mass'"),
    ],
)
def test_bad_parameters_are_one_line_naming_them(model, values, needle):
    with pytest.raises(UserError) as info:
        validate(model, **values)
    text = str(info.value)
    assert needle in text and "\n" not in text


def test_study_uses_the_model_study_plan():
    from rigtools.sim.studies import StudyPlan

    params = validate(
        StudyParameters, kind="frequency", values=[60.0, 62.0, 61.0], direction="both", force=15.0, gap=7e-4
    )
    plan = params.plan()
    assert isinstance(plan, StudyPlan)
    assert [(p.value, p.direction) for p in plan.points()] == [
        (60.0, "up"),
        (61.0, "up"),
        (62.0, "up"),
        (61.0, "down"),
        (60.0, "down"),
    ]
    with pytest.raises(UserError, match="at least one value|values"):
        validate(StudyParameters, kind="gap", values=[]).plan()


def test_multichannel_fit_equals_the_least_squares_fit_of_analysis():
    """Offset, k = 1 and 3 and noise at a frequency with a non-integer number of samples per
    period and a record that is not whole periods: same complex amplitudes as
    rigtools.analysis.harmonics.harmonic_amplitudes within 1e-12 (relative to the fundamental)."""
    rng = np.random.default_rng(1)
    fs, fe, n = 51200.0, 61.3, 25000
    t = np.arange(n) / fs
    x = np.vstack(
        [
            0.3
            + 2 * np.cos(2 * np.pi * fe * t + 0.4)
            + 0.5 * np.cos(6 * np.pi * fe * t - 1.1)
            + 0.01 * rng.standard_normal(n),
            rng.standard_normal(n),
        ]
    )
    fast = phasors(x, fs, fe, 10)
    ref = np.array([phasor(row, fs, fe, 10)[0] for row in x])
    assert np.max(np.abs(fast - ref)) < 1e-12 * 2
    assert abs(fast[0, 0]) == pytest.approx(2.0, rel=1e-3) and np.angle(fast[0, 0]) == pytest.approx(
        0.4, abs=1e-3
    )


def test_ring_keeps_the_latest_samples_across_wraps():
    data = np.arange(2 * 5000.0).reshape(2, 5000)
    ring = PointSink(2, 1000)
    for i in range(0, 5000, 333):
        ring.append(data[:, i : i + 333])
    np.testing.assert_array_equal(ring.last(1000), data[:, -1000:])
    np.testing.assert_array_equal(ring.last(7), data[:, -7:])
    small = PointSink(2, 100)
    small.append(data[:, :250])  # one block larger than the ring
    np.testing.assert_array_equal(small.last(100), data[:, 150:250])
    small.append(data[:, 250:260])
    np.testing.assert_array_equal(small.last(100), data[:, 160:260])


def test_whole_periods():
    assert whole_periods(0.1, 51200.0, 60.0) == 5120  # 6 periods
    assert whole_periods(0.01, 51200.0, 60.0) == 2560  # at least 3 periods


def test_secant_step_is_exact_for_an_affine_force():
    """F(a) = 4 a + 1: from two measurements the secant lands on F0 exactly; from one, the
    proportional step a F0 / F."""
    history = [(0.5, 3.0), (1.0, 5.0)]
    assert SineSession._next_drive(history, 15.0) == pytest.approx(3.5)
    assert SineSession._next_drive(history[:1], 15.0) == pytest.approx(2.5)
    assert SineSession._next_drive([(1.0, 5.0), (2.0, 4.0)], 15.0) == pytest.approx(2.0 * 15 / 4)
