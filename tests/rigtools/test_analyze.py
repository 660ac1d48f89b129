"""rig analyze and rigtools.recording_analysis on real recordings (simulated rig, model runs, synthetic
files), checked against independent references."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_helpers import acquire_frf, run_cli

FRF = acquire_frf(
    "burst", band="20 Hz:1500 Hz", averages=6, seed=3
)  # burst.h5, shared with test_measured_data.py


@pytest.fixture(scope="module")
def frf_file(sim_recording):
    return sim_recording(FRF, "burst.h5")


@pytest.fixture(scope="module")
def study_file(tmp_path_factory):
    """A FEM frequency study with the gap wide open (linear): a stepped sine of the model."""
    path = tmp_path_factory.mktemp("study") / "steps.h5"
    code, _out, err = run_cli(
        [
            "study",
            "frequency",
            "--values",
            "40 Hz,52 Hz,60 Hz",
            "--gap",
            "3 mm",
            "--force",
            "5 N",
            "--duration",
            "0.1 s",
            "--out",
            str(path),
            "--no-plot",
        ]
    )
    assert code == 0, err
    return path


def article_flexural(rig_config, blade: str, n: int = 3) -> np.ndarray:
    """The simulated test article's flexural frequencies from its full FE blade model (not the
    reduced system the simulated rig integrates): the independent reference."""
    from rigtools.sim.modal import blade_modes
    from rigtools.sim.rig_model import build_rig_model

    params = rig_config.test_article.to_params().apply(rig_config.to_params())
    rig = build_rig_model(params)
    return blade_modes(rig.blade(blade), 12).of_kind("flexural").frequencies_hz[:n]


def test_frf_test_gives_the_test_articles_active_frequencies(frf_file):
    from rigtools.recording import open_recording
    from rigtools.recording_analysis.dispatch import analyze_recording

    a = analyze_recording(frf_file)
    with open_recording(frf_file) as rec:
        cfg = rec.rig_config()
    ref = article_flexural(cfg, "active")
    (p,) = a.broadband
    modes = p.frf.modes["active_shroud_accel"].modes
    got = np.array([m.frequency_hz for m in modes])
    assert got.size >= 3
    # the goal: within 0.5 % of the test article's own values (measured: ~0.01 %)
    np.testing.assert_allclose(got[:3], ref, rtol=0.005)
    # the test article's damping ratio 1.2 %, every mode, within 5 %
    np.testing.assert_allclose(
        [m.damping_ratio for m in modes[:3]], cfg.test_article.damping_ratio, rtol=0.05
    )
    # the Table-2 rows: FEM and AM of the nominal rig beside EM, the article's own and the difference
    rows = {(r["blade"], r["mode"]): r for r in a.frequency_table}
    for k in (1, 2, 3):
        r = rows[("active", k)]
        assert r["em_hz"] == pytest.approx(got[k - 1])
        assert abs(r["em_vs_article_pct"]) < 0.5
        assert r["fem_vs_em_pct"] == pytest.approx(100 * (r["fem_hz"] - r["em_hz"]) / r["em_hz"])
        assert r["am_hz"] == pytest.approx(r["fem_hz"], rel=0.005)  # AM and FEM of the nominal rig agree
    # the passive blade is not reached by the force with the gap open: no modes, said so
    assert not p.frf.modes["passive_shroud_accel"].modes
    assert np.isnan(rows[("passive", 1)]["em_hz"])
    assert any(n.startswith("passive blade: the passive blade was not excited") for n in a.notes), a.notes
    assert any("passive_shroud_accel: the passive blade was not excited" in n for n in p.notes), p.notes


def test_frf_kinds_convert_by_frequency(frf_file):
    from rigtools.recording_analysis.dispatch import analyze_recording

    acc = analyze_recording(frf_file, method="peak").broadband[0].frf.estimate
    rec = analyze_recording(frf_file, kind="receptance", method="peak").broadband[0]
    f = acc.frequency_hz[1:]
    w2 = (2 * np.pi * f) ** 2
    np.testing.assert_allclose(rec.frf.estimate.h1[0][1:] * -w2, acc.h1[0][1:], rtol=1e-9)
    assert rec.frf.kind == "receptance" and rec.frf.modes["active_shroud_accel"].method == "peak"


def test_a_response_that_is_no_motion_is_one_line_not_a_traceback(frf_file):
    """Found by the type checker: ``--channels drive`` (volts) reached the FRF conversion with no
    kind (None) and ended in a ValueError traceback; now one line naming the channel, exit 2."""
    from rigtools.errors import EXIT_USAGE

    code, _out, err = run_cli(["analyze", str(frf_file), "--channels", "drive"])
    assert code == EXIT_USAGE
    assert "drive is not an acceleration, velocity or displacement (V)" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_cli_analyze_frf_json_and_figures(frf_file, tmp_path):
    code, out, err = run_cli(["analyze", str(frf_file), "--json", "--out", str(tmp_path / "figs")])
    assert code == 0, err
    doc = json.loads(out)
    modes = doc["points"][0]["frf"]["modes"]["active_shroud_accel"]["modes"]
    assert 51 < modes[0]["frequency_hz"] < 53 and modes[0]["coherence"] > 0.99
    assert doc["natural_frequencies"][0]["blade"] == "active"
    names = sorted(p.rsplit("/", 1)[-1] for p in doc["figures"])
    assert "burst-point0-active_shroud_accel-frf.png" in names
    assert all((tmp_path / "figs" / n).stat().st_size > 10_000 for n in names)
    code, out, err = run_cli(["analyze", str(frf_file)])
    assert code == 0 and "natural frequencies" in out and "active" in out
    from rigtools.runtime import WIDE_OUTPUT_COLUMNS

    assert max(len(line) for line in out.splitlines()) <= WIDE_OUTPUT_COLUMNS  # rig's width in a pipe


def test_stepped_sine_curves_match_linear_fem(study_file):
    """First-harmonic accelerance X1/F1 of a linear FEM frequency study against the FE model's
    modal superposition (rigtools.sim.harmonic) at the same frequencies: 1 %."""
    from rigtools.config import load_rig
    from rigtools.recording_analysis.dispatch import analyze_recording
    from rigtools.sim.harmonic import fem_harmonic_response
    from rigtools.sim.rig_model import build_rig_model

    a = analyze_recording(study_file)
    assert [p.kind for p in a.points] == ["periodic"] * 3
    curves = a.response_curves()
    np.testing.assert_allclose(curves["fe"], [40, 52, 60])
    ref = fem_harmonic_response(build_rig_model(load_rig(None).to_params()), curves["fe"], 5.0)
    got = np.abs(curves["frf"]["active_shroud_accel"]) * 5.0
    np.testing.assert_allclose(got, ref.acceleration_amplitude("active_shroud"), rtol=0.01)
    # harmonics of every step: the force fundamental is F0 (pure sine into the model)
    np.testing.assert_allclose(curves["harmonics"]["force"][:, 0], 5.0, rtol=1e-6)
    for p in a.points:
        assert p.to_dict()["modes"] is None and "no modes from a sine record" in p.notes[-1]


def test_chunked_harmonics_of_a_long_synthetic_record(tmp_path, monkeypatch):
    """Multi-tone signals with noise over a non-integer number of periods, read in blocks (the
    window smaller than the record): amplitudes within 0.1 %, phases within 1 mrad; a v1
    parameter name reads with today's name."""
    from rigtools.recording import ChannelSpec, RecordingWriter
    from rigtools.recording_analysis import dispatch, periodic, samples

    monkeypatch.setattr(samples, "BLOCK_SAMPLES", 7001)
    monkeypatch.setattr(periodic, "WINDOW_SAMPLES", 20000)
    rate, fe, n = 10240.0, 37.3, 123457
    t = np.arange(n) / rate
    rng = np.random.default_rng(5)
    f_true = {1: (12.0, 0.3), 5: (0.7, -1.1)}
    a_true = {1: (40.0, 1.0), 6: (3.0, 2.0), 8: (1.5, -0.4), 22: (0.4, 0.9)}
    sig = lambda tones: sum(a * np.cos(2 * np.pi * k * fe * t + ph) for k, (a, ph) in tones.items())
    force = sig(f_true) + 0.01 * rng.standard_normal(n)
    accel = sig(a_true) + 0.02 * rng.standard_normal(n)
    path = tmp_path / "synthetic.h5"
    with RecordingWriter(path, backend="simulated", rig="{}", experiment={"procedure": "sine dwell"}) as w:
        pt = w.begin_point(
            params={"fe": fe, "force_amplitude": 12.0},
            channels=[
                ChannelSpec("force", "N", "force", rate),
                ChannelSpec("active_shroud_accel", "m/s^2", "acceleration", rate),
            ],
        )
        pt.append(np.vstack([force, accel]))
        pt.set_attrs(measured_force_amplitude=12.0)
        pt.end()
    a = dispatch.analyze_recording(path)
    (p,) = a.points
    assert p.params["force_amplitude_measured"] == 12.0 and "measured_force_amplitude" not in p.params
    assert any("last" in n and "harmonics over all" in n for n in p.notes)
    for ch, tones in (("force", f_true), ("active_shroud_accel", a_true)):
        fit = p.dwell.harmonics[ch]
        for k, (amp, ph) in tones.items():
            assert fit.amplitude[k - 1] == pytest.approx(amp, rel=1e-3)
            assert np.angle(np.exp(1j * (fit.phase[k - 1] - ph))) == pytest.approx(0, abs=1e-3)
    row = a.point_rows()[0]
    assert row["active 22·fe, peak (m/s²)"] == pytest.approx(0.4, rel=1e-2)
    assert row["F1 measured, peak (N)"] == pytest.approx(12.0, rel=1e-3)
    json.dumps(a.to_dict(), allow_nan=False)


def test_cli_bad_input_one_line_exit_2(tmp_path, frf_file):
    bad = tmp_path / "x.h5"
    bad.write_bytes(b"not hdf5 at all" * 10)
    for argv in (
        ["analyze", str(bad)],
        ["analyze", str(tmp_path / "missing.h5")],
        ["analyze", str(frf_file), "--channels", "strain_gauge"],
    ):
        code, _out, err = run_cli(argv)
        assert code == 2
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("rig analyze: error:"), err
    assert "strain_gauge" in lines[0]


def test_figures_have_units_and_legends(frf_file, study_file):
    from rigtools.recording_analysis.dispatch import analyze_recording
    from rigtools.report.sections import analysis_figures

    for path in (frf_file, study_file):
        for nf in analysis_figures(analyze_recording(path, method="peak")):
            for ax in nf.figure.axes:
                if not ax.get_visible() or not ax.lines:
                    continue
                assert "(" in ax.get_ylabel() and ")" in ax.get_ylabel(), (nf.name, ax.get_ylabel())
                if ax.get_xlabel():
                    assert "(" in ax.get_xlabel(), (nf.name, ax.get_xlabel())
                ylabel = ax.get_ylabel()
                if "amplitude" in ylabel:
                    assert "peak" in ylabel or "RMS" in ylabel
                data_lines = [l for l in ax.lines if not l.get_label().startswith("_")]
                if len(data_lines) > 1:
                    assert ax.get_legend() is not None, nf.name
                    styles = {(l.get_color(), l.get_linestyle(), l.get_marker()) for l in data_lines}
                    assert len(styles) == len(data_lines), nf.name


def test_tap_test_record_without_frames_gives_the_mode(tmp_path):
    """Four hammer taps on a known SDOF (no fe, no frame length: one frame per tap), with noise:
    the natural frequency within 0.5 % and the damping ratio within 5 %, by LSCF and by peak."""
    from scipy import signal

    from rigtools.recording import ChannelSpec, RecordingWriter
    from rigtools.recording_analysis.dispatch import analyze_recording

    rate, n = 8192.0, 4 * 8192 + 3000
    fn, zeta, m = 143.0, 0.01, 0.2
    wn = 2 * np.pi * fn
    t = np.arange(n) / rate
    pulse = np.where(t < 2.5e-4, np.sin(np.pi * t / 2.5e-4), 0.0)
    force = sum(a * np.roll(pulse, at) for a, at in ((50, 100), (35, 8300), (60, 16500), (42, 24700)))
    # accelerance of m x'' + c x' + k x = F: a = s^2 / (m (s^2 + 2 zeta wn s + wn^2)) F
    sys_a = signal.dlti(
        *signal.cont2discrete(([1.0, 0, 0], [m, 2 * zeta * wn * m, wn**2 * m]), 1 / rate, method="bilinear")[
            :2
        ],
        dt=1 / rate,
    )
    _, accel = signal.dlsim(sys_a, force)
    accel = accel[:, 0] + 0.002 * np.random.default_rng(1).standard_normal(n)
    path = tmp_path / "tap.h5"
    with RecordingWriter(path, backend="simulated", rig="{}", experiment={"procedure": "tap test"}) as w:
        pt = w.begin_point(
            params={},
            channels=[
                ChannelSpec("force", "N", "force", rate),
                ChannelSpec("passive_shroud_accel", "m/s^2", "acceleration", rate),
            ],
        )
        pt.append(np.vstack([force, accel]))
        pt.end()
    for method in ("lscf", "peak"):
        a = analyze_recording(path, method=method)
        (p,) = a.broadband
        modes = p.frf.modes["passive_shroud_accel"].modes
        assert len(modes) == 1, p.notes
        # the bilinear map warps frequency by tan(w T/2) / (T/2): 0.01 % here
        assert modes[0].frequency_hz == pytest.approx(fn, rel=0.005)
        assert modes[0].damping_ratio == pytest.approx(zeta, rel=0.05)
        assert any("4 hit(s), one 8200-sample frame per hit" in n for n in p.notes), p.notes


def test_frf_set_of_several_responses_is_identified_together(tmp_path):
    """An FRF set of three responses over one reference, exact two-mode accelerances with modal
    constants phi_r * phi_0: rig analyze fits the three together (one LSCF, shapes checked between
    orders): the same two modes at every response (frequency 1e-6, damping 1e-5), each response's
    own modal constant (1e-5), shapes stable (MAC > 0.999), one note and one stabilisation chart
    for the three."""
    from rigtools.frf_set import FRFSet, write_frf_set
    from rigtools.recording_analysis.dispatch import analyze_recording
    from rigtools.report.sections import analysis_figures

    f = np.arange(0, 400.001, 0.25)
    fn, zeta = np.array([61.0, 147.0]), np.array([0.01, 0.02])
    phi = np.array([[1.0, 0.8], [0.6, -0.9], [-0.4, 0.5]])  # (response, mode); force at response 0
    w, wn = 2 * np.pi * f[:, None], 2 * np.pi * fn
    h = ((phi * phi[0]) @ (-(w**2) / (wn**2 - w**2 + 2j * zeta * wn * w)).T).astype(complex)
    path = tmp_path / "three.h5"
    write_frf_set(path, FRFSet(f, h, np.ones(h.shape), ["a", "b", "c"], "force", "accelerance"))
    ana = analyze_recording(path)
    (p,) = ana.broadband
    for r, row in zip("abc", phi * phi[0], strict=True):
        got = p.frf.modes[r].modes
        np.testing.assert_allclose([m.frequency_hz for m in got], fn, rtol=1e-6)
        np.testing.assert_allclose([m.damping_ratio for m in got], zeta, rtol=1e-5)
        np.testing.assert_allclose([m.residue.real for m in got], row, rtol=1e-5)
        assert all(m.mac_min > 0.999 for m in got)
    assert sum("identified together" in n for n in p.notes) == 1
    assert sum(nf.name.endswith("-stabilisation") for nf in analysis_figures(ana)) == 1
    code, out, err = run_cli(["analyze", path, "--json"])
    assert code == 0, err
    doc = json.loads(out)["points"][0]["frf"]["modes"]
    assert {r: [round(m["frequency_hz"], 3) for m in doc[r]["modes"]] for r in "abc"} == {
        r: [61.0, 147.0] for r in "abc"
    }
