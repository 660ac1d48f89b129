"""rig import tdms / lvm / uff on files the toolkit did not make (issue 18, item 4).

- every TDMS file npTDMS ships as test data: imported or refused per channel, one line each;
  a unit-less log imported with --units; channels of unequal length kept whole; a °C channel
  kept in K; a log named as LabVIEW names channels (Force, Acceleration) analysed;
- LVM: a file written here to NI's format (decimal comma, two segments, multi headings, X column)
  and the ladisk beam's .lvm.gz (../shared/data) read back equal;
- UFF 58: time records and FRFs written by pyuff and by rig export read back equal; the
  ufffiles-hammer time record and FRF (../shared/data; its modes: test_measured_data).
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pytest
import pyuff
from cli_helpers import acquire_frf, run_cli
from nptdms import ChannelObject, GroupObject, RootObject, TdmsFile, TdmsWriter

from rigtools.frf_set import read_frf_set
from rigtools.interop.channels import storable_name
from rigtools.recording import open_recording
from rigtools.recording.validate import check_recording

NPTDMS_DATA = Path(__import__("nptdms").__file__).parent / "test" / "data"
G = 9.80665
#: a short burst-random FRF test: the UFF export tests read it (made once)
SHORT_BURST = acquire_frf("burst", band="20 Hz:1500 Hz", frame="0.25 s", averages=3, seed=3)


def _import(*args):
    return run_cli(["import", *map(str, args)])


def _lines(out: str, word: str) -> list[str]:
    return [line for line in out.splitlines() if line.startswith(word)]


# ---------------------------------------------------------------------------------------- TDMS
NPTDMS_FILES = sorted(NPTDMS_DATA.glob("*.tdms"))


@pytest.mark.parametrize("path", NPTDMS_FILES, ids=[p.name for p in NPTDMS_FILES])
def test_every_nptdms_file_imported_or_refused_per_channel(path, tmp_path):
    out = tmp_path / "o.h5"
    tdms = TdmsFile.read(path)
    channels = [(g.name, c) for g in tdms.groups() for c in g.channels()]
    code, stdout, err = _import("tdms", path, out)
    with_units = [c for _, c in channels if str(c.properties.get("unit_string", "")).strip()]
    if with_units:
        assert code == 0, err
        assert len(_lines(stdout, "kept")) + len(_lines(stdout, "skipped")) == len(channels)
        with open_recording(out) as rec:
            got = {(p.params["source_group"], n): p.channels[n] for p in rec.points for n in p.channels}
            assert len(got) == len(with_units)
            for g, c in channels:
                name = storable_name(c.name)
                np.testing.assert_array_equal(got[(g, name)][:], np.asarray(c[:], float))  # scaled by npTDMS
        assert check_recording(out).valid
    else:
        # no channel has units: refused, one line naming every channel and why
        assert code == 2 and not out.exists()
        line = err.strip().splitlines()
        assert len(line) == 1 and line[0].count("skipped ") == len(channels), err
        assert "give --units" in line[0]


def test_unitless_log_imported_with_units(tmp_path):
    src = NPTDMS_DATA / "big_endian.tdms"
    out = tmp_path / "o.h5"
    code, stdout, err = _import(
        "tdms", src, out, "--units", "Amplitude sweep=V", "--units", "Measured Data/Phase sweep=deg"
    )
    assert code == 0, err
    tdms = TdmsFile.read(src)
    with open_recording(out) as rec:
        (p,) = rec.points
        amp, phase = p.channels["Amplitude_sweep"], p.channels["Phase_sweep"]
        assert (amp.units, phase.units, phase.quantity) == ("V", "rad", "angle")
        assert amp.sample_rate == pytest.approx(1000.0)
        np.testing.assert_array_equal(amp[:], tdms["Measured Data"]["Amplitude sweep"][:])
        np.testing.assert_allclose(phase[:], np.radians(tdms["Measured Data"]["Phase sweep"][:]), rtol=1e-15)
    assert "units from --units" in stdout and len(_lines(stdout, "kept")) == 2


def _lab_log(path, *, lengths=(51200, 51200, 1000, 51200)):
    """A lab's log: force (N), an accelerometer (g), a thermocouple (°C, logged slower and
    shorter), a channel without unit_string."""
    rng = np.random.default_rng(5)
    data = [rng.standard_normal(n) for n in lengths]
    props = {"wf_increment": 1 / 51200.0, "wf_start_offset": 0.0}
    with TdmsWriter(str(path)) as w:
        w.write_segment(
            [
                RootObject({"name": "lab log"}),
                GroupObject("Log"),
                ChannelObject("Log", "Force", data[0], properties={**props, "unit_string": "N"}),
                ChannelObject("Log", "Acceleration", data[1], properties={**props, "unit_string": "g"}),
                ChannelObject("Log", "Temperature", data[2] + 20, properties={**props, "unit_string": "°C"}),
                ChannelObject("Log", "Spare", data[3], properties=props),
            ]
        )
    return data


def test_unequal_lengths_kept_whole_temperature_kept_unitless_skipped(tmp_path):
    src, out = tmp_path / "log.tdms", tmp_path / "log.h5"
    force, acc, temp, _ = _lab_log(src)
    code, stdout, err = _import("tdms", src, out, "--json")
    assert code == 0, err
    doc = json.loads(stdout)
    actions = {c["source"]: c["action"] for c in doc["channels"]}
    assert actions == {
        "Log/Force": "kept",
        "Log/Acceleration": "kept",
        "Log/Temperature": "kept",
        "Log/Spare": "skipped",
    }
    with open_recording(out) as rec:
        assert [sorted(p.channels) for p in rec.points] == [["Acceleration", "Force"], ["Temperature"]]
        p0, p1 = rec.points
        assert p0.n_samples == 51200 and p1.n_samples == 1000  # none cut to the shortest
        np.testing.assert_array_equal(p0.channels["Force"][:], force)
        np.testing.assert_allclose(p0.channels["Acceleration"][:], acc * G, rtol=1e-15)
        t = p1.channels["Temperature"]
        assert (t.units, t.quantity) == ("K", "temperature")
        np.testing.assert_allclose(t[:], temp + 20 + 273.15, rtol=1e-15)
        assert p0.params["reference_channel"] == "Force" and "reference_channel" not in p1.params
    assert check_recording(out).valid
    code, stdout, _ = _import("tdms", src, tmp_path / "o2.h5")
    assert len(_lines(stdout, "kept")) == 3 and len(_lines(stdout, "skipped")) == 1
    assert "skipped Log/Spare: no units in the file; give --units Spare=UNIT" in stdout


def test_group_channel_selection_map_and_reference(tmp_path):
    src, out = tmp_path / "log.tdms", tmp_path / "log.h5"
    _lab_log(src)
    code, stdout, err = _import(
        "tdms", src, out, "--group", "Log", "--channel", "Force", "--channel", "Log/Spare",
        "--units", "Spare=N", "--map", "Spare=hammer", "--reference", "hammer",
    )  # fmt: skip
    assert code == 0, err
    with open_recording(out) as rec:
        (p,) = rec.points
        assert sorted(p.channels) == ["Force", "hammer"] and p.params["reference_channel"] == "hammer"
    assert "excitation hammer (named with --reference)" in stdout
    for bad, named in (
        (["--group", "Nope"], "--group: no group 'Nope' in the file (groups: Log)"),
        (["--channel", "Nope"], "Nope"),
        (["--units", "Force=furlongs"], "furlongs"),
        (["--map", "Nope=x"], "Nope"),
    ):
        code, _, err = _import("tdms", src, tmp_path / "bad.h5", *bad)
        # every case: exit 2, one line, naming the bad value (each checked on its own)
        assert code == 2, (bad, code, err)
        assert len(err.strip().splitlines()) == 1, (bad, err)
        assert named in err, (bad, err)
        assert not (tmp_path / "bad.h5").exists(), bad


def test_labview_named_log_analyses(tmp_path, public_data):
    """Channels named as LabVIEW names them keep their names; the force is found by its quantity."""
    d = np.load(public_data("ladisk-impact-beam", "two_hits.npz"))
    src, out = tmp_path / "beam.tdms", tmp_path / "beam.h5"
    props = {"wf_increment": 1 / float(d["fs"]), "wf_start_offset": 0.0}
    with TdmsWriter(str(src)) as w:
        w.write_segment(
            [
                GroupObject("Impact"),
                ChannelObject(
                    "Impact", "Force", d["force_n"].ravel(), properties={**props, "unit_string": "N"}
                ),
                ChannelObject(
                    "Impact", "Acceleration", d["acc_g"].ravel(), properties={**props, "unit_string": "g"}
                ),
            ]
        )
    assert _import("tdms", src, out)[0] == 0
    code, stdout, err = run_cli(["analyze", str(out), "--json"])
    assert code == 0, err
    frf = json.loads(stdout)["points"][0]["frf"]
    assert frf["frf_method"]["excitation"] == "impact" and len(frf["modes"]["Acceleration"]["modes"]) >= 3


# ----------------------------------------------------------------------------------------- LVM
def _lvm_text(segments) -> str:
    """NI's LVM layout (Writer_Version 2): tab separated, decimal comma, multi headings, one X
    column; ``segments`` is a list of ``(names, units, dt, data (n, k))``."""
    head = [
        "LabVIEW Measurement\t",
        "Writer_Version\t2",
        "Reader_Version\t2",
        "Separator\tTab",
        "Decimal_Separator\t,",
        "Multi_Headings\tYes",
        "X_Columns\tOne",
        "Time_Pref\tRelative",
        "Operator\ttest",
        "***End_of_Header***\t",
        "",
    ]
    body = []
    for names, units, dt, data in segments:
        k = len(names)

        def row(key, values):
            return key + "\t" + "\t".join(values) + "\t"

        def c(v):
            return repr(float(v)).replace(".", ",")

        body += [
            row("Channels", [str(k)] + [""] * (k - 1)),
            row("Samples", [str(len(data))] * k),
            row("Y_Unit_Label", units),
            row("X_Dimension", ["Time"] * k),
            row("X0", ["0,0000000000000000E+0"] * k),
            row("Delta_X", [c(dt)] * k),
            "***End_of_Header***\t",
            "X_Value\t" + "\t".join(names) + "\tComment",
        ]
        body += [c(i * dt) + "\t" + "\t".join(c(v) for v in r) for i, r in enumerate(data)]
        body += [""]
    return "\n".join(head + body) + "\n"


def test_lvm_round_trip_two_segments_decimal_comma(tmp_path):
    rng = np.random.default_rng(1)
    a, b = rng.standard_normal((300, 2)), rng.standard_normal((200, 2))
    text = _lvm_text(
        [
            (["Force", "Acceleration"], ["Newtons", "g"], 1e-4, a),
            (["Force", "Acceleration"], ["N", "m/s^2"], 2e-4, b),
        ]
    )
    src = tmp_path / "t.lvm.gz"
    src.write_bytes(gzip.compress(text.encode()))
    out = tmp_path / "t.h5"
    code, stdout, err = _import("lvm", src, out)
    assert code == 0, err
    assert len(_lines(stdout, "kept")) == 4
    with open_recording(out) as rec:
        p0, p1 = rec.points
        assert (p0.sample_rate, p1.sample_rate) == (pytest.approx(1e4), pytest.approx(5e3))
        np.testing.assert_array_equal(p0.channels["Force"][:], a[:, 0])
        np.testing.assert_allclose(p0.channels["Acceleration"][:], a[:, 1] * G, rtol=1e-15)
        np.testing.assert_array_equal(p1.channels["Acceleration"][:], b[:, 1])
        assert p0.params["reference_channel"] == p1.params["reference_channel"] == "Force"
    code, _, err = _import("lvm", tmp_path / "t.h5", tmp_path / "x.h5")
    assert code == 2 and "not a LabVIEW measurement file" in err


def test_ladisk_lvm_imports_equal_and_analyses(tmp_path, public_data):
    beam = public_data("ladisk-impact-beam")
    out = tmp_path / "beam.h5"
    code, stdout, err = _import("lvm", beam / "acceleration_hit1.lvm.gz", out)
    assert code == 0, err
    assert (
        "kept    segment 1/Force (Trigger) -> Force_Trigger: force in N, Newtons -> N, the excitation"
        in stdout
    )
    d = np.load(beam / "two_hits.npz")
    with open_recording(out) as rec:
        (p,) = rec.points
        assert p.n_samples == 50030 and p.sample_rate == pytest.approx(50000.0)
        np.testing.assert_allclose(p.channels["Acceleration_Trigger"][:50000], d["acc_g"][0] * G, rtol=1e-15)
        np.testing.assert_array_equal(p.channels["Force_Trigger"][:50000], d["force_n"][0])
    code, stdout, err = run_cli(["analyze", str(out)])
    assert code == 0, err
    assert len(stdout.strip().splitlines()) < 25 and "impact" in stdout


# ----------------------------------------------------------------------------------------- UFF
def _time_record(name, node, data, dt, units, quantity):
    """A complete dataset-58 dict for pyuff (every field filled, ASCII), the ordinate in ``units``."""
    from rigtools.interop.uff import FUNC_TIME, UffFunction

    d = UffFunction(
        FUNC_TIME, f"{name} time", (name, node), ("", 0), quantity, "", np.arange(data.size) * dt, data, units
    ).dataset()
    return {**d, "binary": 0, "rsp_dir": 3}


def test_uff_time_records_from_pyuff_round_trip(tmp_path):
    rng = np.random.default_rng(2)
    f, a = rng.standard_normal(512), rng.standard_normal(512)
    src = tmp_path / "t.uff"
    pyuff.UFF(str(src)).write_sets(
        [
            _time_record("hammer", 1, f, 1 / 1024, "N", "force"),
            _time_record("acc", 2, a, 1 / 1024, "g", "acceleration"),
        ],
        "add",
    )
    out = tmp_path / "t.h5"
    code, _, err = _import("uff", src, out)
    assert code == 0, err
    with open_recording(out) as rec:
        (p,) = rec.points
        assert (
            sorted(p.channels) == ["acc_2_Z", "hammer_1_Z"] and p.params["reference_channel"] == "hammer_1_Z"
        )
        np.testing.assert_allclose(p.channels["hammer_1_Z"][:], f, rtol=1e-10)
        np.testing.assert_allclose(p.channels["acc_2_Z"][:], a * G, rtol=1e-10)
        assert p.sample_rate == 1024.0


def test_uff_export_frfs_and_time_round_trip(tmp_path, sim_recording):
    """rig export uff writes; rig import uff reads back the same FRFs (an FRF set) and time records."""
    rec_path = sim_recording(SHORT_BURST, "burst.h5")
    uff = tmp_path / "burst.uff"
    assert run_cli(["export", "uff", str(rec_path), str(uff), "--what", "frf"])[0] == 0
    exported = [s for s in pyuff.UFF(str(uff)).read_sets() if s["type"] == 58 and s["func_type"] == 4]
    code, stdout, err = _import("uff", uff, tmp_path / "frf.h5")
    assert code == 0, err
    fs = read_frf_set(tmp_path / "frf.h5")
    assert fs.kind == "accelerance" and len(fs.responses) == len(exported)
    for row, s in enumerate(exported):
        np.testing.assert_allclose(fs.frf[row], s["data"], rtol=1e-12)
    code, stdout, err = run_cli(["analyze", str(tmp_path / "frf.h5"), "--json"])
    assert code == 0, err
    assert json.loads(stdout)["points"][0]["frf"]["modes"]
    assert run_cli(["export", "uff", str(rec_path), str(tmp_path / "t.uff"), "--what", "time"])[0] == 0
    code, _, err = _import("uff", tmp_path / "t.uff", tmp_path / "t.h5")
    assert code == 0, err
    with open_recording(rec_path) as a, open_recording(tmp_path / "t.h5") as b:
        for name, ch in a.points[0].channels.items():
            back = next(c for n, c in b.points[0].channels.items() if n.startswith(name[:10]))
            np.testing.assert_array_equal(back[:], ch[:])


def test_our_export_reads_as_accelerance_in_sdypy(tmp_path, sim_recording):
    from sdypy import EMA

    rec_path = sim_recording(SHORT_BURST, "burst.h5")
    uff = tmp_path / "all.uff"
    assert run_cli(["export", "uff", str(rec_path), str(uff)])[0] == 0
    model = EMA.Model(lower=20, upper=1500, pol_order_high=10)
    model.read_uff(str(uff))
    assert model.frf_form == "accelerance"
    first = next(s for s in pyuff.UFF(str(uff)).read_sets() if s["type"] == 58)
    assert first["func_type"] == 4
    np.testing.assert_allclose(model.frf[0], first["data"][: model.freq.size], rtol=1e-12)
    np.testing.assert_allclose(model.freq, first["x"][: model.freq.size], rtol=1e-12)


def test_ufffiles_time_record(tmp_path, public_data):
    hammer = public_data("ufffiles-hammer")
    out = tmp_path / "t.h5"
    code, stdout, err = _import("uff", hammer / "dataset58_time.unv", out)
    assert code == 0, err
    with open_recording(out) as rec:
        (p,) = rec.points
        (name,) = p.channels
        ch = p.channels[name]
        assert (ch.units, ch.quantity, len(ch)) == ("N", "force", 4096)  # num_pts, not pyuff's padding
        assert ch.sample_rate == 2048.0  # 1/4.88281E-04 within its 6 written digits
        ref = pyuff.UFF(str(hammer / "dataset58_time.unv")).read_sets()
        np.testing.assert_array_equal(ch[:], ref["data"][:4096])
    assert "excitation" in stdout


def test_ufffiles_frf_kind_checked_against_data(tmp_path, public_data):
    frf = public_data("ufffiles-hammer", "dataset58_FRF.unv")
    out = tmp_path / "frf.h5"
    code, stdout, err = _import("uff", frf, out)
    assert code == 0, err
    fs = read_frf_set(out)
    # the labels disagree (axis 'Receptance', units '(m/s)/N'); the data are accelerance: peaks
    # near +-90 deg (not mobility) and |H| rising with frequency away from the peaks
    assert fs.kind == "accelerance" and "from the data" in stdout
    assert fs.frequency_hz.size == 1600 and fs.frequency_hz[-1] == 799.5
    code, stdout, err = _import("uff", frf, tmp_path / "r.h5", "--units", ".1.Z-=m")
    assert code == 0 and read_frf_set(tmp_path / "r.h5").kind == "receptance", err


def test_every_unit_an_import_writes_is_one_a_recording_may_hold():
    """The import's unit table converts only to units rig check and the readers accept."""
    from rigtools.interop.channels import UNITS
    from rigtools.recording.schema import CHANNEL_UNITS

    assert {si.units for si in UNITS.values()} <= set(CHANNEL_UNITS)
