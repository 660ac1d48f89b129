"""Both blades from the simulated rig: the active blade by an FRF test, the passive blade by a tap
(impact-hammer) test. `rig analyze` identifies the passive modes of the tap recording (paper's
Table 3), and `rig update` fits the model to both recordings (issue 11's must-show on both
blades). References: the test article's own FE eigen-solution (tests/rigtools/test_analyze.py's
construction) and its [test_article] values."""

from __future__ import annotations

import json
import shutil

import pytest
from cli_helpers import acquire_frf, rig

from rigtools.config import load_rig

#: the test article's own first three flexural frequencies (FE eigen-solve of its blades)
ARTICLE = {"active": (52.013, 355.625, 1252.944), "passive": (53.69, 471.24, 1296.76)}
#: the FRF test (burst, 20 Hz-2 kHz, 8 averages), shared with test_compare_after_update.py
FRF = acquire_frf("burst", band="20 Hz:2 kHz", averages=8, seed=1)


@pytest.fixture(scope="module")
def folder(tmp_path_factory, sim_recording):
    cwd = tmp_path_factory.mktemp("tap")
    shutil.copy(sim_recording(FRF, "frf.h5"), cwd / "frf.h5")
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


def test_a_tap_response_without_a_blade_in_its_name_takes_the_hit_blade(tmp_path):
    """Found by the type checker: a tap test whose response channel names no blade (``--response
    tip_accel``) gave its modes blade ``None``; the blade the hammer hit (the points' ``blade``)
    is used instead. Synthetic hits: a 0.5 ms half-sine of 50 N into a 60 Hz mode, 1 % damped;
    the identified mode within 0.5 % of 60 Hz."""
    import numpy as np

    from rigtools.recording import ChannelSpec, RecordingWriter
    from rigtools.update_modes import identify_recording

    rate, frame = 8192.0, 8192
    t = np.arange(frame) / rate
    pulse = np.where(t < 0.5e-3, 50.0 * np.sin(np.pi * t / 0.5e-3), 0.0)
    wn, zeta = 2 * np.pi * 60.0, 0.01
    wd = wn * np.sqrt(1 - zeta**2)
    impulse = np.exp(-zeta * wn * t) * np.sin(wd * t) / wd / rate
    accel = np.gradient(np.gradient(np.convolve(pulse, impulse)[:frame], t), t)
    channels = [
        ChannelSpec("hammer", "N", "force", rate),
        ChannelSpec("tip_accel", "m/s^2", "acceleration", rate),
    ]
    experiment = {"procedure": "tap test", "hammer_channel": "hammer", "response": "tip_accel"}
    path = tmp_path / "tap.h5"
    with RecordingWriter(path, "synthetic", "", experiment) as rec:
        for hit in (1, 2, 3):
            point = rec.begin_point(
                params={"hit": hit, "blade": "passive", "frame_samples": frame, "accepted": True},
                channels=channels,
            )
            point.append(np.vstack([pulse, accel]))
            point.end()
    (found,) = identify_recording(path).sets
    assert found.blade == "passive" and found.response == "tip_accel"
    assert found.frequencies_hz[0] == pytest.approx(60.0, rel=0.005)
