"""Both blades from the simulated rig: the active blade by an FRF test, the passive blade by a tap
(impact-hammer) test. `rig analyze` identifies the passive modes of the tap recording (paper's
Table 3), and `rig update` fits the model to both recordings (issue 11's must-show on both
blades). References: the test article's own FE eigen-solution (tests/rigtools/test_analyze.py's
construction) and its [test_article] values."""

from __future__ import annotations

import json

import pytest
from cli_helpers import rig

from rigtools.config import load_rig

#: the test article's own first three flexural frequencies (FE eigen-solve of its blades)
ARTICLE = {"active": (52.013, 355.625, 1252.944), "passive": (53.69, 471.24, 1296.76)}


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("tap")
    rig(
        "acquire",
        "frf",
        "--backend",
        "sim",
        "--signal",
        "burst",
        "--band",
        "20 Hz:2 kHz",
        "--level",
        "0.3 V",
        "--frame",
        "0.5 s",
        "--averages",
        "8",
        "--seed",
        "1",
        "--out",
        "frf.h5",
        cwd=cwd,
    )
    rig(
        "acquire",
        "tap",
        "--backend",
        "sim",
        "--blade",
        "passive",
        "--position",
        "85 mm",
        "--hits",
        "4",
        "--gap",
        "5 mm",
        "--seed",
        "1",
        "--out",
        "tap.h5",
        cwd=cwd,
    )
    return cwd


def test_rig_analyze_identifies_the_passive_blade_from_a_tap_test(folder):
    doc = json.loads(rig("analyze", "tap.h5", "--json", cwd=folder))
    rows = [r for r in doc["natural_frequencies"] if r["blade"] == "passive"]
    em = [r["em_hz"] for r in sorted(rows, key=lambda r: r["mode"])]
    assert len(em) == 3
    for got, ref in zip(em, ARTICLE["passive"], strict=True):
        assert got == pytest.approx(ref, rel=5e-3)  # measured: within 0.011 %


def test_rig_update_on_both_blades(folder):
    cfg = load_rig(None)
    doc = json.loads(
        rig(
            "update",
            "frf.h5",
            "tap.h5",
            "--params",
            "root.rotational_stiffness,shroud.mass,force_sensor.mass,damping.ratio",
            "--out",
            "both.toml",
            "--json",
            cwd=folder,
        )
    )
    fit = doc["fit"]
    blades = {m["blade"] for m in fit["modes"]}
    assert blades == {"active", "passive"} and len(fit["modes"]) == 6
    assert fit["max_frequency_error_after"] < 0.003  # measured 0.069 %
    fitted = {name: p["fitted"] for name, p in fit["parameters"].items()}
    assert fitted["root.rotational_stiffness"] == pytest.approx(
        cfg.test_article.root_rotational_stiffness, rel=0.10
    )  # measured -4.8 %
    assert fitted["damping.ratio"] == pytest.approx(cfg.test_article.damping_ratio, rel=0.10)  # +0.2 %
