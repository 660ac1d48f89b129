"""``rig export uff --what frf`` of a tap test (one point per hit, ``rig acquire tap``): one H1
averaged over the hits, as ``rig analyze`` reports it (it was refused per point: "1 segment(s)
of 51200: need at least 2 averages", naming neither the file nor a way out)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import pyuff
from cli_helpers import run_cli


@pytest.fixture(scope="module")
def tap(tmp_path_factory):
    out = tmp_path_factory.mktemp("tap") / "tap.h5"
    code, _, err = run_cli(
        [
            "acquire",
            "tap",
            "--backend",
            "sim",
            "--position",
            "85 mm",
            "--hits",
            "3",
            "--gap",
            "5 mm",
            "--out",
            out,
        ]
    )
    assert code == 0, err
    return out


def test_export_frf_of_a_tap_test_is_the_hits_average(tap, tmp_path):
    code, out, err = run_cli(["export", "uff", tap, tmp_path / "t.uff", "--what", "frf"])
    assert code == 0, err
    sets = pyuff.UFF(str(tmp_path / "t.uff")).read_sets()
    sets = [s for s in (sets if isinstance(sets, list) else [sets]) if s.get("type") == 58]
    assert [s["func_type"] for s in sets] == [4, 6]  # one FRF, its coherence
    frf, coh = sets
    assert "3 hit(s)" in frf["id1"]
    code, out, _ = run_cli(["analyze", tap, "--json"])
    modes = json.loads(out)["points"][0]["frf"]["modes"]
    first = min(m["frequency_hz"] for m in next(iter(modes.values()))["modes"])
    f, h = np.asarray(frf["x"]), np.abs(np.asarray(frf["data"]))
    near = (f > 0.8 * first) & (f < 1.2 * first)
    # |H1| peaks at the first mode rig analyze identifies, within one line (the grid's resolution)
    assert abs(f[near][np.argmax(h[near])] - first) <= f[1] - f[0]
    assert np.all((np.asarray(coh["data"]) >= 0) & (np.asarray(coh["data"]) <= 1 + 1e-12))


def test_export_frf_of_a_tap_test_with_one_hit_names_file_and_way_out(tap, tmp_path):
    import shutil

    import h5py

    one = tmp_path / "one.h5"
    shutil.copy(tap, one)
    with h5py.File(one, "r+") as f:
        for name in list(f["points"])[1:]:
            f["points"][name].attrs["accepted"] = False
    code, _, err = run_cli(["export", "uff", one, tmp_path / "o.uff", "--what", "frf"])
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert str(one) in err and "at least two accepted hits" in err and "--what time,spectra" in err
    assert not (tmp_path / "o.uff").exists()
