"""A lab's own UFF export imports back through its own import (names, units, quantities, rate,
values), and a foreign file whose records share a name gets advice that works.

UFF 58 keeps 10 characters of a name in its entity fields: the shroud channels of one node
(``active_shroud_accel``, ``_disp``, ``_vel``) all read ``active_shr:2+Y`` there, and the import
refused the export of every ``rig simulate`` recording with advice (``--map``) it then refused.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyuff
from cli_helpers import run_cli

from rigtools.interop.uff import FUNC_TIME, UffFunction, write_uff
from rigtools.recording import open_recording


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """``rig simulate`` (0.2 s) and ``rig export uff`` of it: ``(recording, uff)``."""
    folder = tmp_path_factory.mktemp("uffrt")
    run, uff = folder / "run.h5", folder / "run.uff"
    code, _, err = run_cli(["simulate", "--out", run, "--duration", "0.2 s", "--no-plot"])
    assert code == 0, err
    code, _, err = run_cli(["export", "uff", run, uff])
    assert code == 0, err
    return run, uff


def _channels(path):
    with open_recording(path) as rec:
        (point,) = rec.points
        return {
            name: (ch.units, ch.quantity, ch.sample_rate, ch.t0, np.asarray(ch[:]))
            for name, ch in point.channels.items()
        }


def test_simulated_recording_round_trips_through_uff(simulated, tmp_path):
    run, uff = simulated
    back = tmp_path / "back.h5"
    code, out, err = run_cli(["import", "uff", uff, back])
    assert code == 0, err
    source, got = _channels(run), _channels(back)
    assert list(got) == list(source)  # names and their order
    assert len(source) == 11
    for name, (units, quantity, rate, t0, values) in source.items():
        b_units, b_quantity, b_rate, b_t0, b_values = got[name]
        assert (b_units, b_quantity) == (units, quantity), name
        assert b_rate == pytest.approx(rate, rel=1e-12) and b_t0 == pytest.approx(t0, abs=1e-12)
        np.testing.assert_array_equal(b_values, values)  # binary doubles: exact, not float32 only
    assert "kept    record 1 (active_shroud_accel) -> active_shroud_accel: acceleration in m/s^2" in out


def test_export_read_by_pyuff_keeps_full_names_in_id_line_4(simulated):
    """pyuff reads the full channel name in ID line 4 and the 10-character entity beside it."""
    run, uff = simulated
    time = [s for s in pyuff.UFF(str(uff)).read_sets() if s["type"] == 58 and s["func_type"] == FUNC_TIME]
    source = _channels(run)
    assert [s["id4"].strip() for s in time] == [f"channel {name}" for name in source]
    disp = next(s for s in time if s["id4"].strip() == "channel active_shroud_disp")
    assert (disp["rsp_ent_name"].strip(), disp["rsp_node"], disp["ordinate_spec_data_type"]) == (
        "active_shr",
        2,
        8,
    )
    np.testing.assert_array_equal(disp["data"], source["active_shroud_disp"][4])


def _foreign(path, records):
    """A UFF file as another tool writes it (no ID line 4 names): ``records`` are
    ``(entity, node, quantity, values)``."""
    t = np.arange(64) / 1024.0
    functions = [
        UffFunction(FUNC_TIME, f"{entity} {quantity}", (entity, node), ("", 0), quantity, "", t, data, "")
        for entity, node, quantity, data in records
    ]
    write_uff(path, functions)
    sets = pyuff.UFF(str(path)).read_sets()
    for s in sets:  # as a foreign file: no rigtools mark, no ID line 4
        s.update(id2="analyser", id4="")
    path.unlink()
    pyuff.UFF(str(path)).write_sets(sets, "add", force_double=True)


def test_foreign_records_of_one_name_told_apart_by_quantity(tmp_path):
    src = tmp_path / "f.uff"
    a, d = np.linspace(0, 1, 64), np.linspace(0, 1e-3, 64)
    _foreign(src, [("acc", 2, "acceleration", a), ("acc", 2, "displacement", d)])
    code, out, err = run_cli(["import", "uff", src, tmp_path / "f.h5"])
    assert code == 0, err
    got = _channels(tmp_path / "f.h5")
    assert {n: g[:2] for n, g in got.items()} == {
        "acc_2_Y_acceleration": ("m/s^2", "acceleration"),
        "acc_2_Y_displacement": ("m", "displacement"),
    }
    np.testing.assert_array_equal(got["acc_2_Y_displacement"][4], d)
    assert "kept    record 2 (acc:2+Y:displacement) -> acc_2_Y_displacement: displacement in m" in out


def test_foreign_duplicate_names_advice_works(tmp_path):
    """Two records of one name and quantity: one line naming both, whose advice imports the file."""
    src, out = tmp_path / "dup.uff", tmp_path / "dup.h5"
    a, b = np.linspace(0, 1, 64), np.linspace(0, 2, 64)
    _foreign(src, [("acc", 2, "acceleration", a), ("acc", 2, "acceleration", b)])
    code, _, err = run_cli(["import", "uff", src, out])
    (line,) = err.strip().splitlines()
    assert code == 2 and not out.exists()
    assert line.endswith(
        "record 1 (acc:2+Y) and record 2 (acc:2+Y) both become channel 'acc_2_Y'; "
        "map one to another name (--map record2=NEW_NAME)"
    ), line
    advice = line[line.index("--map ") :].rstrip(")").split()
    code, _, err = run_cli(["import", "uff", src, out, advice[0], advice[1].replace("NEW_NAME", "acc_b")])
    assert code == 0, err
    got = _channels(out)
    np.testing.assert_array_equal(got["acc_2_Y"][4], a)
    np.testing.assert_array_equal(got["acc_b"][4], b)
    # a record number the file does not have is refused in one line
    code, _, err = run_cli(["import", "uff", src, tmp_path / "x.h5", "--map", "record3=x"])
    assert code == 2 and err.strip().endswith(
        "--map: no record3 in the file (its records 58: record1..record2)"
    )
