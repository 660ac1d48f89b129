"""Imports that trust nothing they can check (issue 30, item 2): declared counts, increments and
separators held against the data; one policy for NaN/inf; the parsers' warnings kept off the screen.
Each damaged file is built here from a known array, so the expected result is exact."""

from __future__ import annotations

import logging
import struct

import numpy as np
import pytest
from cli_helpers import run_cli
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter
from test_imports import _lvm_text

from rigtools.interop.checks import number, parser_notes
from rigtools.recording import open_recording

G = 9.80665


def _lvm(tmp_path, data, *, edit=lambda text: text):
    src = tmp_path / "t.lvm"
    src.write_text(edit(_lvm_text([(["Force", "Acceleration"], ["N", "g"], 1e-4, data)])))
    return src


def _import(kind, src, out):
    return run_cli(["import", kind, str(src), str(out)])


@pytest.fixture
def data():
    return np.random.default_rng(3).standard_normal((200, 2))


def test_lvm_declaring_more_samples_than_rows_imports_the_rows_and_says_so(tmp_path, data):
    src = _lvm(tmp_path, data, edit=lambda t: t.replace("Samples\t200\t200", "Samples\t5000\t5000"))
    code, stdout, err = _import("lvm", src, tmp_path / "t.h5")
    assert code == 0, err
    assert "the header declares 5000 samples, the data hold 200: imported 200" in stdout
    with open_recording(tmp_path / "t.h5") as rec:
        np.testing.assert_array_equal(rec.points[0].channels["Force"][:], data[:, 0])


@pytest.mark.parametrize("declared", ["-5", "0", "2,5"])
def test_lvm_sample_count_that_is_no_count_is_refused_by_name(tmp_path, data, declared):
    src = _lvm(
        tmp_path, data, edit=lambda t: t.replace("Samples\t200\t200", f"Samples\t{declared}\t{declared}")
    )
    code, _, err = _import("lvm", src, tmp_path / "t.h5")
    assert code == 2
    assert err.count("\n") == 1 and "is not a positive whole count" in err
    assert not (tmp_path / "t.h5").exists()


def test_lvm_cut_after_its_column_heading_is_one_line(tmp_path, data):
    def cut(text):
        head, _, _ = text.partition("X_Value")
        return head + "X_Value\tForce\tAcceleration\tComment\n"

    code, _, err = _import("lvm", _lvm(tmp_path, data, edit=cut), tmp_path / "t.h5")
    assert code == 2 and "Traceback" not in err
    assert "segment 1 has no data rows after its column heading" in err


def test_lvm_wrong_decimal_separator_is_read_from_the_data(tmp_path, data):
    src = _lvm(tmp_path, data, edit=lambda t: t.replace("Decimal_Separator\t,", "Decimal_Separator\t."))
    code, stdout, err = _import("lvm", src, tmp_path / "t.h5")
    assert code == 0, err
    assert "the header says Decimal_Separator '.', the numbers use ','" in stdout
    with open_recording(tmp_path / "t.h5") as rec:
        point = rec.points[0]
        assert point.sample_rate == pytest.approx(1e4, rel=1e-12)  # Delta_X 1e-4 read with the comma
        np.testing.assert_allclose(point.channels["Acceleration"][:], data[:, 1] * G, rtol=1e-15)


def _tdms(path, values, **props):
    group = GroupObject("g")
    channels = [
        ChannelObject(
            "g", name, v, properties={"unit_string": unit, "wf_increment": props.get("inc", 1 / 51200)}
        )
        for (name, unit), v in zip((("force", "N"), ("accel", "m/s^2")), values, strict=True)
    ]
    with TdmsWriter(path) as writer:
        writer.write_segment([RootObject(), group, *channels])


def test_tdms_increment_written_as_text_with_a_decimal_comma(tmp_path, data):
    src = tmp_path / "t.tdms"
    _tdms(src, data.T, inc="0,0000195312")
    code, _, err = _import("tdms", src, tmp_path / "t.h5")
    assert code == 0, err
    with open_recording(tmp_path / "t.h5") as rec:
        assert rec.points[0].sample_rate == pytest.approx(1 / 0.0000195312, rel=1e-12)


def test_tdms_nan_skips_the_channel_with_its_count_as_lvm_does(tmp_path, data):
    values = data.T.copy()
    values[1, [17, 40, 41]] = [np.nan, np.inf, -np.inf]
    src = tmp_path / "t.tdms"
    _tdms(src, values)
    code, stdout, err = _import("tdms", src, tmp_path / "t.h5")
    assert code == 0, err
    skipped = [line for line in stdout.splitlines() if line.startswith("skipped")]
    assert (
        len(skipped) == 1
        and "3 non-finite value(s) (NaN or inf) among its 200 samples, the first at sample 17" in skipped[0]
    )
    with open_recording(tmp_path / "t.h5") as rec:
        assert list(rec.points[0].channels) == ["force"]
    # the same policy in LVM: the same damage, the same line
    lvm_data = data.copy()
    lvm_data[[17, 40, 41], 1] = [np.nan, np.inf, -np.inf]
    src = _lvm(tmp_path, lvm_data, edit=lambda t: t.replace("nan", "NaN"))
    code, stdout, err = _import("lvm", src, tmp_path / "l.h5")
    assert code == 0, err
    assert "3 non-finite value(s) (NaN or inf) among its 200 samples, the first at sample 17" in stdout


def test_parser_warnings_become_notes_not_screen_output(capsys):
    log = logging.getLogger("nptdms.fake_module")
    log.addHandler(logging.StreamHandler())  # npTDMS gives each module's logger a console handler
    notes: list[str] = []
    with parser_notes(notes, "npTDMS", ("nptdms",)):
        log.warning("Segment at position 1234 is\ntruncated")
        log.warning("Segment at position 1234 is\ntruncated")
    assert notes == ["npTDMS: Segment at position 1234 is truncated"]  # once, on one line
    assert capsys.readouterr().err == ""
    assert len(log.handlers) == 1  # its own handler given back


@pytest.mark.parametrize(
    ("text", "value"),
    [("0,0000195312", 1.95312e-5), ("1.5e-3", 1.5e-3), (2e-5, 2e-5), ("1,5,2", np.nan), (None, np.nan)],
)
def test_number_reads_decimal_commas_and_nothing_else(text, value):
    np.testing.assert_equal(number(text), value)


@pytest.mark.parametrize(
    ("names", "units", "skipped"),
    [
        (
            ("force", "accel"),
            ("m/s^2", "m/s^2"),
            "force: its name says force, its units 'm/s^2' say acceleration",
        ),
        (
            ("Force", "shroud_accel"),
            ("N", "N"),
            "shroud_accel: its name says acceleration, its units 'N' say force",
        ),
    ],
)
def test_a_unit_that_contradicts_the_name_skips_the_channel_saying_both(
    tmp_path, data, names, units, skipped
):
    group = GroupObject("g")
    channels = [
        ChannelObject("g", n, v, properties={"unit_string": u, "wf_increment": 1e-4})
        for n, u, v in zip(names, units, data.T, strict=True)
    ]
    with TdmsWriter(tmp_path / "t.tdms") as writer:
        writer.write_segment([RootObject(), group, *channels])
    code, stdout, err = _import("tdms", tmp_path / "t.tdms", tmp_path / "t.h5")
    assert code == 0, err
    lines = [line for line in stdout.splitlines() if line.startswith("skipped")]
    assert len(lines) == 1 and skipped in lines[0] and "--units" in lines[0] and "--map" in lines[0]
    # the user's word settles it: --map names the channel anew, kept with the file's units
    code, stdout, err = run_cli(
        ["import", "tdms", str(tmp_path / "t.tdms"), str(tmp_path / "m.h5"), "--map", f"{names[0]}=probe"]
        if units[0] == "m/s^2"
        else [
            "import",
            "tdms",
            str(tmp_path / "t.tdms"),
            str(tmp_path / "m.h5"),
            "--map",
            f"{names[1]}=load_cell",
        ]
    )
    assert code == 0, err
    assert not [line for line in stdout.splitlines() if line.startswith("skipped")]


@pytest.mark.parametrize("code", [12, 0])  # 12: acceleration, as analysers write it; 0: unknown
def test_uff_frf_in_g_per_newton_keeps_the_labels_factor_whatever_the_data_type_code(tmp_path, code):
    """A 58 FRF labelled g/N is stored in (m/s^2)/N, x 9.80665, whether or not its data-type code
    also says acceleration (with code 12 the code's factor 1 was kept: 9.81x too small)."""
    import pyuff

    from rigtools.analysis.frf import sdof_frf
    from rigtools.frf_set import read_frf_set
    from rigtools.interop.uff import FUNC_FRF, UffFunction

    f = np.arange(0.0, 500.25, 0.5)
    h_si = sdof_frf(f, 100.0, 0.02, kind="accelerance")
    d = UffFunction(
        FUNC_FRF, "tip over hammer", ("tip", 2), ("hammer", 1), "acceleration", "force", f, h_si / G, "g/N"
    ).dataset()
    d.update(ordinate_spec_data_type=code, ordinate_axis_units_lab="g/N", rsp_dir=3, ref_dir=3)
    src = tmp_path / "g.uff"
    pyuff.UFF(str(src)).write_sets([d], "add")
    code_, stdout, err = _import("uff", src, tmp_path / "g.h5")
    assert code_ == 0, err
    assert "x 9.80665 from its units 'g/N'" in stdout
    fs = read_frf_set(tmp_path / "g.h5")
    np.testing.assert_allclose(fs.frf[0], h_si, rtol=1e-6, atol=1e-9 * np.abs(h_si).max())  # ASCII digits


def _uff_time(tmp_path, values, *, num_pts=None, binary=False):
    import pyuff

    from rigtools.interop.uff import FUNC_TIME, UffFunction

    t = np.arange(values.shape[1]) / 1000.0
    sets = []
    for name, unit, quantity, v in zip(
        ("hammer", "acc"), ("N", "m/s^2"), ("force", "acceleration"), values, strict=True
    ):
        d = UffFunction(FUNC_TIME, name, (name, 1), ("none", 0), quantity, "none", t, v, unit).dataset()
        sets.append({**d, "binary": int(binary)})
    src = tmp_path / "t.uff"
    pyuff.UFF(str(src)).write_sets(sets, "add")
    if num_pts is not None:  # the header's count edited as a cut file would leave it
        text = src.read_text().replace(f"{values.shape[1]:>10d}", f"{num_pts:>10d}", 2)
        src.write_text(text)
    return src


def test_uff_time_record_with_nan_is_skipped_as_tdms_and_lvm_do(tmp_path, data):
    values = data.T.copy()
    values[1, [17, 40, 41]] = [np.nan, np.inf, -np.inf]
    # pyuff writes NaN as 0.0 (and reads an ASCII 'nan' as 0.0): the NaN bytes go into a binary
    # 58b file as a foreign writer would leave them, after the sample before them
    src = _uff_time(tmp_path, values, binary=True)
    raw = bytearray(src.read_bytes())
    for i in (17, 40, 41):
        at = raw.index(struct.pack("<d", values[1, i - 1])) + 8
        raw[at : at + 8] = struct.pack("<d", values[1, i])
    src.write_bytes(bytes(raw))
    code, stdout, err = _import("uff", src, tmp_path / "u.h5")
    assert code == 0, err
    assert "3 non-finite value(s) (NaN or inf) among its 200 samples, the first at sample 17" in stdout


def test_uff_record_declaring_more_values_than_it_holds_says_so(tmp_path, data):
    src = _uff_time(tmp_path, data.T, num_pts=400)
    code, stdout, err = _import("uff", src, tmp_path / "u.h5")
    assert code == 0, err  # pyuff reads the 200 values there are: imported, and said
    assert stdout.count("declares 400 values, holds 200: imported 200 (a cut file?)") == 2


@pytest.mark.parametrize("cut", ["heading", "no-x-value"])
def test_lvm_whose_rows_lvm_read_cannot_place_is_one_line(tmp_path, data, cut):
    """lvm_read's KeyError('data') was shown bare: "cannot read the LabVIEW data ('data')"."""

    def edit(text):
        if cut == "heading":  # the file ends after the segment header, before its column heading
            return text[: text.index("X_Value")]
        return text.replace("X_Value\t", "")  # a column heading without the X column's name

    code, _, err = _import("lvm", _lvm(tmp_path, data, edit=edit), tmp_path / "t.h5")
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "a segment header with no data rows under it" in err and "t.lvm" in err


def test_an_import_stopped_half_way_over_an_old_file_leaves_it_as_it_was(tmp_path):
    """rig import --overwrite stopped by Ctrl-C left half the import (status 'recording') where
    the old recording was: now the import is written beside it and renamed only when whole."""
    import hashlib

    from test_bad_input import _write_recording

    from rigtools.config import default_rig_text
    from rigtools.interop.channels import resolve
    from rigtools.interop.imported import ForeignPoint, write_imported

    old = _write_recording(tmp_path / "keep.h5")
    digest = hashlib.sha256(old.read_bytes()).hexdigest()
    channel = resolve("segment 1/force", "force", "N", mapping={}, units={})

    def read(start, n):
        raise KeyboardInterrupt  # Ctrl-C while the samples are copied

    point = ForeignPoint(params={}, channels=[channel], samples=1000, sample_rate=1000.0, read=read)
    with pytest.raises(KeyboardInterrupt):
        write_imported(old, backend="lvm", rig=default_rig_text(), experiment={"procedure": "import"},
                       points=[point], every=[channel], overwrite=True)  # fmt: skip
    assert hashlib.sha256(old.read_bytes()).hexdigest() == digest
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.endswith(".lock")) == ["keep.h5"]


@pytest.mark.parametrize("increment", [0.0, -0.5])
def test_uff_frfs_on_a_grid_check_would_reject_are_not_written(tmp_path, increment):
    """An FRF record with a zero or negative increment imported with exit 0 into an FRF set
    that rig check then rejected ('frequency not increasing')."""
    import pyuff

    from rigtools.analysis.frf import sdof_frf
    from rigtools.interop.uff import FUNC_FRF, UffFunction

    f = np.arange(0.0, 500.25, 0.5)
    d = UffFunction(
        FUNC_FRF, "tip over hammer", ("tip", 2), ("hammer", 1), "acceleration", "force", f,
        sdof_frf(f, 100.0, 0.02, kind="accelerance"), "m/s^2/N",
    ).dataset()  # fmt: skip
    d.update(rsp_dir=3, ref_dir=3)
    src = tmp_path / "f.uff"
    pyuff.UFF(str(src)).write_sets([d], "add")
    # pyuff writes the increment from the abscissa: the header's increment edited as a foreign writer's
    raw = src.read_bytes()
    assert raw.count(b"  5.00000e-01  ") == 1
    src.write_bytes(raw.replace(b"  5.00000e-01  ", f"  {increment:.5e}  ".encode()))
    code, _, err = _import("uff", src, tmp_path / "f.h5")
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    # 0: read by pyuff, refused by the FRF set's check; negative: pyuff itself cannot read the record
    expected = (
        "not written: the FRF set would be damaged: /frequency" if increment == 0 else "not a readable UFF"
    )
    assert expected in err
    assert not (tmp_path / "f.h5").exists()


def test_lvm_declaring_fewer_samples_than_its_column_holds_says_so(tmp_path, data):
    src = _lvm(tmp_path, data, edit=lambda t: t.replace("Samples\t200\t200", "Samples\t100\t100"))
    code, stdout, err = _import("lvm", src, tmp_path / "t.h5")
    assert code == 0, err
    assert "the header declares 100 samples, its column holds 200 values: imported 100" in stdout


def test_lvm_with_a_byte_order_mark_reads(tmp_path, data):
    src = _lvm(tmp_path, data, edit=lambda t: "\ufeff" + t)
    code, _, err = _import("lvm", src, tmp_path / "t.h5")
    assert code == 0, err


def test_tdms_units_property_is_read_as_its_docstring_says(tmp_path, data):
    channel = ChannelObject("g", "accel", data[:, 0], properties={"units": "g", "wf_increment": 1e-4})
    with TdmsWriter(tmp_path / "t.tdms") as writer:
        writer.write_segment([RootObject(), GroupObject("g"), channel])
    code, stdout, err = _import("tdms", tmp_path / "t.tdms", tmp_path / "t.h5")
    assert code == 0, err
    assert "acceleration in m/s^2, g -> m/s^2 (x 9.80665)" in stdout


def test_uff_record_declaring_fewer_values_than_it_holds_says_so(tmp_path, data):
    """Cut to its declared count silently before (a padded last line holds fewer than 6 extra)."""
    code, stdout, err = _import("uff", _uff_time(tmp_path, data.T, num_pts=100), tmp_path / "u.h5")
    assert code == 0, err
    assert stdout.count("declares 100 values, holds 200: imported 100") == 2
    with open_recording(tmp_path / "u.h5") as rec:
        np.testing.assert_allclose(rec.points[0].channels["hammer_1_Y"][:], data[:100, 0], rtol=1e-5)


@pytest.mark.parametrize(
    ("declared", "units"), [("Pa", "Pa"), ("PA", "Pa"), ("kPa", "Pa"), ("pA", None), ("pa", None)]
)
def test_picoampere_is_not_read_as_pascal(declared, units):
    """'pA' was 'pressure in Pa, pA -> Pa': the case of the first letter tells them apart."""
    from rigtools.interop.channels import si_units

    si = si_units(declared)
    assert (si.units if si else None) == units
