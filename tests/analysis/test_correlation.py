"""EM-vs-FEM tables, the agreement score's defining properties, and the natural-frequency
offset that explains a harmonic difference (exact single-mode references)."""

import numpy as np
import pytest

from rigtools.analysis.correlation import (
    agreement_score,
    explain_harmonic_difference,
    explain_large_differences,
    harmonic_table,
    natural_frequency_table,
    single_mode_gain,
)


def test_natural_frequency_table_pairs_by_blade_and_order():
    fem = {"active": [361.9, 60.0, 1000.0], "passive": [70.0, 480.0, 1320.0]}
    em = {"active": [59.0, 355.8, 990.0], "passive": [69.0, 470.0]}
    am = {"active": [60.5, 365.0, 1010.0], "passive": [70.5, 481.0, 1330.0]}
    t = natural_frequency_table(fem, em, am)
    assert list(t.blade) == ["active"] * 3 + ["passive"] * 3
    assert list(t["mode"]) == [1, 2, 3, 1, 2, 3]
    row = t.iloc[1]
    assert row.fem_hz == 361.9 and row.em_hz == 355.8
    assert row.fem_vs_em_pct == pytest.approx(100 * (361.9 - 355.8) / 355.8, rel=1e-12)
    assert row.am_vs_em_pct == pytest.approx(100 * (365.0 - 355.8) / 355.8, rel=1e-12)
    assert np.isnan(t.iloc[5].em_hz) and np.isnan(t.iloc[5].fem_vs_em_pct)
    t2 = natural_frequency_table(fem, am=am)
    assert t2.iloc[0].am_vs_fem_pct == pytest.approx(100 * 0.5 / 60.0, rel=1e-12)


def test_harmonic_table_differences():
    em = {"force": np.array([15.0, 0.5, 0.1]), "active_acceleration": np.array([100.0, 20.0, 34.0])}
    fem = {
        "force": np.array([15.0, 0.0, 0.0]),
        "active_acceleration": np.array([110.0, 10.0, 128.0]),
        "x": [1],
    }
    t = harmonic_table(em, fem, 60.0)
    assert len(t) == 6 and set(t.channel) == {"force", "active_acceleration"}
    r = t[(t.channel == "active_acceleration") & (t.k == 3)].iloc[0]
    assert (
        r.frequency_hz == 180.0
        and r.diff_pct == pytest.approx(100 * (128 - 34) / 34)
        and r.ratio == pytest.approx(128 / 34)
    )


def _harm(seed, n=30):
    rng = np.random.default_rng(seed)
    return {
        "force": rng.uniform(0.01, 1, n) * 15,
        "active": rng.uniform(0.01, 1, n) * 300,
        "passive": rng.uniform(0.01, 1, n) * 500,
    }


def test_agreement_score_properties():
    em = _harm(1)
    # identical -> 1
    assert agreement_score(em, em).score == pytest.approx(1.0, abs=1e-15)
    # every harmonic off by q -> 1/q (here both directions)
    for q in (2.0, 0.5, 10.0):
        fem = {c: v * q for c, v in em.items()}
        assert agreement_score(em, fem).score == pytest.approx(min(q, 1 / q), rel=1e-12)
    # symmetric
    fem = _harm(2)
    assert agreement_score(em, fem).score == pytest.approx(agreement_score(fem, em).score, rel=1e-12)
    # invariant to a common unit scale per channel (e.g. m/s^2 vs g)
    scaled_em = {c: v * (9.81 if c != "force" else 1.0) for c, v in em.items()}
    scaled_fem = {c: v * (9.81 if c != "force" else 1.0) for c, v in fem.items()}
    assert agreement_score(scaled_em, scaled_fem).score == pytest.approx(
        agreement_score(em, fem).score, rel=1e-12
    )
    # monotone: moving one harmonic further away lowers the score; bounded in (0, 1]
    prev = 1.0
    for f in (1.0, 1.5, 3.0, 10.0, 100.0):
        fem = {c: v.copy() for c, v in em.items()}
        fem["active"][5] *= f
        s = agreement_score(em, fem).score
        assert 0 < s <= prev + 1e-15
        prev = s
    # strong harmonics weigh more: the same factor on the largest harmonic costs more than on a small one
    big = {c: v.copy() for c, v in em.items()}
    small = {c: v.copy() for c, v in em.items()}
    big["active"][np.argmax(em["active"])] *= 2
    small["active"][np.argmin(em["active"])] *= 2
    assert agreement_score(em, big).score < agreement_score(em, small).score


def test_frequency_offset_explains_a_super_harmonic_difference():
    """Single-mode reference: 6 fe = 360 Hz near a 361.9 Hz mode (zeta 0.5 %); a model whose
    mode is 1.7 % off gives the amplitude ratio gain(fn (1 + 0.017)) / gain(fn); the explanation
    recovers +1.7 % (1e-6), and the 1 % sensitivity is the closed-form gain ratio."""
    fe, fn, zeta = 60.0, 361.9, 0.005
    f = 6 * fe
    true_ratio = single_mode_gain(f, fn * 1.017, zeta) / single_mode_gain(f, fn, zeta)
    e = explain_harmonic_difference(6, fe, true_ratio, fn, zeta, natural_hz_model=fn * 1.017)
    assert e.offset_pct_needed == pytest.approx(1.7, abs=1e-6)
    assert e.ratio_from_model_frequency == pytest.approx(true_ratio, rel=1e-12)
    r = f / fn
    closed = abs(1 - r**2 + 2j * zeta * r) / abs(1 - (r / 1.01) ** 2 + 2j * zeta * r / 1.01)
    assert e.ratio_per_percent[0] == pytest.approx(closed, rel=1e-12)
    assert "1 %" in e.sentence()
    # via the table: the 6th harmonic of the active shroud, FEM 3.76x EM
    em = {"active_acceleration": np.r_[np.ones(5), 34.0, np.ones(3)]}
    fem = {"active_acceleration": np.r_[np.ones(5), 34.0 * true_ratio, np.ones(3)]}
    out = explain_large_differences(harmonic_table(em, fem, fe), fe, {"active": [60.5, fn, 1000.0]}, zeta)
    assert len(out) == 1 and out[0][0] == "active_acceleration" and out[0][1].k == 6
    assert out[0][1].offset_pct_needed == pytest.approx(1.7, abs=1e-6)


def test_pair_points_by_parameters():
    from rigtools.analysis.correlation import pair_points

    em = [
        {"fe": 60.0, "gap": 0.5e-3, "force_amplitude_target": 15.0},
        {"fe": 60.0, "gap": 0.7e-3, "force_amplitude_target": 15.0},
        {"fe": 80.0, "gap": 0.7e-3, "force_amplitude_target": 15.0},
    ]
    model = [
        {"fe": 60.0, "gap": 0.7e-3, "force_amplitude_target": 15.1},
        {"fe": 60.0, "gap": 0.5e-3, "force_amplitude_target": 14.9},
    ]
    assert pair_points(em, model) == [(0, 1), (1, 0)]


def test_trend_series_and_point_agreement_from_dwell_analyses():
    from rigtools.analysis.correlation import point_agreement, trend_series
    from rigtools.analysis.point import analyze_dwell

    fs, fe = 10240.0, 60.0
    t = np.arange(int(fs)) / fs
    w = 2 * np.pi * fe
    pts = []
    for scale in (1.0, 2.0):
        ch = {
            "force": 15 * np.sin(w * t),
            "active_shroud_accel": scale * (100 * np.sin(w * t) + 34 * np.sin(6 * w * t)),
            "passive_shroud_accel": scale
            * (50 * np.sin(w * t) + 7 * np.sin(8 * w * t) + 3 * np.sin(22 * w * t)),
        }
        pts.append(analyze_dwell(ch, fs, fe))
    s = trend_series(pts)
    np.testing.assert_allclose(s["active shroud accel 6·fe amplitude"], [34.0, 68.0], rtol=1e-9)
    np.testing.assert_allclose(s["passive shroud accel 22·fe amplitude"], [3.0, 6.0], rtol=1e-9)
    np.testing.assert_allclose(s["peak force-sensor signal"], [15.0, 15.0], rtol=1e-3)
    # the force channel agrees exactly, the shrouds differ by x2 everywhere: error = (0 + 2 log10 2) / 3
    # (to 1e-4: the absent harmonics sit on the 1e-3 floor on both sides, ratio 1, weight ~1e-5)
    a = point_agreement(pts[0], pts[1])
    assert a.score == pytest.approx(10 ** (-2 * np.log10(2) / 3), rel=1e-4)
    assert a.per_channel["force"] == pytest.approx(0.0, abs=1e-9)


def test_a_model_harmonic_zero_but_for_round_off_is_not_minus_100_percent():
    """F0 sin drives the model: its force harmonics k >= 2 are zero (round-off), not "-100 %"."""
    import numpy as np

    from rigtools.analysis.correlation import harmonic_table, without_round_off

    em = {"force": np.array([15.0, 0.3, 0.01])}
    fem = {"force": np.array([15.3, 2e-15, 0.0])}
    t = harmonic_table(em, fem, 60.0)
    assert t["diff_pct"].iloc[0] == pytest.approx(2.0, rel=1e-12)
    assert t["diff_pct"].iloc[1:].isna().all() and t["ratio"].iloc[1:].isna().all()
    assert list(t["fem"].iloc[1:]) == [0.0, 0.0] and t["em"].iloc[1] == 0.3
    kept = without_round_off([1.0, 1e-8, 1e-10])
    assert kept[1] == 1e-8 and np.isnan(kept[2])  # 1e-9 of the largest is the limit
