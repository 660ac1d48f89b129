"""``rig info`` and ``rig check`` of an FRF set (``rig import uff`` of UFF 58 FRFs).

A UFF written with pyuff: two accelerance FRFs of a 100 Hz, 2 %-damped oscillator at nodes 2 (+Z)
and 3 (-Y) over a force at node 1 (+Z), 0-500 Hz in 0.5 Hz lines, a coherence for the first.
``rig info`` reports those numbers; ``rig check`` passes it (exit 0) and finds each damage made
to a copy with h5py (exit 1, one line each; a newer schema exit 2). The public ufffiles-hammer
FRF (../shared/data, skipped where absent) is described and valid too.
"""

from __future__ import annotations

import json
import shutil

import h5py
import numpy as np
import pytest
import pyuff
from cli_helpers import run_cli

from rigtools.analysis.frf import sdof_frf
from rigtools.interop.uff import FUNC_COHERENCE, FUNC_FRF, UffFunction

F = np.arange(0.0, 500.25, 0.5)


def _record(func_type, name, node, direction, data):
    d = UffFunction(
        func_type,
        f"{name} over hammer",
        (name, node),
        ("hammer", 1),
        "acceleration" if func_type == FUNC_FRF else "coherence",
        "force",
        F,
        data,
        "m/s^2/N" if func_type == FUNC_FRF else "-",
    ).dataset()
    return {**d, "rsp_dir": direction, "ref_dir": 3}


@pytest.fixture(scope="module")
def frf_set(tmp_path_factory):
    folder = tmp_path_factory.mktemp("frfset")
    h = sdof_frf(F, 100.0, 0.02, kind="accelerance")
    src = folder / "two.uff"
    pyuff.UFF(str(src)).write_sets(
        [
            _record(FUNC_FRF, "tip", 2, 3, h),
            _record(FUNC_COHERENCE, "tip", 2, 3, np.full(F.size, 0.98)),
            _record(FUNC_FRF, "root", 3, -2, 0.5 * h),
        ],
        "add",
    )
    out = folder / "two.h5"
    code, _, err = run_cli(["import", "uff", src, out])
    assert code == 0, err
    return out


def test_info_describes_the_frf_set(frf_set):
    code, out, err = run_cli(["info", frf_set, "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert (doc["kind"], doc["frf_kind"], doc["frf_units"], doc["n_frfs"]) == (
        "frf set",
        "accelerance",
        "(m/s^2)/N",
        2,
    )
    got = [(r["name"], r["node"], r["direction"], r["units"], r["coherence"]) for r in doc["responses"]]
    assert got == [("tip_2_Z", 2, "+Z", "m/s^2", True), ("root_3-Y", 3, "-Y", "m/s^2", False)]
    assert [(r["name"], r["node"], r["direction"], r["units"]) for r in doc["references"]] == [
        ("hammer", 1, "+Z", "N")
    ]
    f = doc["frequency"]
    assert f["lines"] == 1001 and f["min_hz"] == 0.0
    assert f["max_hz"] == pytest.approx(500.0, rel=1e-9) and f["resolution_hz"] == pytest.approx(
        0.5, rel=1e-9
    )
    assert doc["source"] == {"file": "two.uff", "format": "uff"}
    code, out, err = run_cli(["info", frf_set])
    assert code == 0, err
    flat = " ".join(out.split())  # the console wraps at its width after the (temporary) path
    assert "2 accelerance FRF(s), (m/s^2)/N" in flat and "1001 lines 0-500 Hz, 0.5 Hz resolution" in flat
    assert "from two.uff" in out and "tip_2_Z" in out and "3 -Y" in out


def test_info_shows_each_frfs_own_reference_direction(tmp_path):
    """One reference point hit in two directions (a roving-response test with the hammer at node
    1 in +Z and in -X): each FRF's row shows its own reference direction (the table looked the
    reference up by name and showed the last one, -X, for both)."""
    h = sdof_frf(F, 100.0, 0.02, kind="accelerance")
    src = tmp_path / "two_ways.uff"
    pyuff.UFF(str(src)).write_sets(
        [_record(FUNC_FRF, "tip", 2, 3, h), {**_record(FUNC_FRF, "side", 2, 1, h), "ref_dir": -1}], "add"
    )
    assert run_cli(["import", "uff", src, tmp_path / "two_ways.h5"])[0] == 0
    code, out, err = run_cli(["info", tmp_path / "two_ways.h5", "--json"])
    assert code == 0, err
    got = [
        (r["name"], r["reference"], r["reference_node"], r["reference_direction"])
        for r in json.loads(out)["responses"]
    ]
    assert got == [("tip_2_Z", "hammer", 1, "+Z"), ("side_2_X", "hammer", 1, "-X")]
    code, out, err = run_cli(["info", tmp_path / "two_ways.h5"])
    rows = [line.split("│")[1:-1] for line in out.splitlines() if "hammer" in line]
    assert [[cell.strip() for cell in row] for row in rows] == [
        ["tip_2_Z", "2 +Z", "m/s^2 per N", "hammer", "1 +Z", "no"],
        ["side_2_X", "2 +X", "m/s^2 per N", "hammer", "1 -X", "no"],
    ]


def test_check_passes_a_good_frf_set(frf_set):
    code, out, _ = run_cli(["check", frf_set])
    assert code == 0 and out.strip() == f"{frf_set}: valid rigtools FRF set (2 FRF(s), 1001 lines)"
    code, out, _ = run_cli(["check", frf_set, "--json"])
    doc = json.loads(out)
    assert code == 0 and doc["valid"] and (doc["frfs"], doc["lines"], doc["problems"]) == (2, 1001, [])


def _swap_lines(f):
    f["frequency"][10], f["frequency"][11] = f["frequency"][11], f["frequency"][10]


def _inf(f):
    f["frf_real"][1, 7] = np.inf


def _coherence(f):
    f["coherence"][0, 3] = 1.5


def _three_names(f):
    f.attrs["responses"] = json.dumps(["a", "b", "c"])


@pytest.mark.parametrize(
    ("damage", "where", "message"),
    [
        (_swap_lines, "/frequency", "not increasing: line 11 (5 Hz) after 5.5 Hz"),
        (_inf, "/frf_real", "1 non-finite value(s), first at line 7"),
        (_coherence, "/coherence", "row 0: values 0.98 to 1.5, outside [0, 1]"),
        (_three_names, "/frf_real", "shape (2, 1001), expected (3, 1001) (responses, lines)"),
    ],
)
def test_check_finds_each_damage(frf_set, tmp_path, damage, where, message):
    bad = tmp_path / "bad.h5"
    shutil.copy(frf_set, bad)
    with h5py.File(bad, "r+") as f:
        damage(f)
    code, out, _ = run_cli(["check", bad])
    assert code == 1, out
    assert out.splitlines()[0].startswith(f"{bad}: INVALID FRF set")
    assert f"  error: {where}: {message}" in out.splitlines()
    code, out, _ = run_cli(["check", bad, "--json"])
    doc = json.loads(out)
    assert (
        code == 1
        and not doc["valid"]
        and {"where": where, "message": message}
        in [{k: p[k] for k in ("where", "message")} for p in doc["problems"]]
    )
    if damage is _inf:  # --quick reads no values
        assert run_cli(["check", bad, "--quick"])[0] == 0


def test_check_of_a_newer_frf_set_is_unreadable(frf_set, tmp_path):
    newer = tmp_path / "newer.h5"
    shutil.copy(frf_set, newer)
    with h5py.File(newer, "r+") as f:
        f.attrs["schema_version"] = 2
    code, _, err = run_cli(["check", newer])
    assert code == 2 and "schema_version 2 is newer than this rigtools reads (1)" in err
    assert len(err.strip().splitlines()) == 1


def test_public_ufffiles_frf(tmp_path, public_data):
    frf = public_data("ufffiles-hammer", "dataset58_FRF.unv")
    out = tmp_path / "hammer.h5"
    code, _, err = run_cli(["import", "uff", frf, out])
    assert code == 0, err
    code, js, err = run_cli(["info", out, "--json"])
    assert code == 0, err
    doc = json.loads(js)
    assert doc["n_frfs"] == 1 and doc["frequency"] == {
        "lines": 1600,
        "min_hz": 0.0,
        "max_hz": 799.5,
        "resolution_hz": 0.5,
    }
    assert doc["responses"][0]["entity"] == ".1.Z-" and doc["references"][0]["name"] == ".56.Z"
    assert doc["source"]["file"] == "dataset58_FRF.unv"
    assert run_cli(["check", out])[0] == 0


@pytest.mark.parametrize(
    ("band", "words"),
    [
        (
            "0.1 Hz:0.2 Hz",
            "band 0.1-0.2 Hz holds 0 of the FRF's lines (0-500 Hz, every 0.5 Hz)",
        ),  # IndexError
        ("600 Hz:1 kHz", "band 600-1000 Hz holds 0 of the FRF's lines"),  # "Singular matrix"
        ("100 Hz:101 Hz", "band 100-101 Hz holds 3 of the FRF's lines"),  # "Singular matrix"
    ],
)
def test_analyze_refuses_a_band_with_too_few_lines(frf_set, band, words):
    code, _, err = run_cli(["analyze", frf_set, "--band", band])
    assert code == 2 and "Traceback" not in err, err
    (line,) = err.strip().splitlines()
    assert words in line and "give one over at least 5 lines" in line, line


def test_analyze_takes_the_grid_part_of_a_band_reaching_past_it(frf_set):
    """90 Hz-1 kHz over a 0-500 Hz grid: the 100 Hz mode over 90-500 Hz, no warning on stderr."""
    code, out, err = run_cli(["analyze", frf_set, "--band", "90 Hz:1 kHz", "--json"])
    assert code == 0 and err == "", err
    (point,) = json.loads(out)["points"]
    assert (point["params"]["band_low"], point["params"]["band_high"]) == (90.0, 500.0)


@pytest.mark.parametrize(
    ("case", "words"),
    [
        ("reference", "--reference: "),  # ignored silently before
        ("folder", "two.uff: not a file"),  # "no such file" before
    ],
)
def test_import_uff_frfs_bad_input_is_one_line(frf_set, tmp_path, case, words):
    src = frf_set.parent / "two.uff"
    if case == "folder":
        src = tmp_path / "two.uff"
        src.mkdir()
    extra = ["--reference", "root"] if case == "reference" else []
    code, _, err = run_cli(["import", "uff", src, tmp_path / "x.h5", *extra])
    assert code == 2, err
    (line,) = err.strip().splitlines()
    assert words in line, line
    assert not (tmp_path / "x.h5").exists()


def test_export_uff_writes_the_frf_set_back(frf_set, tmp_path):
    """``rig export uff SET.h5`` (refused before): one FRF per response, the coherence where the
    set has one, each with its entity, node and direction codes; the values the set's (binary
    doubles: exact), and an import of the export gives the same set."""
    out = tmp_path / "back.uff"
    code, text, err = run_cli(["export", "uff", frf_set, out])
    assert code == 0, err
    assert text.strip() == f"wrote {out}: 2 frf, 1 coherence (UFF 58, SI)"
    records = [s for s in pyuff.UFF(str(out)).read_sets() if s["type"] == 58]
    got = [
        (s["func_type"], s["rsp_ent_name"], s["rsp_node"], s["rsp_dir"], s["ref_ent_name"], s["ref_node"])
        + (s["ref_dir"], s["ordinate_spec_data_type"], s["orddenom_spec_data_type"])
        for s in records
    ]
    assert got == [
        (FUNC_FRF, "tip", 2, 3, "hammer", 1, 3, 12, 13),
        (FUNC_COHERENCE, "tip", 2, 3, "hammer", 1, 3, 1, 0),
        (FUNC_FRF, "root", 3, -2, "hammer", 1, 3, 12, 13),
    ]
    h = sdof_frf(F, 100.0, 0.02, kind="accelerance")
    np.testing.assert_array_equal(records[0]["data"], h)
    np.testing.assert_array_equal(records[1]["data"], np.full(F.size, 0.98))
    np.testing.assert_array_equal(records[2]["data"], 0.5 * h)
    assert records[0]["abscissa_inc"] == 0.5 and records[0]["num_pts"] == F.size
    again = tmp_path / "again.h5"
    assert run_cli(["import", "uff", out, again])[0] == 0
    first, second = (json.loads(run_cli(["info", p, "--json"])[1]) for p in (frf_set, again))
    for key in ("frf_kind", "n_frfs", "references", "responses", "frequency"):
        assert first[key] == second[key], key


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--what", "time"], "an FRF set holds FRFs only (no time): use --what frf"),
        (["--excitation", "random"], "--excitation: "),
        (["--reference", "hammer"], "--reference: "),
    ],
)
def test_export_uff_of_an_frf_set_refuses_what_it_cannot_use(frf_set, tmp_path, extra, words):
    code, _, err = run_cli(["export", "uff", frf_set, tmp_path / "x.uff", *extra])
    (line,) = err.strip().splitlines()
    assert code == 2 and words in line, line
    assert not (tmp_path / "x.uff").exists()
