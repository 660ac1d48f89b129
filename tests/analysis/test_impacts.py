"""Impacts from shroud accelerations only, against synthetic records with known contacts and a
simulated vibro-impact run whose contact force is the truth."""

import numpy as np
import pytest

from rigtools.analysis.impacts import detect_impacts, impacts_from_contact_force

FS, FE, TAU = 51200.0, 60.0, 1.0e-3


def _record(onsets, n_periods=30, seed=0, noise=0.5):
    """Smooth response (fe and a 6 fe resonance) plus damped-contact pulses
    f(t) = 50 N (0.4 + 0.6 sin(pi t / tau)) for 0 <= t < tau (a damped contact force jumps where
    the contact closes and opens); active shroud mass 0.1 kg, passive 0.08 kg."""
    rng = np.random.default_rng(seed)
    n = round(n_periods * FS / FE)
    t = np.arange(n) / FS
    fc = np.zeros(n)
    for t0 in onsets:
        i0 = round(t0 * FS)
        m = round(TAU * FS)
        if i0 + m < n:
            fc[i0 : i0 + m] = 50.0 * (0.4 + 0.6 * np.sin(np.pi * np.arange(m) / m))
    w = 2 * np.pi * FE
    active = 100 * np.sin(w * t) + 40 * np.sin(6 * w * t + 0.3) - fc / 0.1
    passive = 30 * np.sin(w * t - 0.5) + 25 * np.sin(8 * w * t) + fc / 0.08
    force = 15 * np.sin(w * t) + 0.02 * fc
    noise = noise * rng.standard_normal((3, n))
    return active + noise[0], passive + noise[1], force + noise[2], fc


def test_period_one_impacts_counted_timed_and_sized():
    """One contact per period at phase 0.25: 30 impacts (1 per period), onsets within one sample,
    contact duration within 2 samples (0.04 ms) of 1 ms, period 1."""
    onsets = (np.arange(30) + 0.25) / FE
    a, p, f, _fc = _record(onsets)
    r = detect_impacts(a, FS, FE, passive_acceleration=p, force=f)
    assert r.n_impacts == 30
    assert r.impacts_per_period == pytest.approx(1.0)
    np.testing.assert_allclose(r.times, onsets, atol=1.01 / FS)
    assert r.contact_duration == pytest.approx(TAU, abs=2 / FS)
    assert r.periodic and r.period_multiple == 1
    # raw peak of the active shroud: the pulse peak 500 m/s^2 on top of the smooth motion
    assert 400 < r.peak_levels["active_acceleration"] < 650
    assert r.impulse_levels["passive_acceleration"] > 5 * 2.5  # well above the noise


def test_period_two_pattern():
    """Even periods one contact (phase 0.25), odd periods two (0.25 and 0.6): 1.5 per period,
    period multiple 2."""
    onsets = []
    for k in range(30):
        onsets.append((k + 0.25) / FE)
        if k % 2:
            onsets.append((k + 0.6) / FE)
    a, p, _f, _ = _record(onsets)
    r = detect_impacts(a, FS, FE, passive_acceleration=p)
    assert r.n_impacts == len(onsets)
    assert r.impacts_per_period == pytest.approx(1.5, abs=0.04)
    assert r.period_multiple == 2


def test_irregular_impacts_are_not_periodic_and_no_impacts_found_without_contact():
    rng = np.random.default_rng(4)
    onsets = (np.arange(30) + rng.uniform(0.1, 0.9, 30)) / FE
    a, p, _, _ = _record(onsets)
    r = detect_impacts(a, FS, FE, passive_acceleration=p)
    assert r.n_impacts == 30
    assert not r.periodic and r.period_multiple is None
    a, p, _, _ = _record([])
    r = detect_impacts(a, FS, FE, passive_acceleration=p)
    assert r.n_impacts == 0 and r.contact_duration is None and r.impacts_per_period == 0
    assert r.to_dict()["n_impacts"] == 0


def test_against_a_simulated_vibro_impact_run():
    """Default rig, fe = 60 Hz, F0 = 15 N, gap 0.5 mm (the paper's Figure 9 case), 19.68 kS/s:
    from the shroud accelerations only, every contact onset within one sample of the simulated
    contact force's, impacts per period and period multiple equal. The simulated contact opens
    smoothly (force decaying to zero), so the duration comes from the relative displacement
    rebuilt from the relative acceleration (periodic double integral): within 10 % of the
    contact force's 1.52 ms (the opening is grazing, so half a sample at the closing moves the
    estimate by ~0.12 ms)."""
    from rigtools.config import load_rig
    from rigtools.sim.reduction import reduced_system
    from rigtools.sim.rig_model import build_rig_model
    from rigtools.sim.vibro_impact import run_harmonic

    model = build_rig_model(load_rig().to_params())
    run = run_harmonic(reduced_system(model.params, rig_model=model), FE, 15.0)
    o, fs = run.outputs, run.sample_rate
    truth = impacts_from_contact_force(o["contact_force"], fs, FE)
    r = detect_impacts(
        o["active_tip_acceleration"], fs, FE, passive_acceleration=o["passive_tip_acceleration"]
    )
    assert r.impacts_per_period == pytest.approx(truth["impacts_per_period"])
    np.testing.assert_allclose(r.times, truth["onsets"], atol=1.01 / fs)
    assert r.period_multiple == run.period_multiple
    assert r.contact_duration == pytest.approx(truth["contact_duration"], rel=0.10)


def test_periodic_double_integral_is_exact_for_whole_periods():
    """a = -w^2 A cos(w t) - (3w)^2 B sin(3 w t) integrates to A cos + B sin (1e-9), also when the
    record holds extra samples past the last whole period (repeated periodic part)."""
    from rigtools.analysis.impacts import periodic_double_integral

    fs, fe = 10000.0, 50.0
    t = np.arange(2037) / fs
    w = 2 * np.pi * fe
    u = 2e-3 * np.cos(w * t) + 5e-4 * np.sin(3 * w * t)
    a = -(w**2) * 2e-3 * np.cos(w * t) - (3 * w) ** 2 * 5e-4 * np.sin(3 * w * t)
    np.testing.assert_allclose(periodic_double_integral(a, fs, fe), u, atol=1e-9 * 2e-3)
