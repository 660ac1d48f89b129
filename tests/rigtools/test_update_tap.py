"""``rig update`` with two recordings: the simulated rig's FRF test (active blade) and a tap test of
the passive blade.

``rig acquire tap`` is being built elsewhere; until it lands, the passive blade's tap test here is a
synthetic recording written with the recording writer: periodic half-sine hammer pulses at the
passive blade's mid-span (85 mm) and the passive shroud's acceleration from the test article's FE
model (rigtools.sim.harmonic: modal superposition over all its modes, exact for a periodic force), with
sensor noise as the simulated rig's. It follows the broadband-point contract ``rig update`` reads:
``frame_samples``, ``record_start`` (s), ``record_samples``, ``signal = "tap"``, a force channel
and a ``passive_*`` acceleration.

With both blades' first three flexural modes the root stiffness and the shroud and sensor masses
are separable (from the active blade alone they are not: test_update.py).
"""

import json

import numpy as np
import pytest
from cli_helpers import acquire_frf, run_cli

from rigtools.config import default_rig_text, load_rig
from rigtools.recording import ChannelSpec, RecordingWriter
from rigtools.sim.harmonic import fem_harmonic_response
from rigtools.sim.parameter_fit import mode_targets
from rigtools.sim.rig_model import build_rig_model

RATE = 51200.0
FRAME = 51200  # 1 s frames: 1 Hz resolution
FRAMES = 4
FRF = acquire_frf("chirp", band="20 Hz:2 kHz", frame="1 s", averages=4, seed=1)  # test_update*.py
FOUR = "root.rotational_stiffness,shroud.mass,force_sensor.mass,damping.ratio"


@pytest.fixture(scope="module")
def article():
    cfg = load_rig(None)
    spec = cfg.test_article.to_params()
    return spec, spec.apply(cfg.to_params())


def write_tap(path, params, seed=3):
    """Synthetic passive-blade tap test of ``params`` (see the module docstring)."""
    rng = np.random.default_rng(seed)
    t = np.arange(FRAME) / RATE
    width = 0.5e-3
    force = np.where(t < width, 50.0 * np.sin(np.pi * t / width), 0.0)  # 50 N, 0.5 ms half-sine
    spec = np.fft.rfft(force)
    f = np.arange(spec.size) * RATE / FRAME
    resp = fem_harmonic_response(build_rig_model(params), f[1:], 1.0)
    acc = np.zeros(spec.size, complex)
    acc[1:] = -((2 * np.pi * f[1:]) ** 2) * resp.displacement["passive_shroud"]
    y = np.fft.irfft(acc * spec, FRAME)
    n = FRAMES * FRAME
    x_all = np.tile(force, FRAMES) + rng.normal(0, 0.005, n)
    y_all = np.tile(y, FRAMES) + rng.normal(0, 0.02, n)
    with RecordingWriter(path, "synthetic", default_rig_text(), {"procedure": "tap test (synthetic)"}) as rec:
        point = rec.begin_point(
            params={
                "signal": "tap",
                "band_low": 20.0,
                "band_high": 2000.0,
                "frame_samples": FRAME,
                "record_start": 0.0,
                "record_samples": n,
                "hammer_location": "passive blade, 85 mm",
            },
            channels=[
                ChannelSpec("force", "N", "force", RATE, location="hammer on the passive blade"),
                ChannelSpec(
                    "passive_shroud_accel",
                    "m/s^2",
                    "acceleration",
                    RATE,
                    location="passive blade shroud (tip)",
                ),
            ],
        )
        point.append(np.vstack([x_all, y_all]))
        point.end()


@pytest.fixture(scope="module")
def both(tmp_path_factory, article, sim_recording):
    folder = tmp_path_factory.mktemp("tap")
    frf, tap = sim_recording(FRF, "frf.h5"), folder / "tap.h5"  # frf.h5 shared with test_update.py
    write_tap(tap, article[1])
    out = folder / "both.toml"
    code, js, err = run_cli(["update", frf, tap, "--params", FOUR, "--out", out, "--json"])
    assert code == 0, err
    return json.loads(js), out


def test_tap_test_gives_the_passive_blades_modes(both, article):
    doc, _ = both
    exact = {(t.blade, t.order): t.frequency_hz for t in mode_targets(article[1], 3)}
    got = {(t["blade"], t["order"]): t for t in doc["targets"]}
    assert sorted(got) == sorted(exact)
    for key, t in got.items():
        assert t["frequency_hz"] == pytest.approx(exact[key], rel=5e-4)
        assert t["damping_ratio"] == pytest.approx(0.012, rel=0.05)
    assert got[("passive", 1)]["sources"] == ["tap.h5:passive_shroud_accel"]
    assert not any("no passive-blade modes" in n for n in doc["notes"])


def test_both_blades_separate_root_stiffness_and_masses(both, article):
    """Four parameters from six modes of two blades: root stiffness within 10 % of 1.2e4 N*m/rad,
    shroud mass within 1 % of +1 %, damping within 10 % of 0.012, all six frequencies within
    0.3 %, and no pair reported inseparable."""
    doc, out = both
    spec, art = article
    fit = doc["fit"]
    p = {k: v["fitted"] for k, v in fit["parameters"].items()}
    print(
        f"both blades: root {p['root.rotational_stiffness']:.5g} N*m/rad, shroud {p['shroud.mass']:.5g} kg, "
        f"sensor {p['force_sensor.mass']:.5g} kg, zeta {p['damping.ratio']:.4g}; "
        f"max frequency error {100 * fit['max_frequency_error_after']:.3f} %; "
        f"unresolved {fit['identifiability']['unresolved']}"
    )
    assert p["root.rotational_stiffness"] == pytest.approx(spec.root_rotational_stiffness, rel=0.10)
    assert p["shroud.mass"] == pytest.approx(art.shroud.mass, rel=0.01)
    assert p["damping.ratio"] == pytest.approx(spec.damping_ratio, rel=0.10)
    assert fit["max_frequency_error_after"] < 0.003
    assert not any(
        "shroud.mass" in line and "root.rotational_stiffness" in line
        for line in fit["identifiability"]["unresolved"]
    )
    cfg = load_rig(out)
    assert (
        cfg.shroud.mass == p["shroud.mass"]
        and cfg.root.rotational_stiffness == p["root.rotational_stiffness"]
    )
    assert "frf.h5, tap.h5" in out.read_text()
