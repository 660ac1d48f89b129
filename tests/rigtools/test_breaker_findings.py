"""The careless-user breaker's findings left open last session (issue 30): each one's command,
now one clear line or the right answer. Files are built here from known arrays."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
from cli_helpers import run_cli
from test_bad_input import _write_recording
from test_import_damaged import _lvm, _uff_time

import rigtools
from rigtools.analysis.frf import sdof_frf
from rigtools.errors import UserError
from rigtools.interop.imported import split_by_timing
from rigtools.interop.uff_data import frf_kind_from_data
from rigtools.model_options import excitation
from rigtools.recording import check_recording, open_recording
from rigtools.units import parse_quantity


@pytest.fixture
def data():
    return np.random.default_rng(3).standard_normal((200, 2))


def _one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


# ----------------------------------------------------------------- samples no quantity reaches
def test_samples_beyond_1e150_are_refused_by_check_and_report(tmp_path):
    """Every sample 1e308 crashed rig report in matplotlib's tick locator; such samples are a
    damage check names, and report refuses the file in one line."""
    path = _write_recording(tmp_path / "big.h5")
    with h5py.File(path, "r+") as f:
        f["points/0000/force"][:] = 1e308
    errors = [p.line() for p in check_recording(path).problems if p.severity == "error"]
    assert errors == [
        (
            "/points/0000/force: 2000 samples beyond +-1e+150: no measured or modelled quantity in SI "
            "units reaches that (a damaged file?); its squares overflow every spectrum and fit"
        )
    ]
    code, _, err = run_cli(["report", path, "--out", tmp_path / "r"])
    assert code == 2 and f"{path} is damaged: /points/0000/force: 2000 samples beyond" in _one_line(err)
    assert not (tmp_path / "r").exists()


# -------------------------------------------------------------------------------- UFF import
def test_a_cut_uff_file_says_it_left_its_partial_record_out(tmp_path, data):
    """pyuff drops a record the file ends inside without a word: now one line says so."""
    src = _uff_time(tmp_path, data.T)
    raw = src.read_bytes()
    second = raw.index(b"    -1\n    -1\n") + 7  # the second record's opening -1
    (tmp_path / "cut.uff").write_bytes(raw[: second + (len(raw) - second) // 2])
    code, out, err = run_cli(["import", "uff", tmp_path / "cut.uff", tmp_path / "c.h5"])
    assert code == 0, err
    assert (
        f"{tmp_path / 'cut.uff'}: the file ends inside a record after 1 whole record(s) (a cut file?): the partial record is left out"
        in out
    )
    with open_recording(tmp_path / "c.h5") as rec:
        assert list(rec.points[0].channels) == ["hammer_1_Y"]
    (tmp_path / "cut1.uff").write_bytes(raw[: second // 2])  # inside the first record
    code, _, err = run_cli(["import", "uff", tmp_path / "cut1.uff", tmp_path / "c1.h5"])
    assert code == 2 and "the file ends inside a record after 0 whole record(s) (a cut file?)" in _one_line(
        err
    )


def test_a_uff_time_record_whose_code_and_label_disagree_is_not_guessed(tmp_path, data):
    """Units label 'N' over data-type code 12 (acceleration): skipped naming both and the way out;
    --units says which and imports it."""
    src = _uff_time(tmp_path, data.T)
    text = src.read_text()
    # the hammer's record: its data-type code (record 8, first field) 13 (force) -> 12 (acceleration)
    head, _, tail = text.partition("hammer")
    lines = tail.split("\n")
    i = next(j for j, line in enumerate(lines) if line.split()[:1] == ["13"])
    lines[i] = lines[i].replace("13", "12", 1)
    src.write_text(head + "hammer" + "\n".join(lines))
    code, out, err = run_cli(["import", "uff", src, tmp_path / "u.h5"])
    assert code == 0, err
    assert "its units label 'N' says force, its data-type code 12 says acceleration: give --units" in out
    with open_recording(tmp_path / "u.h5") as rec:
        assert list(rec.points[0].channels) == ["acc_1_Y"]
    code, out, err = run_cli(["import", "uff", src, tmp_path / "v.h5", "--units", "record1=N"])
    assert code == 0, err
    with open_recording(tmp_path / "v.h5") as rec:
        np.testing.assert_allclose(rec.points[0].channels["hammer_1_Y"][:], data[:, 0], rtol=1e-6)


def _frf_uff(path, f, h, *, units="g/N", code=12, label="Accelerance", coherence_x=None):
    import pyuff

    from rigtools.interop.uff import FUNC_COHERENCE, FUNC_FRF, UffFunction

    d = UffFunction(
        FUNC_FRF, "tip", ("tip", 2), ("hammer", 1), "acceleration", "force", f, h, units
    ).dataset()
    d.update(ordinate_spec_data_type=code, ordinate_axis_units_lab=units, ordinate_axis_lab=label)
    d.update(rsp_dir=3, ref_dir=3)
    sets = [d]
    if coherence_x is not None:
        c = UffFunction(
            FUNC_COHERENCE,
            "tip",
            ("tip", 2),
            ("hammer", 1),
            "none",
            "none",
            coherence_x,
            np.linspace(0.2, 0.9, coherence_x.size),
            "",
        ).dataset()
        c.update(rsp_dir=3, ref_dir=3)
        sets.append(c)
    pyuff.UFF(str(path)).write_sets(sets, "add")
    return path


def test_a_real_valued_frf_keeps_the_kind_its_three_headers_agree_on(tmp_path):
    """A magnitude-only FRF (real values, phase 0) was called mobility by the data rule's phase
    test against its code, units and axis label; real values have no phase: the headers stand."""
    f = np.arange(0.0, 500.25, 0.5)
    magnitude = np.abs(sdof_frf(f, 100.0, 0.02, kind="accelerance")) / 9.80665
    assert frf_kind_from_data(f, magnitude.astype(complex)) is None
    src = _frf_uff(tmp_path / "r.uff", f, magnitude.astype(complex))
    code, out, err = run_cli(["import", "uff", src, tmp_path / "r.h5"])
    assert code == 0, err
    assert "FRF, accelerance from its data-type code, x 9.80665 from its units 'g/N'" in out


def test_a_coherence_on_another_grid_is_not_paired_line_by_line(tmp_path):
    f = np.arange(0.0, 500.25, 0.5)
    h = sdof_frf(f, 100.0, 0.02, kind="accelerance")
    src = _frf_uff(tmp_path / "c.uff", f, h / 9.80665, coherence_x=f + 100.0)  # same length, other lines
    code, out, err = run_cli(["import", "uff", src, tmp_path / "c.h5"])
    assert code == 0, err
    assert "its coherence record left out: on another frequency grid (1001 lines 100-600 Hz)" in out
    from rigtools.frf_set import read_frf_set

    assert np.all(np.isnan(read_frf_set(tmp_path / "c.h5").coherence))
    src = _frf_uff(tmp_path / "d.uff", f, h / 9.80665, coherence_x=f)  # its own lines: paired
    code, out, err = run_cli(["import", "uff", src, tmp_path / "d.h5"])
    assert code == 0 and "with its coherence" in out, err
    np.testing.assert_allclose(
        read_frf_set(tmp_path / "d.h5").coherence[0], np.linspace(0.2, 0.9, f.size), rtol=1e-6
    )


# -------------------------------------------------------------------------------- LVM import
def test_lvm_x_dimension_frequency_is_not_read_as_time(tmp_path, data):
    src = _lvm(
        tmp_path,
        data,
        edit=lambda t: t.replace("X_Dimension\tTime\tTime", "X_Dimension\tFrequency\tFrequency"),
    )
    code, _, err = run_cli(["import", "lvm", src, tmp_path / "t.h5"])
    assert (
        code == 2
        and "X_Dimension 'Frequency': its rows are not samples in time (a spectrum?)" in _one_line(err)
    )
    assert not (tmp_path / "t.h5").exists()


def test_lvm_x_column_against_delta_x(tmp_path, data):
    """X_Columns One: the X column steps by 1e-4 s, the header's Delta_X says 1e-3 s: refused
    naming both (the rate would be 10x off); the file's own rounding of X (6 digits) is no conflict."""
    src = _lvm(tmp_path, data, edit=lambda t: t.replace("Delta_X\t0,0001\t0,0001", "Delta_X\t0,001\t0,001"))
    code, _, err = run_cli(["import", "lvm", src, tmp_path / "t.h5"])
    assert code == 2
    assert "its X column steps by 0.0001 s on average, the header's Delta_X says 0.001 s" in _one_line(err)
    code, _, err = run_cli(["import", "lvm", _lvm(tmp_path, data), tmp_path / "ok.h5"])
    assert code == 0, err


# ------------------------------------------------------------------------- timing and compare
def test_rates_one_ppm_apart_are_one_clock():
    """Channels whose clocks part by less than half a sample over the record are one point (a
    rate written as rounded increments); 100 ppm over 51200 samples (5 samples) are two."""
    n, rate = 51200, 51200.0
    assert split_by_timing([("a", n, rate), ("b", n, rate * (1 + 1e-6))]) == [[0, 1]]
    assert split_by_timing([("a", n, rate), ("b", n, rate * (1 + 1e-4))]) == [[0], [1]]
    assert split_by_timing([("a", n, rate), ("b", n - 1, rate)]) == [[0], [1]]


def test_compare_a_file_with_itself_reads_the_same_window_on_both_sides(tmp_path):
    """rig compare d.h5 d.h5: the model side read the whole record, the EM side its record
    window: a file compared with itself scored 0.42. Now both read the window: score 1, no error."""
    path = _write_recording(tmp_path / "d.h5")
    with h5py.File(path, "r+") as f:
        for p in ("0000", "0001"):
            f[f"points/{p}"].attrs["record_start"] = 0.5
            f[f"points/{p}"].attrs["record_samples"] = 1000
            for c in f[f"points/{p}"]:
                f[f"points/{p}/{c}"][:1000] *= 3.0  # settling: outside the record window
    code, out, err = run_cli(["compare", "--json", path, path])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["mean_score"] == pytest.approx(1.0, abs=1e-12)  # identical samples
    assert all(p["agreement"]["error_decades"] == pytest.approx(0.0, abs=1e-12) for p in doc["points"])


# ------------------------------------------------------------------------------- front door
def test_numpy_scalars_are_numbers():
    assert parse_quantity(np.float64(60.0), "frequency") == 60.0
    assert parse_quantity(np.int32(3)) == 3.0
    assert excitation(np.float64(60.0), np.float32(5.0), names=("fe", "force")) == (60.0, 5.0)
    with pytest.raises(ValueError, match="expected a number or a quantity"):
        parse_quantity(np.bool_(True))


@pytest.mark.parametrize(
    "call",
    [
        lambda tmp: rigtools.simulate_point(60, 5, out=tmp / "x.h5", overwrite="no"),
        lambda tmp: rigtools.continuation("fe", "55 Hz", "60 Hz", switch="no"),
        lambda tmp: rigtools.analyze_recording(_write_recording(tmp / "a.h5"), skip_damaged="no"),
    ],
    ids=["overwrite", "switch", "skip_damaged"],
)
def test_a_string_is_no_yes_or_no(call, tmp_path):
    with pytest.raises(UserError, match=r"= 'no': give True or False"):
        call(tmp_path)
    assert not (tmp_path / "x.h5").exists()


def test_force_range_is_the_clis_in_python_and_in_rig_simulate(tmp_path):
    with pytest.raises(UserError, match=r"^force = 1e\+30: outside the allowed range \[0, 1000\] N"):
        rigtools.simulate_point(60, force=1e30)
    code, _, err = run_cli(
        ["simulate", "--fe", "60 Hz", "--force", "1e30", "--no-plot", "--out", tmp_path / "s.h5"]
    )
    assert code == 2 and "--force = '1e30': outside the allowed range [0, 1000] N" in _one_line(err)


def test_advice_in_the_callers_words(tmp_path, data):
    """analyze_recording and the importers advise with Python's keywords in a script, the
    options' names under rig."""
    from rigtools.interop.lvm import import_lvm

    path = _write_recording(tmp_path / "a.h5")
    with pytest.raises(UserError) as info:
        rigtools.analyze_recording(path, kind="inertance")
    assert str(info.value) == "kind 'inertance': use one of accelerance, mobility, receptance"
    src = _lvm(tmp_path, data)
    with pytest.raises(UserError) as info:
        import_lvm(src, tmp_path / "t.h5", rig=None, units={"Nope": "N"})
    assert str(info.value).startswith("units: no channel 'Nope' in the file") and "--" not in str(info.value)
    code, _, err = run_cli(["import", "lvm", src, tmp_path / "t.h5", "--units", "Nope=N"])
    assert code == 2 and "--units: no channel 'Nope' in the file" in _one_line(err)
