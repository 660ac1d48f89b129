"""The front door validates as the CLI does (issue 30, item 4): the same checks, one line naming
the argument by its Python name, before any work."""

from __future__ import annotations

import re

import numpy as np
import pytest

import rigtools
from rigtools.errors import UserError
from rigtools.point_spectrum import Spectrum


@pytest.fixture
def spec():
    return Spectrum("force", "N", np.linspace(0.0, 1000.0, 101), np.ones(101))


@pytest.mark.parametrize("f", [float("nan"), -1.0, 1000.1, 1e6, "60 Hz", None])
def test_spectrum_at_outside_its_bins_names_the_frequency(spec, f):
    with pytest.raises(UserError, match=r"^frequency_hz = .*not in this spectrum \(0 to 1000 Hz"):
        spec.at(f)


def test_spectrum_at_its_edges_answers(spec):
    assert spec.at(0.0) == spec.at(1000.0) == 1.0


def test_spectrum_of_no_point_names_the_argument():
    with pytest.raises(UserError, match=r"^point = None: give a recorded point"):
        rigtools.spectrum(None, "force")


@pytest.mark.parametrize("fe", [-60, 0, float("nan"), "-60 Hz"])
def test_analyze_recording_refuses_a_frequency_that_is_none(tmp_path, fe):
    with pytest.raises(UserError, match=r"^fe = "):
        rigtools.analyze_recording(tmp_path / "never-opened.h5", fe=fe)


def test_simulate_point_refuses_a_run_larger_than_the_memory_up_front():
    # 1e9 s at 60 Hz and hundreds of steps per period is ~1e13 samples: the CLI's memory check
    # (one line with the estimate) instead of numpy's MemoryError after the model is built
    with pytest.raises(UserError, match=r"needs about .*shorten duration") as info:
        rigtools.simulate_point(60, 15, duration="1e9 s")
    assert "--" not in str(info.value)  # Python names, not the CLI's options


@pytest.mark.parametrize("seed", [-1, 1.5, "x", 2**63])
def test_a_seed_that_is_no_seed_names_seed(tmp_path, seed):
    with pytest.raises(UserError, match=r"^seed = .*a seed is a whole number"):
        rigtools.dwell("60 Hz", "5 N", tmp_path / "d.h5", seed=seed, backend="sim")
    assert not (tmp_path / "d.h5").exists()


@pytest.mark.parametrize("k_max", [0, -3, 2.5, True])
def test_compare_with_model_k_max_names_k_max(tmp_path, k_max):
    with pytest.raises(UserError, match=r"^k_max = "):
        rigtools.compare_with_model(tmp_path / "em.h5", k_max=k_max)


def test_update_model_without_recordings_says_so(tmp_path):
    with pytest.raises(UserError, match=r"^recordings = \[\]: give at least one"):
        rigtools.update_model([], tmp_path / "u.toml")


def test_continuation_found_that_is_no_list_is_refused_before_the_work():
    with pytest.raises(UserError, match=r"^found = 'x': give a list \(found=\[\]\)"):
        rigtools.continuation("fe", "60 Hz", "61 Hz", gap="5 mm", found="x")


@pytest.mark.parametrize(
    ("args", "kwargs", "said"),
    [
        (("temp", "60 Hz", "61 Hz"), {}, "param = 'temp'"),
        (("fe", "x", "61 Hz"), {}, "start = 'x'"),
        (("fe", "60 Hz", "60 Hz"), {}, "start and stop are both '60 Hz'"),
    ],
)
def test_continuation_names_its_python_arguments(args, kwargs, said):
    """The script's words, not the command line's (--param, --from, --to)."""
    with pytest.raises(UserError, match=r"^" + re.escape(said)):
        rigtools.continuation(*args, gap="5 mm", **kwargs)


@pytest.mark.parametrize("amplitudes", [[-1e-4], [0.33e-3, 0.0]])
def test_cbc_refuses_a_target_amplitude_that_is_not_positive(tmp_path, amplitudes):
    """``control_based_continuation(..., amplitudes=[-1e-4])`` ran (the approach, 0 points) where
    ``rig acquire cbc --amplitude`` refuses (a text list goes through the command's parser, which
    says so already): now one line naming amplitudes, nothing written."""
    out = tmp_path / "c.h5"
    with pytest.raises(
        UserError, match=r"^amplitudes = .*: target amplitudes must be > 0 m \(got -?0"
    ) as info:
        rigtools.control_based_continuation("64 Hz", amplitudes, out, gap="0.5 mm", backend="sim")
    assert "\n" not in str(info.value) and not out.exists()


@pytest.mark.parametrize("gains", ["-5,0", (2000.0, -3.0), -1.0])
def test_cbc_refuses_a_negative_gain_in_the_scripts_words(tmp_path, gains):
    """A negative gain (positive feedback: it drives the orbit from its target) was accepted by
    the Python door and the command alike; now one line naming ``gains`` (the command says
    ``--gains``), nothing written."""
    out = tmp_path / "c.h5"
    with pytest.raises(UserError, match=r"^gains = .*: gains are >= 0") as info:
        rigtools.control_based_continuation("64 Hz", "0.32 mm", out, gains=gains, gap="0.5 mm", backend="sim")
    assert "\n" not in str(info.value) and not out.exists()


@pytest.mark.parametrize(
    ("forces", "params", "said"),
    [
        ("-5 N", {}, "forces = '-5 N': force amplitudes must be > 0 (got -5)"),  # was ">= 0", and "--force"
        ([0.0], {}, "forces = '0.0 N': force amplitudes must be > 0 (got 0)"),
        ("1 N", {"lock_tolerance": "1 s"}, "lock_tolerance = '1 s': give an angle with its unit"),
        ("1 N", {"max_periods": 30}, "max_periods 30 is below lock_periods 40"),
        ("1 N", {"phases": "200 deg"}, "phases = 200 deg: use -180 < phase < 0"),  # was "phase 200 deg"
    ],
)
def test_pll_names_its_python_arguments(tmp_path, forces, params, said):
    """The PLL door words its options parser's errors in the script's keywords (forces, not
    --force); the command says --force (tests/rigtools/test_bad_input.py)."""
    out = tmp_path / "p.h5"
    kwargs = {"lock_periods": 40, **params} if "max_periods" in params else params
    with pytest.raises(UserError, match=r"^" + re.escape(said)):
        rigtools.phase_locked_loop(forces, out, gap="0.5 mm", backend="sim", **kwargs)
    assert not out.exists()


@pytest.mark.parametrize(("word", "value"), [("release", "1 s"), ("max_iteration", 3)])
def test_cbc_names_an_unknown_keyword_as_the_other_doors_do(tmp_path, word, value):
    """A keyword the CBC door does not take (``release`` for ``release_seconds``, the option's
    name) was refused as "unknown key 'release'", naming neither the door nor what it takes; now
    the line of every door: the function, the keyword, a "did you mean" where one is close, and
    the accepted keywords. Nothing written."""
    out = tmp_path / "c.h5"
    with pytest.raises(
        UserError, match=rf"^rigtools.control_based_continuation: no keyword '{word}'"
    ) as info:
        rigtools.control_based_continuation("64 Hz", "0.32 mm", out, backend="sim", **{word: value})
    text = str(info.value)
    assert "release_seconds" in text and "max_iterations" in text and "\n" not in text
    assert not out.exists()


def test_dwell_names_a_bad_max_updates_by_its_keyword(tmp_path):
    """``rigtools.dwell(..., max_updates=0)`` was refused as ``control.max_updates = 0`` (the
    model's nesting, a word the script never wrote); now ``max_updates = 0``. A ``control=``
    dictionary keeps its path."""
    out = tmp_path / "d.h5"
    with pytest.raises(UserError, match=r"^max_updates = 0: outside the allowed range \[1, 100\]"):
        rigtools.dwell("60 Hz", "15 N", out, backend="sim", max_updates=0)
    with pytest.raises(UserError, match=r"^control.max_updates = 0: "):
        rigtools.dwell("60 Hz", "15 N", out, backend="sim", control={"max_updates": 0})
    assert not out.exists()


@pytest.mark.parametrize(
    ("kwargs", "said"),
    [
        ({"amplitudes": []}, "amplitudes = []: give at least one value"),  # was "at least 1 values"
        ({"inner_loop": "fast"}, "inner_loop = 'fast': choose one of realtime, buffered"),  # was "inner loop"
        (
            {"amplitudes": [0.32]},
            "amplitudes = [0.32]: a target must be at most 50 mm (got 0.32 m",
        ),  # was run
    ],
)
def test_cbc_door_lines_name_the_keyword(tmp_path, kwargs, said):
    """The CBC door's lines start with the keyword as the script wrote it; nothing written."""
    out = tmp_path / "c.h5"
    args = {"fe": "64 Hz", "amplitudes": "0.32 mm", "out": out, "backend": "sim", **kwargs}
    with pytest.raises(UserError, match=r"^" + re.escape(said)):
        rigtools.control_based_continuation(**args)
    assert not out.exists()
