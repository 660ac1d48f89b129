"""Force control held back by a limit (:meth:`rigtools.procedures.session.SineSession.hold_force`):
the verdict "the force target cannot be reached" must not depend on the noise draw.

At the limit a channel's linear prediction (``margin`` x warning / measured peak) sets the drive;
a measured peak carries noise, so that cap moves by ~1e-5..2e-3 of the drive from one measurement
to the next. The controller used to count only a step of <= 1e-6 as "no progress": a cap a hair
above the drive was taken as a step, and 15 in 1000 noise draws (simulated-rig seeds 0..999 of the
58 Hz, 1 kN sweep of ``test_bad_input_faults.py``) crept up the limit until the updates ran out,
ended without ``control_limited_by`` and went on to the next step.
"""

from types import SimpleNamespace

import numpy as np
import pytest
from cli_helpers import run_cli

from rigtools.procedures.session import SineSession

GAIN = 15.3  # N/V, the force per drive volt at 58 Hz on the default rig
CREST = 1.61  # force peak / fundamental there (impacts)
WARNING = 40.0  # N, the default rig's force warning


class ScriptedSession(SineSession):
    """hold_force's arithmetic on a constructed rig: the force fundamental is ``GAIN`` x drive,
    the force sensor's peak ``CREST`` x force x the next of ``peak_factors`` (a noisy maximum)."""

    def __init__(self, peak_factors) -> None:
        self.drive = SimpleNamespace(target=0.0)
        self.cfg = SimpleNamespace(safety=SimpleNamespace(max_drive=10.0))
        self.monitor = SimpleNamespace(limits={"force": SimpleNamespace(warning=WARNING)})
        self.names, self.n_inputs = ["force", "drive"], 1
        self.proc = SimpleNamespace(emit=lambda *args, **kwargs: None)
        self.stream = SimpleNamespace(stats=SimpleNamespace(warnings=[]))
        self._factors = iter(peak_factors)

    def measure(self, fe, seconds=0.1, max_wait=3.0):
        force = GAIN * self.drive.target
        return complex(force), np.array([CREST * force * next(self._factors)]), True

    def set_drive(self, amplitude, ramp_time=None) -> None:
        self.drive.target = amplitude


def creeping(step: float) -> list[float]:
    """Peak factors that read ``step`` lower at every measurement: the cap rises by ``step``."""
    return [(1 + step) ** -k for k in range(20)]


def test_a_cap_creeping_by_noise_is_the_limit():
    """1 kN asked, 19.9 N allowed: the drive goes to the force warning's cap (0.8 x 40 N / 1.61 /
    15.3 N/V = 1.2991 V; 1.2992 V as read at 0.8 V) and stops there although every later cap reads 1e-4 higher (it used to
    take 10 updates of 1e-4 and end with no limit named)."""
    res = ScriptedSession(creeping(1e-4)).hold_force(58.0, 1000.0)
    cap = 0.8 * WARNING / CREST / GAIN
    assert res.limited_by == "force warning" and not res.converged
    assert res.updates == 2  # 0.2 V -> 0.8 V (x4, max_step) -> the cap -> stop
    assert res.drive == pytest.approx(cap * (1 + 1e-4), rel=1e-12)  # the cap read at 0.8 V
    assert [round(a, 4) for a, _ in res.history] == [0.2, 0.8, 1.2992]


def test_the_last_update_judges_the_limit_too():
    """A control tolerance below the cap's creep (0.1 % < 0.3 % per measurement): the drive takes
    every small step up the cap until the 10 updates are spent, and the verdict is still the
    limit (19.9 N at the cap is 2 % of 1 kN)."""
    res = ScriptedSession(creeping(3e-3)).hold_force(58.0, 1000.0, tolerance=1e-3)
    assert res.limited_by == "force warning" and res.updates == 10 and not res.converged


def test_a_small_step_that_reaches_the_target_is_taken():
    """The cap 0.4 % above the drive with the force 0.6 % short (tolerance 0.5 %): a step smaller
    than the tolerance, but one that brings the force within it, is taken -- not the limit."""
    session = ScriptedSession([1.0] * 20)
    cap = 0.8 * WARNING / CREST / GAIN
    session.set_drive(cap / 1.004)
    target = GAIN * session.drive.target / 0.994
    res = session.hold_force(58.0, target)
    assert res.converged and res.limited_by == "" and res.updates == 1
    assert res.drive == pytest.approx(cap, rel=1e-12)
    assert res.history[-1][1] / target == pytest.approx(1.004 * 0.994, rel=1e-12)


def test_a_force_past_the_target_with_a_channel_past_its_margin_steps_down_first():
    """20 N asked, 20.4 N measured with the force peak 5 % past 0.8 x its warning: the drive steps
    down to the cap (0.95 x), and only there, 19.38 N short of 20 N, is the limit named."""
    a0 = 1.02 * 20.0 / GAIN
    session = ScriptedSession([0.8 * WARNING / (CREST * GAIN * 0.95 * a0)] * 20)
    session.set_drive(a0)
    res = session.hold_force(60.0, 20.0)
    assert res.limited_by == "force warning" and res.updates == 1
    assert [a / a0 for a, _ in res.history] == pytest.approx([1.0, 0.95], rel=1e-12)
    assert res.history[-1][1] == pytest.approx(0.95 * 20.4, rel=1e-12)


def test_the_noise_draw_that_made_the_sweep_go_on_stops_at_the_first_step(tmp_path):
    """Seed 231 is one of the 15 draws in 1000 that crept up the force warning at 58 Hz and
    recorded a second step; the run now ends failed after the first, limited by the force warning."""
    from rigtools.recording import open_recording

    out = tmp_path / "a.h5"
    argv = ["acquire", "sweep", "--backend", "sim", "--periods", "5", "--out", out, "--seed", "231"]
    code, _, err = run_cli([*argv, "--frequencies", "58 Hz,60 Hz,62 Hz", "--force", "1 kN"])
    assert code == 5 and "cannot be reached at 58 Hz" in err and "force warning limit" in err
    with open_recording(out) as rec:
        assert len(rec.points) == 1 and rec.points[0].params["control_limited_by"] == "force warning"


def test_the_simulated_rig_records_the_same_noise_unless_another_seed_is_asked(tmp_path):
    """Without --seed the simulated rig draws its noise from seed 0 (it used to draw from the
    operating system, so no two runs were alike): two runs write the same samples, --seed 1
    others; the recording names its seed."""
    from rigtools.recording import open_recording

    forces, seeds = {}, {}
    for name, extra in (("a", []), ("b", []), ("c", ["--seed", "1"])):
        out = tmp_path / f"{name}.h5"
        argv = ["acquire", "dwell", "--backend", "sim", "--fe", "60 Hz", "--force", "1 kN", "--out", out]
        assert run_cli([*argv, *extra])[0] == 5
        with open_recording(out) as rec:
            forces[name] = rec.points[0].channels["force"].read()
            seeds[name] = rec.experiment["device"]["details"]["seed"]
    assert forces["a"].size > 10000 and np.array_equal(forces["a"], forces["b"])
    assert forces["a"].shape == forces["c"].shape and not np.allclose(
        forces["a"], forces["c"], rtol=0, atol=1e-4
    )
    assert seeds == {"a": "0", "b": "0", "c": "1"}
