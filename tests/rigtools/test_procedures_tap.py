"""Impact-hammer (tap) test and FRF test on the simulated rig: the first three flexural
frequencies of BOTH blades against the simulated test article's own FE values.

Reference: :func:`rigtools.sim.modal.flexural_frequencies` of the FE model built from the rig file's
``[test_article]`` (``TestArticle.apply``, as :class:`rigtools.drivers.simulated.SimulatedRig` builds
it), an eigen-solve of the full FE blade -- independent of the reduced model, the modal
impulses of the hammer, the sensor chain, the trigger and the identification. Seed 1; the
figures in the docstrings were measured with these settings.
"""

import contextlib
import io
import json

import numpy as np
import pytest

from rigtools.config import load_rig
from rigtools.procedures import Status, TapTest
from rigtools.procedures.tap import analyze_tap_recording, double_hit, undecayed
from rigtools.recording import check_recording, open_recording

WIDE = 5e-3


@pytest.fixture(scope="module")
def cfg():
    return load_rig()


def _article(cfg, blade: str) -> np.ndarray:
    from rigtools.sim.modal import flexural_frequencies
    from rigtools.sim.rig_model import build_rig_model

    model = build_rig_model(cfg.test_article.to_params().apply(cfg.to_params()))
    return flexural_frequencies(model.blade(blade), 3)


def test_tap_test_gives_the_passive_blades_first_three_flexural_frequencies(cfg, tmp_path):
    """5 hits of 20 N (0.5 ms half-sine) at 85 mm on the passive blade, gap open: modes 1-3 within
    0.5 % of the article's own 53.69 / 471.24 / 1296.76 Hz (measured -0.006 / +0.006 / +0.039 %),
    damping within 5 % of the article's 1.2 %. Each hit is one raw point of 2 s, 10 ms of it
    before the trigger; the drive stays at 0 V; the file checks valid."""
    out = tmp_path / "tap.h5"
    r = TapTest(
        cfg, {"blade": "passive", "position": 0.085, "hits": 5, "gap": WIDE}, out, backend="sim", seed=1
    ).run()
    assert r.status is Status.FINISHED and r.summary["accepted"] == 5 and r.summary["hits"] == 5
    assert r.summary["response"] == "passive_shroud_accel"
    res = analyze_tap_recording(out, f_min=20, f_max=1600, n_modes=3)
    modes = res.modes["passive_shroud_accel"].modes
    em = np.array([m.frequency_hz for m in modes])
    np.testing.assert_allclose(em, _article(cfg, "passive"), rtol=5e-3)
    np.testing.assert_allclose([m.damping_ratio for m in modes], 0.012, rtol=0.05)
    assert check_recording(out).valid
    with open_recording(out) as rec:
        assert rec.status == "complete" and len(rec.points) == 5
        p = rec.points[0]
        assert p.params["accepted"] and p.params["pretrigger_samples"] == 512
        assert p.n_samples == p.params["frame_samples"] == 102400
        hammer = np.asarray(p["hammer"])
        assert np.argmax(hammer >= 5.0) == 512  # the trigger, after the pretrigger
        assert np.max(np.abs(hammer[:500])) < 0.1  # quiet before the pulse
        assert np.all(np.asarray(p["drive"]) == 0.0)


def test_frf_test_gives_the_active_blades_first_three_flexural_frequencies(cfg, tmp_path):
    """A periodic chirp 20-1600 Hz through the shaker (rig acquire frf), 1 s frames, 4 averages,
    gap open: the active blade's modes 1-3 from H1 (active shroud / force) within 0.5 % of the
    article's own 52.01 / 355.63 / 1252.94 Hz (measured -0.0004 / -0.005 / -0.004 %)."""
    from rigtools.analysis.frf import FRFMethod
    from rigtools.analysis.point import analyze_frf_test
    from rigtools.procedures.frf import FrfTest

    out = tmp_path / "frf.h5"
    FrfTest(
        cfg,
        {"signal": "chirp", "band": (20.0, 1600.0), "level": 0.3, "frame": 1.0, "averages": 4, "gap": WIDE},
        out,
        backend="sim",
        seed=1,
    ).run()
    with open_recording(out) as rec:
        p = rec.points[0]
        start = round(p.params["record_start"] * p.sample_rate)
        n, frame = int(p.params["record_samples"]), int(p.params["frame_samples"])
        blocks = [
            {
                name: np.asarray(p[name][start + i : start + i + frame])
                for name in ("force", "active_shroud_accel")
            }
            for i in range(0, n, frame)
        ]
        rate = p.sample_rate
    res = analyze_frf_test(
        blocks,
        rate,
        frf_method=FRFMethod("periodic", frame),
        responses=("active_shroud_accel",),
        f_min=20,
        f_max=1600,
        n_modes=3,
    )
    em = np.array([m.frequency_hz for m in res.modes["active_shroud_accel"].modes])
    np.testing.assert_allclose(em, _article(cfg, "active"), rtol=5e-3)


def test_double_hit_and_decay_checks():
    rate, level = 51200.0, 5.0
    t = np.arange(int(0.05 * rate)) / rate
    pulse = lambda t0: np.where((t >= t0) & (t < t0 + 5e-4), 20 * np.sin(np.pi * (t - t0) / 5e-4), 0.0)
    one = pulse(0.01)
    start = int(np.argmax(one >= level))
    assert double_hit(one, start, level, 102) == ""
    text = double_hit(one + pulse(0.02), start, level, 102)
    assert text.startswith("double hit") and 500 < int(text.split()[2]) < 530  # ~10 ms later
    decay = np.exp(-t * 200) * np.sin(2 * np.pi * 300 * t)
    assert undecayed(decay) == ""
    assert "not decayed" in undecayed(np.exp(-t * 2) * np.sin(2 * np.pi * 300 * t))


class _Run:
    def __init__(self, code, stdout, stderr):
        self.returncode, self.stdout, self.stderr = code, stdout, stderr


def _rig(*args):
    from rigtools.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["acquire", "tap", *args])
    return _Run(code, out.getvalue(), err.getvalue())


def test_cli_tap_json_and_errors(tmp_path):
    out = tmp_path / "t.h5"
    r = _rig(
        "--backend", "sim", "--position", "85 mm", "--hits", "2", "--gap", "5 mm", "--out", str(out), "--json"
    )
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["status"] == "finished" and doc["accepted"] == 2
    f = [m["frequency_hz"] for m in doc["modes"]]
    assert any(abs(x / 53.6855 - 1) < 5e-3 for x in f)
    bad = _rig("--backend", "sim", "--position", "200 mm", "--out", str(tmp_path / "b.h5"))
    assert bad.returncode == 2 and bad.stderr.strip().splitlines() == [
        "rig acquire: error: hammer position 200 mm is not on the passive blade (0 .. 155 mm from the root)"
    ]
    ni = _rig("--position", "85 mm", "--out", str(tmp_path / "n.h5"))
    assert ni.returncode == 2 and "[daq.channels.hammer]" in ni.stderr and "Traceback" not in ni.stderr
    unit = _rig("--backend", "sim", "--position", "85 N", "--out", str(tmp_path / "u.h5"))
    assert unit.returncode == 2 and "--position" in unit.stderr


def test_the_rig_files_hammer_channel_is_used_and_checked(cfg, tmp_path):
    """A [daq.channels.hammer] entry of the rig file is the hammer (its terminal and
    sensitivity recorded); a hammer channel that is not a force channel is refused in one line;
    a frame too short for the response to decay (0.5 s: mode 1 keeps 16 % of its amplitude) is
    recorded but rejected, and the test waits for the next accepted hit (here --timeout ends it
    after three rejected hits, status failed)."""
    import tomllib

    import tomli_w

    from rigtools.config import default_rig_text
    from rigtools.errors import UserError

    data = tomllib.loads(default_rig_text())
    data["daq"]["channels"]["hammer"] = {
        "physical_channel": "Dev1/ai3",
        "kind": "force",
        "sensitivity": "2.25 mV/N",
        "excitation_current": "4 mA",
        "range": "2200 N",
        "location": "impact hammer",
    }
    path = tmp_path / "hammer.toml"
    path.write_text(tomli_w.dumps(data))
    rig = load_rig(path)
    out = tmp_path / "h.h5"
    r = TapTest(rig, {"position": 0.085, "hits": 2, "gap": WIDE}, out, backend="sim", seed=1).run()
    assert r.status is Status.FINISHED
    with open_recording(out) as rec:
        ch = rec.points[0].channels["hammer"]
        assert ch.physical_channel == "Dev1/ai3" and ch.sensitivity == pytest.approx(2.25)
    data["daq"]["channels"]["hammer"]["kind"] = "accel"
    data["daq"]["channels"]["hammer"]["sensitivity"] = "10 mV/g"
    data["daq"]["channels"]["hammer"]["range"] = "4900 m/s^2"
    path.write_text(tomli_w.dumps(data))
    with pytest.raises(UserError, match=r"is kind 'accel': the hammer channel must be kind = \"force\""):
        TapTest(load_rig(path), {"position": 0.085, "hits": 2}, tmp_path / "x.h5", backend="sim").run()
    short = TapTest(
        cfg,
        {"position": 0.085, "hits": 2, "frame": 0.5, "timeout": 2.5, "gap": WIDE},
        tmp_path / "s.h5",
        backend="sim",
        seed=1,
    )
    with pytest.raises(
        UserError,
        match=r"no accepted hit over 5 N on hammer within 2.5 s \(0 of 2 hits "
        r"accepted, \d rejected: the response has not decayed",
    ):
        short.run()
    assert short.result.points[0]["accepted"] is False
    assert "not decayed" in short.result.points[0]["reject_reason"]
    with open_recording(tmp_path / "s.h5") as rec:
        assert rec.attrs["end_status"] == "failed" and not rec.points[0].params["accepted"]


def test_a_hammer_or_response_channel_that_is_no_input_is_named_in_the_callers_words(tmp_path):
    """On the simulated rig ``--hammer-channel nosuch`` made up a channel measuring the shaker's
    force, waited the whole timeout (60 s of the rig) and ended "no accepted hit over 5 N on
    nosuch"; now it is refused at once in one line naming the option and the inputs. A script's
    ``response="nosuch"`` was refused naming ``--response``, the command's word; now ``response``."""
    import rigtools
    from rigtools.errors import UserError

    out = tmp_path / "t.h5"
    r = _rig("--backend", "sim", "--position", "85 mm", "--hammer-channel", "nosuch", "--out", str(out))
    said = (
        "rig acquire: error: --hammer-channel = 'nosuch': no such input (inputs: force, "
        "active_shroud_accel, passive_shroud_accel; the simulated rig adds one whose name says "
        "hammer, e.g. 'hammer')"
    )
    assert r.returncode == 2 and r.stderr.strip().splitlines() == [said]
    with pytest.raises(UserError, match=r"^hammer_channel = 'nosuch': no such input"):
        rigtools.tap_test("85 mm", out, hammer_channel="nosuch", backend="sim")
    with pytest.raises(UserError, match=r"^response = 'nosuch': no such input \(inputs: force, "):
        rigtools.tap_test("85 mm", out, response="nosuch", backend="sim")
