"""One vocabulary for scripts and the CLI (issue 31, items 1-2): the CLI's words and range strings
work in Python, a measuring function without a backend is refused in one line, a misspelt keyword
gets a "did you mean", errors advise in the caller's language, and every procedure returns one
result type however it is called."""

from __future__ import annotations

import json
import warnings

import pytest

import rigtools
from rigtools import cli, errors
from rigtools.config import load_rig
from rigtools.errors import UserError
from rigtools.experiments import NO_BACKEND
from rigtools.options import band_option, value_list
from rigtools.procedures import PointResult, RunResult, SineDwell, Status

# The lab script of the must-show: the CLI's words (periods, max_updates) and range strings.
SCRIPT = """
import sys, rigtools
sweep = rigtools.stepped_sine("62 Hz:66 Hz:2 Hz", "15 N", sys.argv[1] + "/sweep.h5", gap="0.7 mm",
                              periods=5, max_updates=6, backend="sim", seed=1)
frf = rigtools.frf_test("20 Hz:500 Hz", "1 V", sys.argv[1] + "/frf.h5", frame="0.5 s", averages=2,
                        gap="5 mm", backend="sim")
print(sweep.status, [p.fe for p in sweep.points], frf.status, frf.points[0].extra["band_low"],
      frf.points[0].extra["band_high"])
"""


def test_a_script_in_the_clis_words_and_range_strings_runs(tmp_path):
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(tmp_path)], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    # the steps are 62, 64, 66 Hz (start:stop:step, stop included, as `rig acquire sweep` reads
    # it); the band is 20..500 Hz: written by hand, not by the parser under test
    assert done.stdout.split() == ["finished", "[62.0,", "64.0,", "66.0]", "finished", "20.0", "500.0"]
    with rigtools.open_recording(tmp_path / "sweep.h5") as rec:
        p = rec.points[0]
        rate = p.sample_rate
        # periods=5 is record_periods=5: the settled window holds 5 periods of 62 Hz, to a sample
        assert abs(p.record_window[1] - 5 * rate / 62.0) <= 1.0
        assert int(p.params["control_updates"]) <= 6  # max_updates=6 reached the force control


def test_range_strings_parse_as_the_cli_parses_them():
    from rigtools.procedures import FrfParameters, StudyParameters, SweepParameters
    from rigtools.procedures.base import validate

    sweep = validate(SweepParameters, frequencies="62 Hz:72 Hz:2 Hz", force="15 N")
    assert sweep.frequencies == (62.0, 64.0, 66.0, 68.0, 70.0, 72.0)
    assert list(sweep.frequencies) == value_list("62 Hz:72 Hz:2 Hz", "frequency", minimum=2)
    study = validate(StudyParameters, kind="gap", values="0.3 mm:0.9 mm:0.3 mm")
    assert study.values == pytest.approx((3e-4, 6e-4, 9e-4), rel=1e-12)  # float steps, 1e-12
    frf = validate(FrfParameters, band="50 Hz:200 Hz", level="1 V")
    assert frf.band == (50.0, 200.0) == band_option("50 Hz:200 Hz")
    # a malformed range is the CLI's one line, naming the Python keyword
    with pytest.raises(UserError, match=r"^frequencies = '62 Hz:72 Hz': write start:stop:step$"):
        validate(SweepParameters, frequencies="62 Hz:72 Hz", force=15)
    with pytest.raises(UserError, match=r'^band = \'50 Hz\': write LOW:HIGH, e.g. "100 Hz:4 kHz"$'):
        validate(FrfParameters, band="50 Hz", level=1)


@pytest.mark.parametrize(
    "call",
    [
        lambda out: rigtools.dwell("60 Hz", "15 N", out),
        lambda out: rigtools.stepped_sine("62 Hz:72 Hz:2 Hz", "15 N", out),
        lambda out: rigtools.acquire_study("gap", ["0.3 mm"], out, fe="60 Hz", force="15 N"),
        lambda out: rigtools.frf_test("20 Hz:500 Hz", "1 V", out),
        lambda out: rigtools.tap_test("85 mm", out),
    ],
    ids=["dwell", "stepped_sine", "acquire_study", "frf_test", "tap_test"],
)
def test_a_measurement_without_a_backend_is_refused_in_one_line(tmp_path, call):
    out = tmp_path / "run.h5"
    with pytest.raises(UserError) as info:
        call(out)
    text = str(info.value)
    assert text == NO_BACKEND and "\n" not in text
    assert 'backend="nidaq"' in text and 'backend="sim"' in text
    assert not out.exists()


def test_a_misspelt_keyword_gets_did_you_mean_and_the_accepted_ones(tmp_path):
    out = tmp_path / "d.h5"
    with pytest.raises(UserError) as info:
        rigtools.dwell("60 Hz", "15 N", out, record_period=6, backend="sim")
    text = str(info.value)
    assert text.startswith("rigtools.dwell: no keyword 'record_period'; did you mean 'record_periods'?")
    assert "(accepted: backend, control, fe, force, gap, k_max, max_updates, out," in text
    with pytest.raises(UserError, match=r"no keyword 'backnd'; did you mean 'backend'\?"):
        rigtools.stepped_sine("62 Hz:64 Hz:2 Hz", "1 N", out, backnd="sim")
    with pytest.raises(UserError, match=r"no keyword 'colour' \(accepted: "):  # nothing close
        rigtools.frf_test("20 Hz:500 Hz", "1 V", out, colour="red", backend="sim")
    with pytest.raises(UserError, match=r"did you mean 'sim'\?"):
        rigtools.dwell("60 Hz", "15 N", out, backend="simulated")
    with pytest.raises(UserError, match=r"periods=5 and record_periods=6 name one parameter"):
        rigtools.dwell("60 Hz", "15 N", out, record_periods=6, periods=5, backend="sim")
    assert not out.exists()


def test_errors_advise_in_the_callers_language(tmp_path, capsys):
    assert errors.option("backend", "sim") == 'backend="sim"' and not errors.on_command_line()
    with errors.command_line():
        assert errors.option("backend", "sim") == "--backend sim"
        assert errors.in_callers_words("use --backend sim") == "use --backend sim"
    assert errors.in_callers_words("use --backend sim to run") == 'use backend="sim" to run'
    # a script: the NI backend with a simulated-rig option is refused in a script's words
    with pytest.raises(UserError, match=r'^seed: for the simulated rig only; add backend="sim"$'):
        rigtools.dwell("60 Hz", "15 N", tmp_path / "d.h5", seed=3, backend="nidaq")
    # the command line: the same refusal in its words, and the flag is down again afterwards
    code = cli.main(
        ["acquire", "dwell", "--fe", "60", "--force", "15 N", "--seed", "3", "--out", str(tmp_path / "c.h5")]
    )
    assert code == 2 and not errors.on_command_line()
    assert (
        capsys.readouterr().err.strip()
        == "rig acquire: error: --seed: for the simulated rig only; add --backend sim"
    )


def test_the_ni_driver_missing_in_a_script_says_backend_sim(tmp_path, monkeypatch):
    """The drivers write their advice in the CLI's words (they cannot import rigtools.errors);
    the door of a script rewords it. The driver's absence is made so on every machine."""
    from rigtools.drivers.contracts import DriverUnavailable

    nidaq = pytest.importorskip("rigtools.drivers.nidaq", reason="the nidaqmx package is not installed")

    def no_driver(*args, **kwargs):
        raise DriverUnavailable(nidaq.NO_DRIVER_MESSAGE)

    monkeypatch.setattr(nidaq.NiDaqDevice, "configure", no_driver)
    with pytest.raises(DriverUnavailable) as info:
        rigtools.dwell("60 Hz", "15 N", tmp_path / "d.h5", backend="nidaq")
    assert (
        str(info.value)
        == 'NI-DAQmx driver not found on this machine; use backend="sim" to run on the simulated rig'
    )


def test_rigtools_study_is_the_deprecated_name_of_acquire_study(tmp_path):
    with (
        pytest.warns(DeprecationWarning, match=r"rigtools.study is deprecated.*rigtools.acquire_study"),
        pytest.raises(UserError, match="backend: not given"),
    ):
        rigtools.study("gap", ["0.3 mm"], tmp_path / "s.h5")
    assert "study" not in rigtools.__all__ and "acquire_study" in rigtools.__all__
    with pytest.warns(DeprecationWarning, match="ProcedureResult is deprecated"):
        from rigtools.procedures import ProcedureResult
    assert ProcedureResult is RunResult


def test_one_result_type_from_both_doors(tmp_path):
    params = {"fe": 60.0, "force": 5.0, "gap": 5e-3, "record_periods": 6}
    by_class = SineDwell(load_rig(), params, tmp_path / "a.h5", backend="sim", seed=1).run()
    by_door = rigtools.dwell("60 Hz", "5 N", tmp_path / "b.h5", gap="5 mm", periods=6, backend="sim", seed=1)
    assert type(by_class) is type(by_door) is RunResult
    assert by_class.procedure == by_door.procedure == "sine dwell"
    for run in (by_class, by_door):
        # the status is the enum and the word at once: every comparison a copied example makes
        assert run.status == "finished" and run.status is Status.FINISHED and run.status.value == "finished"
        assert f"{run.status}" == str(run.status) == "finished" and repr(run.status) == "'finished'"
        assert json.loads(json.dumps(run.to_dict()))["status"] == "finished"
        assert isinstance(run.points[0], PointResult)
    # the same seed and parameters record the same point through either door
    a, b = by_class.points[0], by_door.points[0]
    assert a.force_amplitude_measured == b.force_amplitude_measured
    assert a.harmonics["force"] == b.harmonics["force"] and len(a.phases["force"]) == len(
        a.harmonics["force"]
    )
    # force control holds F0 within 1 % (the procedure's tolerance)
    assert abs(a.force_amplitude_measured - 5.0) < 0.05


def test_point_dict_access_still_works_with_a_deprecation_warning():
    raw = {
        "fe": 60.0,
        "force_amplitude": 15.0,
        "direction": "up",
        "harmonics": {"force": {"amplitude": [15.0, 0.2], "phase": [0.0, 1.0]}},
    }
    p = PointResult.from_procedure(0, raw)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert (p.fe, p.force, p.extra["direction"], p.harmonics["force"]) == (60.0, 15.0, "up", (15.0, 0.2))
    with pytest.warns(DeprecationWarning, match=r"point\['fe'\] is deprecated"):
        assert p["fe"] == 60.0
    with pytest.warns(DeprecationWarning):
        assert p["harmonics"] == raw["harmonics"] and p["force_amplitude"] == 15.0
    with pytest.warns(DeprecationWarning):
        assert p["direction"] == "up"
