"""Exports keep what imports read (issue 29, item 5).

- The MPSTD file (../shared/data/pyuff-mpstd-58b: four 58b time records, records 1 and 4 on one
  DOF, node 1 +Z) imported with no --map and exported: pyuff reads back each record's node,
  direction, entity name, ID line 1 and values as the original has them (the export wrote nodes
  101-104 in +Y before); the two records of one DOF are named from their ID lines, and a
  user's --map still names one.
- A response-only recording (no force channel) exports time records and spectra with the
  default --what, exit 0, and one line saying no FRF was written (it failed, pointing at
  --reference, which cannot help); --what frf alone is refused in one line saying why.
- A TDMS import (no node or direction in the file) is written with direction 0 (none), not
  a made-up +Y, and one line says so.
- Property (hypothesis): node numbers and direction codes drawn for foreign UFF time records
  written by pyuff survive rig import uff -> rig export uff -> pyuff.
- The recording schema refuses a node or direction code out of range (writer and rig check).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest
import pyuff
from cli_helpers import run_cli
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from nptdms import ChannelObject, GroupObject, TdmsWriter
from public_data import PUBLIC_DATA, missing

from rigtools.config import load_rig
from rigtools.recording import ChannelSpec, RecordingWriter, open_recording

DATA = PUBLIC_DATA
MPSTD = DATA / "pyuff-mpstd-58b" / "MPSTD#Set001_2024_10_08_10_27_07.uff"
#: what a record says of its response (sensor) and reference
PLACE_FIELDS = ("rsp_ent_name", "rsp_node", "rsp_dir", "ref_node", "ref_dir", "id1")
NO_FRF = "no FRF written: the recording holds no force channel (response-only); an FRF needs the measured excitation"


def _need(folder: Path) -> None:
    if not folder.is_dir():
        missing(f"public data {folder} is absent (a clone without ../shared)", "RIGTOOLS_REQUIRE_DATA")


def _records(path, func_type: int | None = None) -> list[dict]:
    sets = pyuff.UFF(str(path)).read_sets()
    sets = sets if isinstance(sets, list) else [sets]
    return [s for s in sets if s["type"] == 58 and (func_type is None or s["func_type"] == func_type)]


def _place(s: dict) -> tuple:
    return tuple(s[k].strip() if isinstance(s[k], str) else int(s[k]) for k in PLACE_FIELDS)


# ------------------------------------------------------------------------------ the MPSTD file
@pytest.fixture(scope="module")
def mpstd(tmp_path_factory):
    """The MPSTD file imported (no --map) and exported with the default --what."""
    _need(MPSTD.parent)
    folder = tmp_path_factory.mktemp("mpstd")
    rec, uff = folder / "m.h5", folder / "m.uff"
    code, imported, err = run_cli(["import", "uff", MPSTD, rec])
    assert code == 0, err
    code, exported, err = run_cli(["export", "uff", rec, uff])
    assert code == 0, err
    return rec, uff, imported, exported


def test_mpstd_records_of_one_dof_named_from_their_id_lines(mpstd):
    rec, _, imported, _ = mpstd
    for line in (
        "kept    record 1 (1+Z:Dof1) -> 1_Z_Dof1: acceleration in m/s^2",
        "kept    record 2 (2+Z) -> 2_Z: acceleration in m/s^2",
        "kept    record 4 (1+Z:Dof4) -> 1_Z_Dof4: acceleration in m/s^2",
    ):
        assert line in imported
    with open_recording(rec) as r:
        (point,) = r.points
        got = [(n, c.node, c.direction, c.entity, c.description) for n, c in point.channels.items()]
    assert got == [
        ("1_Z_Dof1", 1, 3, "1+Z", "MPS set1 Dof1"),
        ("2_Z", 2, 3, "2+Z", "MPS set1 Dof2"),
        ("3_Z", 3, 3, "3+Z", "MPS set1 Dof3"),
        ("1_Z_Dof4", 1, 3, "1+Z", "MPS set1 Dof4"),
    ]


def test_mpstd_export_keeps_each_records_dof_and_values(mpstd):
    """Record by record: node, direction, entity, reference and ID line 1 equal the file's; the
    values are bit-identical (the file's float32 values are exact in the recording's float64, m/s2
    is SI with factor 1, and the export writes binary doubles)."""
    _, uff, _, exported = mpstd
    original, back = _records(MPSTD), _records(uff, func_type=1)
    assert len(back) == len(original) == 4
    for o, b in zip(original, back, strict=True):
        assert _place(b) == _place(o), o["id1"]
        assert (b["num_pts"], b["abscissa_min"], b["ordinate_spec_data_type"]) == (
            o["num_pts"],
            o["abscissa_min"],
            o["ordinate_spec_data_type"],
        )
        assert b["abscissa_inc"] == o["abscissa_inc"]  # 3.125e-4 s: 6 digits write it exactly
        np.testing.assert_array_equal(b["data"], o["data"])
    spectra = _records(uff, func_type=2)
    assert [_place(s)[:5] for s in spectra] == [_place(o)[:5] for o in original]
    assert [s["id1"] for s in spectra] == [
        f"{o['id1']}: auto spectrum, RMS^2 per bin (flattop)" for o in original
    ]
    assert exported.splitlines()[0] == NO_FRF


def test_mpstd_map_still_names_a_record(tmp_path):
    _need(MPSTD.parent)
    rec = tmp_path / "m.h5"
    code, out, err = run_cli(["import", "uff", MPSTD, rec, "--map", "record4=dof4", "--channel", "record4"])
    assert code == 0, err
    assert "kept    record 4 (1+Z:Dof4) -> dof4" in out
    with open_recording(rec) as r:
        (point,) = r.points
        assert [(n, c.node, c.direction) for n, c in point.channels.items()] == [("dof4", 1, 3)]


# ------------------------------------------------------------------------ response-only records
def _response_only(path: Path, amplitude: float, f0: float, rate: float, n: int) -> np.ndarray:
    """An imported recording of two accelerations, no force: a sine on a bin and noise."""
    t = np.arange(n) / rate
    rows = np.vstack([amplitude * np.sin(2 * np.pi * f0 * t), np.random.default_rng(1).standard_normal(n)])
    with RecordingWriter(
        path, backend="tdms", rig=load_rig(None).to_json(), experiment={"procedure": "import"}
    ) as rec:
        p = rec.begin_point(
            params={},
            channels=[
                ChannelSpec("a1", "m/s^2", "acceleration", rate),
                ChannelSpec("a2", "m/s^2", "acceleration", rate),
            ],
        )
        p.append(rows)
        p.end()
    return rows


def test_response_only_recording_exports_time_and_spectra_with_one_line(tmp_path):
    rate, n, f0, amplitude = 1024.0, 4096, 64.0, 0.5  # 64 Hz lies on a bin of 4096 samples
    rows = _response_only(tmp_path / "r.h5", amplitude, f0, rate, n)
    code, out, err = run_cli(["export", "uff", tmp_path / "r.h5", tmp_path / "r.uff"])
    assert code == 0, err
    lines = out.strip().splitlines()
    assert lines[0] == NO_FRF and sum(line.startswith("no FRF") for line in lines) == 1
    assert lines[-1].endswith("2 time, 2 spectra (UFF 58, SI)")
    assert [s["func_type"] for s in _records(tmp_path / "r.uff")] == [1, 2, 1, 2]
    time, spectra = _records(tmp_path / "r.uff", 1), _records(tmp_path / "r.uff", 2)
    np.testing.assert_array_equal(time[0]["data"], rows[0])
    # RMS^2 per bin of a sine of amplitude A is A^2/2 (closed form); the flattop window's
    # scalloping on a bin centre is below 1e-3 of the amplitude, its square within 2e-3
    peak = spectra[0]["data"][np.argmin(np.abs(spectra[0]["x"] - f0))]
    assert peak == pytest.approx(amplitude**2 / 2, rel=2e-3)


def test_response_only_frf_alone_is_refused_in_one_line(tmp_path):
    _response_only(tmp_path / "r.h5", 1.0, 64.0, 1024.0, 2048)
    code, _, err = run_cli(["export", "uff", tmp_path / "r.h5", tmp_path / "r.uff", "--what", "frf"])
    assert code == 2 and not (tmp_path / "r.uff").exists()
    (line,) = err.strip().splitlines()
    assert line.endswith(f"nothing to export for --what 'frf': {NO_FRF}") and "--reference" not in line


def test_tdms_import_without_places_exports_direction_none_with_one_line(tmp_path):
    """A TDMS log names no node or direction: the export numbers its channels 101+ in channel
    order with direction 0 (none), says so, and makes up no +Y."""
    src, rec, uff = tmp_path / "log.tdms", tmp_path / "log.h5", tmp_path / "log.uff"
    data = np.random.default_rng(3).standard_normal((3, 512))
    with TdmsWriter(str(src)) as w:
        w.write_segment(
            [GroupObject("acc")]
            + [
                ChannelObject("acc", f"s{i}_X", d, properties={"unit_string": "g", "wf_increment": 1 / 256})
                for i, d in enumerate(data)
            ]
        )
    assert run_cli(["import", "tdms", src, rec])[0] == 0
    code, out, err = run_cli(["export", "uff", rec, uff, "--what", "time"])
    assert code == 0, err
    assert (
        "3 channel(s) without node or direction (the file they were imported from gave none): "
        "written as nodes 101-103 in channel order, direction 0 (none)"
    ) in out
    assert [(s["rsp_node"], s["rsp_dir"], s["id4"].strip()) for s in _records(uff)] == [
        (101 + i, 0, f"channel s{i}_X") for i in range(3)
    ]
    # and a re-import keeps them: the same arrays, units and quantities (binary doubles both
    # ways: bit-identical), and a second export writes the same places
    assert run_cli(["import", "uff", uff, tmp_path / "back.h5"])[0] == 0
    with open_recording(rec) as a, open_recording(tmp_path / "back.h5") as b:
        (pa,), (pb,) = a.points, b.points
        assert list(pb.channels) == list(pa.channels)
        for name, ch in pa.channels.items():
            assert (
                (pb.channels[name].units, pb.channels[name].quantity)
                == (ch.units, ch.quantity)
                == ("m/s^2", "acceleration")
            )
            np.testing.assert_array_equal(pb.channels[name][:], ch[:])
    code, out, err = run_cli(["export", "uff", tmp_path / "back.h5", tmp_path / "back.uff", "--what", "time"])
    assert code == 0 and "without node or direction" not in out, err
    assert [_place(s) for s in _records(tmp_path / "back.uff")] == [_place(s) for s in _records(uff)]


# --------------------------------------------------------------------------- property: any place
def _foreign_uff(path: Path, places: list[tuple[str, int, int, str]], data: np.ndarray) -> None:
    """Time records as another writer leaves them, written by pyuff from dicts filled in here
    (not by rigtools): ``places`` are ``(entity, node, direction, ID line 1)``; acceleration in
    m/s^2, binary doubles."""
    n, dt = data.shape[1], 1 / 512
    axes = {"spec_data_type": 0, "len_unit_exp": 0, "force_unit_exp": 0, "temp_unit_exp": 0}
    labels = {"axis_lab": "NONE", "axis_units_lab": "NONE"}
    common = {
        "type": 58, "binary": 1, "id2": "analyser", "id3": "NONE", "id4": "NONE", "id5": "NONE",
        "func_type": 1, "func_id": 0, "ver_num": 0, "load_case_id": 0,
        "ref_ent_name": "NONE", "ref_node": 0, "ref_dir": 0,
        "ord_data_type": 4, "num_pts": n, "abscissa_spacing": 1, "abscissa_min": 0.0,
        "abscissa_inc": dt, "z_axis_value": 0.0,
        **{f"abscissa_{k}": v for k, v in axes.items()}, "abscissa_spec_data_type": 17,
        "abscissa_axis_lab": "Time", "abscissa_axis_units_lab": "s",
        **{f"ordinate_{k}": v for k, v in axes.items()}, "ordinate_spec_data_type": 12,
        "ordinate_len_unit_exp": 1, "ordinate_axis_lab": "Acceleration", "ordinate_axis_units_lab": "m/s^2",
        **{f"orddenom_{k}": v for k, v in {**axes, **labels}.items()},
        **{f"z_axis_{k}": v for k, v in {**axes, **labels}.items()},
    }  # fmt: skip
    sets = [
        {**common, "id1": id1, "rsp_ent_name": entity, "rsp_node": node, "rsp_dir": direction,
         "data": row, "x": np.arange(n) * dt}
        for (entity, node, direction, id1), row in zip(places, data, strict=True)
    ]  # fmt: skip
    pyuff.UFF(str(path)).write_sets(sets, "add", force_double=True)


DIRECTION_CODES = st.sampled_from([c for c in range(-6, 7) if c != 0])  # as the UFF direction tests
NODES = st.integers(min_value=1, max_value=2**31 - 1)  # UFF's I10 node field, read as int32


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    dofs=st.lists(st.tuples(NODES, DIRECTION_CODES), min_size=1, max_size=4),
    one_entity=st.booleans(),
    twin=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_drawn_nodes_and_directions_survive_import_and_export(dofs, one_entity, twin, seed):
    """Any node (1..2**31-1) and direction code (+-1..6) of foreign time records: pyuff reads
    the same from the export, record by record, with the same values (binary doubles both
    ways: bit-identical). ``twin`` repeats the first DOF (as the MPSTD file does) and
    ``one_entity`` gives every record one entity name, so such records are told apart by ID
    line 1 only."""
    dofs = dofs + dofs[:1] if twin else dofs
    places = [
        ("acc" if one_entity else f"s{i}", node, direction, f"test run {i}")
        for i, (node, direction) in enumerate(dofs)
    ]
    data = np.random.default_rng(seed).standard_normal((len(places), 64))
    with tempfile.TemporaryDirectory() as tmp:
        src, rec, out = Path(tmp) / "f.uff", Path(tmp) / "f.h5", Path(tmp) / "back.uff"
        _foreign_uff(src, places, data)
        code, _, err = run_cli(["import", "uff", src, rec])
        assert code == 0, err
        code, _, err = run_cli(["export", "uff", rec, out, "--what", "time"])
        assert code == 0, err
        original, back = _records(src), _records(out)
        assert [_place(s) for s in back] == [_place(s) for s in original]
        for o, b in zip(original, back, strict=True):
            np.testing.assert_array_equal(b["data"], o["data"])


# --------------------------------------------------------------------------------- the schema
@pytest.mark.parametrize(
    "field, value",
    [("direction", 7), ("direction", -7), ("direction", True), ("node", -1), ("node", 2**31), ("node", 1.0)],
)
def test_channel_place_out_of_range_is_refused(field, value):
    with pytest.raises(ValueError, match=f"{field} .* must be an integer in"):
        ChannelSpec("a", "m/s^2", "acceleration", 100.0, **{field: value})


def test_check_flags_a_direction_code_another_tool_wrote_out_of_range(tmp_path):
    import h5py

    from rigtools.recording.validate import check_recording

    path = tmp_path / "r.h5"
    _response_only(path, 1.0, 64.0, 1024.0, 256)
    assert check_recording(path).valid
    with h5py.File(path, "r+") as f:
        f["points/0000/a1"].attrs["direction"] = np.int64(9)
        f["points/0000/a2"].attrs["node"] = "one"
    problems = [(p.where, p.message) for p in check_recording(path).problems]
    assert ("/points/0000/a1", "direction 9 is not a UFF direction code (-6..6)") in problems
    assert ("/points/0000/a2", "attribute 'node' = 'one' is not int") in problems
