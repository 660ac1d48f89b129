"""UFF 58 export, TDMS import and SEP005 dicts: round trips through the real libraries (pyuff,
npTDMS) equal to the source; malformed inputs give one line and exit 2."""

from __future__ import annotations

import re

import numpy as np
import pytest
import pyuff
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

from rigtools.analysis.frf import FRFMethod
from rigtools.analysis.spectra import amplitude_spectrum
from rigtools.cli import main
from rigtools.config import load_rig
from rigtools.interop.sep005 import to_sep005
from rigtools.interop.tdms import LBF, G
from rigtools.recording import ChannelSpec, RecordingWriter, open_recording

FS = 2048.0
N = 8192


def _signals():
    rng = np.random.default_rng(7)
    force = rng.standard_normal(N)
    # a known linear response: a 2-tap filter of the force (FRF 0.5 + 0.25 e^{-iw/fs})
    accel = 0.5 * force + 0.25 * np.concatenate([[0.0], force[:-1]]) + 1e-3 * rng.standard_normal(N)
    return force, accel


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("uff") / "frf.h5"
    force, accel = _signals()
    with RecordingWriter(
        path, backend="simulated", rig=load_rig(None).to_json(), experiment={"procedure": "frf"}
    ) as rec:
        p = rec.begin_point(
            params={},
            channels=[
                ChannelSpec("force", "N", "force", FS),
                ChannelSpec("active_shroud_accel", "m/s^2", "acceleration", FS),
            ],
        )
        p.append(np.vstack([force, accel]))
        p.end()
    return path


def _read(path):
    sets = pyuff.UFF(str(path)).read_sets()
    return sets if isinstance(sets, list) else [sets]


def test_uff_round_trip_equals_source(recording, tmp_path, capsys):
    out = tmp_path / "frf.uff"
    # continuous random force: rig analyze's estimate (Hann, 50 % overlap), frames of 256 asked for
    args = ["export", "uff", str(recording), str(out), "--excitation", "random", "--frame-samples", "256"]
    assert main(args) == 0
    sets = _read(out)
    assert sets[0]["type"] == 164 and sets[0]["units_code"] == 1  # SI
    f58 = [s for s in sets if s["type"] == 58]
    force, accel = _signals()
    by = {(s["func_type"], s["rsp_node"]): s for s in f58}
    # time records: values bit for bit, abscissa to the format's E13.5 increment
    t_force, t_acc = by[(1, 1)], by[(1, 2)]
    np.testing.assert_array_equal(t_force["data"], force)
    np.testing.assert_array_equal(t_acc["data"], accel)
    assert t_acc["abscissa_inc"] == pytest.approx(1 / FS, rel=1e-5)
    assert (t_force["ordinate_spec_data_type"], t_force["ordinate_force_unit_exp"]) == (13, 1)
    assert (t_acc["ordinate_spec_data_type"], t_acc["ordinate_len_unit_exp"]) == (12, 1)
    assert t_acc["abscissa_spec_data_type"] == 17 and t_acc["rsp_dir"] == 2
    # no reference for time records and spectra (node 0); the recording's date in ID line 3, where
    # dataset 58 keeps "when the function was created" (DD-MMM-YY HH:MM:SS; it was in line 4)
    assert t_acc["ref_node"] == 0 and t_force["ref_node"] == 0
    assert re.fullmatch(r"\d\d-[A-Z][a-z]{2}-\d\d \d\d:\d\d:\d\d", t_acc["id3"].strip())
    # ID line 4: the full channel names (the entity fields keep 10 characters); the reference's for FRFs
    assert t_acc["id4"].strip() == "channel active_shroud_accel"
    # FRFs first: readers that take the FRF kind from the first record (sdypy-EMA) read accelerance
    assert f58[0]["func_type"] == 4
    # spectra equal the analysis layer's
    _f, amp = amplitude_spectrum(accel, FS)
    spec = by[(2, 2)]
    np.testing.assert_allclose(spec["data"], amp**2 / 2, rtol=1e-15, atol=0)
    assert spec["ordinate_len_unit_exp"] == 2  # (m/s^2)^2
    # FRF and coherence: reference node 1 (force), numerator acceleration, denominator force
    frf, coh = by[(4, 2)], by[(6, 2)]
    est = FRFMethod("random", 256).estimate([np.vstack([force, accel])], FS)
    assert coh["ordinate_axis_lab"] == "coherence" and coh["ordinate_spec_data_type"] == 1
    np.testing.assert_allclose(frf["data"], est.h1[0], rtol=1e-12, atol=0)  # the one estimate: rig analyze's
    np.testing.assert_allclose(coh["data"], est.coherence[0], rtol=1e-12, atol=1e-15)
    assert (frf["ref_node"], frf["orddenom_spec_data_type"], frf["orddenom_force_unit_exp"]) == (1, 13, 1)
    assert frf["abscissa_spec_data_type"] == 18
    assert frf["id4"].strip() == "channel active_shroud_accel; reference force"
    # and the physics: the known FRF 0.5 + 0.25 exp(-i w / fs) where coherent
    w = 2 * np.pi * est.frequency_hz / FS
    np.testing.assert_allclose(est.h1[0][1:-1], (0.5 + 0.25 * np.exp(-1j * w))[1:-1], atol=2e-3)
    assert "1 frf" in capsys.readouterr().out


def test_sep005_dicts(recording):
    _force, accel = _signals()
    with open_recording(recording) as rec:
        chans = to_sep005(rec, point=0)
    assert [c["name"] for c in chans] == ["force", "active_shroud_accel"]
    assert all(c["fs"] == FS for c in chans)
    assert [c["unit_str"] for c in chans] == ["N", "m/s^2"]
    np.testing.assert_array_equal(chans[1]["data"], accel)


def _write_tdms(path, *, units=("g", "Newtons"), increment=1 / FS, extra=None):
    rng = np.random.default_rng(3)
    a, f = rng.standard_normal(1000), rng.standard_normal(1000)
    props = lambda u: {
        k: v
        for k, v in {
            "unit_string": u,
            "wf_increment": increment,
            "wf_start_offset": 0.0,
        }.items()
        if v is not None
    }
    with TdmsWriter(str(path)) as w:
        objs = [
            RootObject({"name": "log"}),
            GroupObject("Task"),
            ChannelObject("Task", "Dev1/ai1", a, properties=props(units[0])),
            ChannelObject("Task", "Dev1/ai0", f, properties=props(units[1])),
        ]
        if extra:
            objs += extra
        w.write_segment(objs)
    return a, f


def test_tdms_import_round_trip(tmp_path):
    src, out = tmp_path / "log.tdms", tmp_path / "log.h5"
    a, f = _write_tdms(src, units=("g", "lbf"))
    assert main(["import", "tdms", str(src), str(out), "--rename", "Dev1/ai0=force"]) == 0
    with open_recording(out) as rec:
        assert rec.backend == "tdms" and rec.complete
        p = rec.points[0]
        assert set(p.channels) == {"Dev1_ai1", "force"}
        acc = p.channels["Dev1_ai1"]
        assert (acc.units, acc.quantity, acc.sample_rate) == ("m/s^2", "acceleration", FS)
        np.testing.assert_allclose(acc.read(), a * G, rtol=1e-15)
        np.testing.assert_allclose(p.channels["force"].read(), f * LBF, rtol=1e-15)
        assert p.channels["force"].units == "N"


@pytest.mark.parametrize("case", ["not_tdms", "no_units", "no_timing", "bad_units", "exists"])
def test_malformed_inputs_one_line_exit_2(tmp_path, capsys, case):
    """Nothing importable (not TDMS, no channel with units or timing) or an existing OUT: one
    line, exit 2. (One channel without units is skipped, not the file: tests/rigtools/test_imports.py.)"""
    src, out = tmp_path / "in.tdms", tmp_path / "out.h5"
    if case == "not_tdms":
        src.write_bytes(b"this is not a TDMS file at all" * 10)
    elif case == "no_units":
        _write_tdms(src, units=(None, None))
    elif case == "no_timing":
        _write_tdms(src, increment=None)
    elif case == "bad_units":
        _write_tdms(src, units=("furlongs", "parsecs"))
    else:
        _write_tdms(src)
        out.write_bytes(b"keep me")
    assert main(["import", "tdms", str(src), str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rig import: error:"), err
    if case == "exists":
        assert out.read_bytes() == b"keep me"
    else:
        assert not out.exists()


@pytest.mark.parametrize("case", ["not_h5", "exists", "self", "bad_what"])
def test_export_bad_input(tmp_path, recording, capsys, case):
    src, out = recording, tmp_path / "x.uff"
    args = []
    if case == "not_h5":
        src = tmp_path / "no.h5"
        src.write_text("plain text")
    elif case == "exists":
        out.write_text("keep")
    elif case == "self":
        out = recording
        args = ["--overwrite"]
    else:
        args = ["--what", "modes"]
    before = recording.read_bytes()
    assert main(["export", "uff", str(src), str(out), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rig export: error:"), err
    assert recording.read_bytes() == before


def test_uff_direction_codes_round_trip_through_pyuff(tmp_path):
    """Every UFF direction code is written as given and read back by pyuff (rotations 4-6 were
    written and named as Z), and an import names each record by it (``acc:5+RX``)."""
    from rigtools.interop.uff import FUNC_FRF, UffFunction, direction_text, record_name, write_uff

    codes = [1, 2, 3, 4, 5, 6, -1, -2, -3, -4, -5, -6]
    f = np.linspace(0.0, 100.0, 11)
    functions = [
        UffFunction(
            FUNC_FRF,
            f"dir {c}",
            ("acc", 5),
            ("hammer", 1),
            "acceleration",
            "force",
            f,
            np.full(f.size, 1.0 + 1j * c),
            "m/s^2/N",
            response_direction=c,
            reference_direction=-c,
        )
        for c in codes
    ]
    write_uff(tmp_path / "d.uff", functions)
    got = [s for s in _read(tmp_path / "d.uff") if s["type"] == 58]
    assert [(s["rsp_dir"], s["ref_dir"]) for s in got] == [(c, -c) for c in codes]
    assert [record_name(s) for s in got] == [
        "acc:5+X",
        "acc:5+Y",
        "acc:5+Z",
        "acc:5+RX",
        "acc:5+RY",
        "acc:5+RZ",
        "acc:5-X",
        "acc:5-Y",
        "acc:5-Z",
        "acc:5-RX",
        "acc:5-RY",
        "acc:5-RZ",
    ]
    assert (direction_text(0), direction_text(7), record_name({"rsp_node": 5, "rsp_dir": 9})) == (
        "",
        "",
        "node:5dir9",
    )
    with pytest.raises(ValueError, match="UFF direction code 7 is not one of -6..6"):
        UffFunction(FUNC_FRF, "", ("a", 2), ("f", 1), "acceleration", "force", f, f, "", response_direction=7)
