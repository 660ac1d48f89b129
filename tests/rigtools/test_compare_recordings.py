"""``rig compare`` / :func:`rigtools.recording_comparison.compare_recordings` on the simulated rig.

The simulated rig's test article is the FE model with deliberate deviations (root stiffness,
shroud and sensor masses, damping, sensor noise, IEPE high-pass), so EM and FEM differ as on a
real rig: its 2nd active mode sits 1.7 % below the FEM's. Numbers printed by the tests were
measured on a 2-core machine; the comments give them.
"""

import json

import numpy as np
import pytest
from cli_helpers import acquire_dwell, acquire_frf, acquire_gap_study, run_cli

GAPS = "0.3 mm,0.6 mm,0.9 mm"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cmp")
    paths = {"study65": d / "gap65.h5", "dwell60": d / "dwell60.h5", "frf": d / "frf.h5"}
    code, _, err = run_cli([*acquire_gap_study(GAPS, fe="65", periods=10), "--out", paths["study65"]])
    assert code == 0, err
    code, _, err = run_cli([*acquire_dwell(gap="0.6 mm", periods=10), "--out", paths["dwell60"]])
    assert code == 0, err
    code, _, err = run_cli(
        [*acquire_frf("chirp", band="20 Hz:1 kHz", averages=4, seed=1), "--out", paths["frf"]]
    )
    assert code == 0, err
    paths["dir"] = d
    return paths


def test_gap_study_measured_excitation_agrees_better_than_nominal(files):
    """The must-show: a simulated-rig gap study (65 Hz, 15 N, 0.3/0.6/0.9 mm) against --simulate.
    Measured: mean score 0.951 (0.955, 0.954, 0.944); nominal 0.831 (0.838, 0.829, 0.826): the
    FEM driven by F0 sin lacks the force's 5·fe and 6·fe harmonics (about 5 N and 1 N)."""
    scores = {}
    for exc in ("measured", "nominal"):
        figs = (
            ["--out", str(files["dir"] / "figs")] if exc == "measured" else []
        )  # figures once: slow to draw
        code, out, err = run_cli(
            ["compare", str(files["study65"]), "--simulate", "--excitation", exc, "--json", *figs]
        )
        assert code == 0, err
        doc = json.loads(out)
        scores[exc] = [p["agreement"]["score"] for p in doc["points"]]
        print(f"{exc}: mean score {doc['mean_score']:.4f}, per point {np.round(scores[exc], 4).tolist()}")
        assert doc["study_kind"] == "gap" and len(doc["points"]) == 3
        assert [round(p["params"]["gap"] * 1e3, 6) for p in doc["points"]] == [0.3, 0.6, 0.9]
        # EM and FEM side by side: every channel's harmonics on both sides
        rows = doc["points"][0]["harmonics"]
        assert {r["channel"] for r in rows} == {"force", "active_shroud_accel", "passive_shroud_accel"}
        assert all(r["em"] > 0 and r["fem"] > 0 for r in rows if r["channel"] != "force")
        # the fundamental of the force applied equals the EM force fundamental
        f1 = next(r for r in rows if r["channel"] == "force" and r["k"] == 1)
        assert f1["fem"] == pytest.approx(f1["em"], rel=1e-9)
        if figs:  # trends + per point overlay and harmonic bars, named after the EM file
            names = sorted(p.rsplit("/", 1)[-1] for p in doc["figures"])
            assert len(names) == 1 + 2 * 3 and "gap65.compare-trends.png" in names
    assert np.mean(scores["measured"]) > np.mean(scores["nominal"]) + 0.05
    assert all(m > n for m, n in zip(scores["measured"], scores["nominal"], strict=True))


def test_6fe_difference_at_60_hz_is_explained_by_the_em_2nd_mode_offset(files):
    """The issue's example: 60 Hz, 15 N. The active shroud's 6·fe (360 Hz) is x3.5 on the FEM
    (nominal excitation); the explanation cites the EM 2nd mode (355.6 Hz from the FRF test) and
    the FEM's (361.9 Hz, +1.77 %). Measured: EM force 5·fe harmonic about 6 N."""
    from rigtools.recording_comparison import compare_recordings

    cmp = compare_recordings(
        str(files["dwell60"]), simulate=True, excitation="nominal", frf=str(files["frf"])
    )
    nat = cmp.natural.set_index(["blade", "mode"])
    em2, fem2 = nat.loc[("active", 2), "em_hz"], nat.loc[("active", 2), "fem_hz"]
    print(f"active mode 2: EM {em2:.2f} Hz, FEM {fem2:.2f} Hz ({100 * (fem2 / em2 - 1):+.2f} %)")
    assert 350 < em2 < 360 and 1.2 < 100 * (fem2 / em2 - 1) < 2.3
    (p,) = cmp.points
    force5 = p.em.harmonics["force"].at(5)
    print(f"EM force 5·fe {force5:.2f} N")
    assert 4.0 < force5 < 8.0
    row = p.table[(p.table.channel == "active_shroud_accel") & (p.table.k == 6)].iloc[0]
    print(f"active 6·fe: EM {row.em:.1f}, FEM {row.fem:.1f} m/s^2 ({row.diff_pct:+.0f} %)")
    assert row.diff_pct > 100
    found = [(ch, e, m) for ch, e, m in p.explanations if ch == "active_shroud_accel" and e.k == 6]
    assert found, p.explanations
    _ch, e, m = found[0]
    assert e.natural_hz == pytest.approx(em2) and m == ("active", 2, pytest.approx(fem2))
    line = next(x for x in p.explanation_lines("FEM") if "6·fe" in x)
    print(line)
    assert "EM active mode 2 at 355" in line and "+1." in line
    # just above the EM resonance: a higher natural frequency raises the harmonic, a lower one lowers it
    assert e.ratio_per_percent[0] > 1 > e.ratio_per_percent[1]
    # printed on stdout by the command
    code, out, err = run_cli(
        [
            "compare",
            str(files["dwell60"]),
            "--simulate",
            "--excitation",
            "nominal",
            "--frf",
            str(files["frf"]),
        ]
    )
    assert code == 0, err
    text = " ".join(out.split())
    assert "EM active mode 2 at 355" in text and "mean agreement score (nominal excitation, FEM)" in text


def test_model_recording_is_paired_by_meaning_and_scores_as_the_same_run_simulated(files):
    """``rig simulate`` at the EM point's fe, gap and F0 (a FEM recording) against ``--simulate
    --excitation nominal``: the same model at the same point, so the same score (the F0 differs
    by the EM force's 0.1 % control error)."""
    fem = files["dir"] / "fem60.h5"
    code, _, err = run_cli(_simulate_60hz("0.6 mm", "0.2 s", fem))
    assert code == 0, err
    code, out, err = run_cli(["compare", str(files["dwell60"]), str(fem), "--json"])
    assert code == 0, err
    from_file = json.loads(out)
    code, out, err = run_cli(
        ["compare", str(files["dwell60"]), "--simulate", "--excitation", "nominal", "--json"]
    )
    simulated = json.loads(out)
    a, b = from_file["points"][0]["agreement"]["score"], simulated["points"][0]["agreement"]["score"]
    print(f"score against the FEM recording {a:.4f}, against --simulate nominal {b:.4f}")
    assert from_file["model_source"].endswith("fem60.h5") and from_file["excitation"] is None
    assert a == pytest.approx(b, abs=0.01)
    # a model point at another gap does not pair: one line, exit 2
    other = files["dir"] / "fem60-gap09.h5"
    code, _, err = run_cli(_simulate_60hz("0.9 mm", "0.1 s", other))
    assert code == 0, err
    code, out, err = run_cli(["compare", str(files["dwell60"]), str(other)])
    assert code == 2 and "no EM point" in err and "(60.0, 0.9, 15.0)" in err and err.count("\n") == 1, err


def _simulate_60hz(gap, duration, out):
    """``rig simulate`` of the FEM at the EM dwell's point (60 Hz, 15 N) at ``gap``."""
    point = ["--fe", "60 Hz", "--force", "15 N", "--gap", gap]
    return ["simulate", *point, "--duration", duration, "--out", out, "--no-plot"]


def test_a_study_without_frf_data_says_so(files):
    from rigtools.recording_comparison import compare_recordings

    cmp = compare_recordings(str(files["dwell60"]), simulate=True, excitation="measured")
    assert any("holds no FRF data" in n for n in cmp.notes)
    assert np.isnan(cmp.natural["em_hz"]).all()
    assert cmp.natural.loc[0, "fem_hz"] == pytest.approx(53.21, abs=0.05)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["compare"], "EM.h5"),
        (["compare", "{em}", "{em}", "--simulate"], "not both"),
        (["compare", "{em}"], "--simulate"),
        (["compare", "{dir}/missing.h5", "--simulate"], "no such file"),
        (["compare", "{em}", "--simulate", "--model", "xfem"], "--model"),
        (["compare", "{em}", "--simulate", "--harmonics", "0"], "--harmonics"),
        (["compare", "{frf}", "--simulate"], "no complete periodic"),
    ],
)
def test_bad_input_exit_2_in_one_line(files, argv, message):
    argv = [a.format(em=files["dwell60"], dir=files["dir"], frf=files["frf"]) for a in argv]
    code, _out, err = run_cli(argv)
    assert code == 2 and message in err, err
    assert "Traceback" not in err


def test_figures_never_replace_a_file_rigtools_did_not_write(files):
    out = files["dir"] / "guarded"
    out.mkdir()
    mine = out / "dwell60.compare-point-0-overlay.png"
    mine.write_text("a user's notes")
    code, _, err = run_cli(["compare", str(files["dwell60"]), "--simulate", "--out", str(out)])
    assert code == 2 and "not overwritten" in err and err.count("\n") == 1, err
    assert mine.read_text() == "a user's notes"


def test_report_section_holds_the_tables_notes_and_figures(files):
    from rigtools.recording_comparison import compare_recordings
    from rigtools.report import Report

    cmp = compare_recordings(
        str(files["dwell60"]), simulate=True, excitation="measured", frf=str(files["frf"])
    )
    report = Report("compare")
    cmp.add_to_report(report)
    (sec,) = report.sections
    page = report.html()
    assert sec.figures == 2  # overlay and harmonic bars of the one point
    assert "Natural frequencies" in page and "355.6" in page and "Agreement per point" in page
    assert page.count("<table>") == 3  # natural frequencies, agreement, harmonics
    doc = cmp.to_dict()
    json.dumps(doc, allow_nan=False)
    assert doc["points"][0]["explanations"][0]["model_mode"]["mode"] == 2
