"""CLI option helpers: each bad value is one UserError line naming the option and the value."""

import argparse
import os
import subprocess
import sys

import pytest

from rigtools import options
from rigtools.errors import UserError, command_line
from rigtools.units import MAX_GAP


def _refused(call, *args, **kwargs) -> str:
    with pytest.raises(UserError) as info:
        call(*args, **kwargs)
    message = str(info.value)
    assert "\n" not in message and info.value.exit_code == 2
    return message


# ------------------------------------------------------------------ gap
@pytest.mark.parametrize(
    "text, si", [("0.5 mm", 5e-4), ("0", 0.0), ("50 mm", MAX_GAP), ("500 um", 5e-4), ("0.0005", 5e-4)]
)
def test_gap_accepted(text, si):
    assert options.gap(text) == pytest.approx(si, rel=1e-12)


@pytest.mark.parametrize(
    "text, expected",
    [
        (
            "0.5",
            (
                "--gap = '0.5' is 500 mm, wider than any blade could close (a gap must be between 0 and "
                "50 mm); a plain number is metres: write gaps with units, e.g. '0.5 mm'"
            ),
        ),
        ("51 mm", "--gap = '51 mm' is 51 mm, wider than any blade could close (a gap must be between 0"),
        ("-0.1 mm", "--gap = '-0.1 mm': a gap must be between 0 and 50 mm"),
        ("1e400 mm", "--gap = '1e400 mm': '1e400 mm' is not a finite number"),
        ("0.5 MM", "--gap = '0.5 MM': unit 'MM' in '0.5 MM' is ambiguous"),
        ("3 N", "--gap = '3 N': '3 N' is a force, expected a length"),
        ("half a mm", "--gap = 'half a mm': cannot read"),
    ],
)
def test_gap_refused(text, expected):
    assert expected in _refused(options.gap, text)


def test_gap_names_its_option():
    assert _refused(options.gap, "1 m", "--values").startswith("--values = '1 m'")


# ------------------------------------------------------------------ durations, counts, positives
@pytest.mark.parametrize(
    "text, si", [("2 s", 2.0), ("500 ms", 0.5), ("1 min", 60.0), ("3", 3.0), ("1 h", 3600.0)]
)
def test_duration_accepted(text, si):
    assert options.duration(text) == si


@pytest.mark.parametrize(
    "text, kwargs, expected",
    [
        ("0 s", {}, "--duration = '0 s': must be > 0"),
        ("-1 s", {}, "--duration = '-1 s': must be > 0"),
        ("inf", {}, "cannot read 'inf'"),
        ("1e400 s", {}, "not a finite number"),
        ("2 h", {"maximum": 3600.0}, "--duration = '2 h': must be at most 3600 s"),
        ("2 Hz", {}, "'2 Hz' is a frequency, expected a time"),
        ("-1 s", {"allow_zero": True}, "must be >= 0"),
    ],
)
def test_duration_refused(text, kwargs, expected):
    assert expected in _refused(options.duration, text, **kwargs)


def test_duration_zero_allowed_when_asked():
    assert options.duration("0 s", "--settle", allow_zero=True) == 0.0


def test_positive_finite_names_option_and_unit():
    assert options.positive_finite("20 N", "force", "--force", maximum=100.0, unit="N") == 20.0
    assert "--force = '200 N': must be at most 100 N" in _refused(
        options.positive_finite, "200 N", "force", "--force", maximum=100.0, unit="N"
    )


@pytest.mark.parametrize(
    "text, kwargs, expected",
    [
        ("0", {}, "--steps = '0': must be >= 1"),
        ("2.5", {}, "expected a whole number"),
        ("ten", {}, "expected a whole number"),
        ("1e3", {}, "expected a whole number"),
        ("5001", {"maximum": 5000}, "must be between 1 and 5000"),
        (True, {}, "expected a whole number"),
    ],
)
def test_count_refused(text, kwargs, expected):
    assert expected in _refused(options.count, text, "--steps", **kwargs)


@pytest.mark.parametrize("text, value", [("1", 1), (" 40 ", 40), (7, 7), ("+3", 3)])
def test_count_accepted(text, value):
    assert options.count(text, "--steps") == value


# ------------------------------------------------------------------ seed
@pytest.mark.parametrize(
    "value, expected", [("0", 0), (42, 42), ("9223372036854775807", 2**63 - 1), (None, None)]
)
def test_seed_accepted(value, expected):
    assert options.seed(value) == expected


@pytest.mark.parametrize(
    "value, expected",
    [
        ("-1", "--seed = '-1': a seed is a whole number between 0 and 2**63 - 1"),
        (-5, "--seed = -5"),
        ("1.5", "a seed is a whole number >= 0"),
        ("abc", "--seed = 'abc'"),
        (2**63, "between 0 and 2**63 - 1"),
        (True, "--seed = True"),
    ],
)
def test_seed_refused(value, expected):
    assert expected in _refused(options.seed, value)


# ------------------------------------------------------------------ drive amplitude (peak V)
@pytest.mark.parametrize(
    "text, peak", [("1 V", 1.0), ("2 Vpp", 1.0), ("500 mV", 0.5), ("1", 1.0), ("300 mVpp", 0.15)]
)
def test_drive_amplitude_is_peak(text, peak):
    assert options.drive_amplitude(text) == pytest.approx(peak, rel=1e-14)


@pytest.mark.parametrize(
    "text, expected",
    [("0 V", "must be > 0 V"), ("-1 V", "must be > 0 V"), ("1 N", "is a force"), ("2 vpp", "write 'Vpp'")],
)
def test_drive_amplitude_refused(text, expected):
    assert expected in _refused(options.drive_amplitude, text)


# ------------------------------------------------------------------ output paths
def test_output_path_accepts_a_new_file(tmp_path):
    assert options.output_path(str(tmp_path / "run.h5")) == tmp_path / "run.h5"


def test_output_path_refusals(tmp_path):
    existing = tmp_path / "run.h5"
    existing.write_bytes(b"x")
    assert "is a directory" in _refused(options.output_path, str(tmp_path))
    assert "is a directory" in _refused(options.output_path, str(tmp_path / "new") + "/")
    assert "does not exist" in _refused(options.output_path, str(tmp_path / "nope" / "run.h5"))
    with command_line():  # rig's words; a script's: overwrite=True
        assert f"--out = {str(existing)!r} exists; give --overwrite" in _refused(
            options.output_path, str(existing)
        )
    assert "exists; give overwrite=True" in _refused(options.output_path, str(existing))
    assert "is not a folder" in _refused(options.output_path, str(existing / "x.h5"))
    assert "must end in .csv or .json" in _refused(
        options.output_path, str(tmp_path / "a.png"), False, suffixes=(".csv", ".json")
    )
    assert options.output_path(str(tmp_path / "A.CSV"), suffixes=(".csv",)).name == "A.CSV"
    assert "give a file name" in _refused(options.output_path, "  ")
    assert "--plot:" in _refused(options.output_path, "", option="--plot")
    assert options.output_path(str(existing), overwrite=True) == existing


def test_output_path_never_one_of_the_inputs(tmp_path):
    recording = tmp_path / "run.h5"
    recording.write_bytes(b"recording")
    message = _refused(options.output_path, str(recording), True, "--plot", inputs=[recording])
    assert "is an input of this command" in message
    # the same file by another spelling
    other = tmp_path / "sub" / ".." / "run.h5"
    (tmp_path / "sub").mkdir()
    assert "is an input" in _refused(options.output_path, str(other), True, inputs=[str(recording)])
    assert recording.read_bytes() == b"recording"


def test_output_path_a_link_to_a_file_still_to_be_made_exists(tmp_path):
    """``run.h5 -> elsewhere.h5`` (a link in the same folder to a file not there yet) is a name
    taken: refused without --overwrite up front, as any existing name (HDF5 refused to create
    over it after the whole run, in a line of h5py's internals), written through with it."""
    link = tmp_path / "run.h5"
    link.symlink_to("elsewhere.h5")
    with command_line():  # the command's words (a script's: overwrite=True)
        assert _refused(options.output_path, str(link)) == (
            f"--out = {str(link)!r} exists; give --overwrite to replace it"
        )
    assert _refused(options.output_path, str(link), False, "out").endswith(
        "exists; give overwrite=True to replace it"
    )
    assert options.output_path(str(link), overwrite=True) == link


@pytest.mark.skipif(os.name != "posix", reason="POSIX permission bits")
def test_output_path_read_only(tmp_path):
    """Refused by the permission bits, root included (the OS lets root write there: the tests
    skipped as root before, and /work/shared/data, r-xr-xr-x, took outputs)."""
    folder = tmp_path / "ro"
    folder.mkdir()
    target = tmp_path / "ro_file.h5"
    target.write_bytes(b"x")
    target.chmod(0o444)
    folder.chmod(0o555)
    try:
        assert _refused(options.output_path, str(folder / "run.h5")) == (
            f"--out = {str(folder / 'run.h5')!r}: folder {str(folder)!r} is not writable "
            "(dr-xr-xr-x: its permission bits let no one write there)"
        )
        assert _refused(options.output_path, str(target), True) == (
            f"--out = {str(target)!r} exists and is read-only (-r--r--r--); not replaced"
        )
        # a folder still to be made in a read-only one, and a derived file beside an input
        assert "is not writable" in _refused(options.output_folder, folder / "new" / "figs")
        from rigtools.derived_files import atomic_write

        assert "is not writable" in _refused(atomic_write, folder / "run.png", lambda tmp: None)
        assert sorted(p.name for p in folder.iterdir()) == []
    finally:
        folder.chmod(0o755)
        target.chmod(0o644)


@pytest.mark.skipif(os.name != "posix", reason="POSIX permission bits")
def test_commands_write_nothing_into_a_read_only_data_folder(tmp_path):
    """A folder of input data sets made read-only (as ../shared/data is): every writer refuses it
    in one line before any work, root included; the data stay as they were."""
    from cli_helpers import run_cli

    data = tmp_path / "data"
    data.mkdir()
    (data / "in.h5").write_bytes(b"measured")
    data.chmod(0o555)
    try:
        for argv, where in (
            (["simulate", "--out", data / "x.h5"], f"--out = {str(data / 'x.h5')!r}:"),
            (["demo", "--quick", "--out", data / "demo"], f"--out {data / 'demo'}:"),
        ):
            code, out, err = run_cli(argv)
            assert (code, out, err.strip().splitlines()) == (
                2,
                "",
                [
                    (
                        f"rig {argv[0]}: error: {where} folder {str(data)!r} is not writable "
                        "(dr-xr-xr-x: its permission bits let no one write there)"
                    )
                ],
            )
        assert [p.name for p in data.iterdir()] == ["in.h5"] and (data / "in.h5").read_bytes() == b"measured"
    finally:
        data.chmod(0o755)


def test_output_path_read_only_folder_simulated(tmp_path, monkeypatch):
    """The same refusal when the tests run as root (os.access says what the OS would)."""
    monkeypatch.setattr(options.os, "access", lambda path, mode: False)
    assert f"folder {str(tmp_path)!r} is not writable" in _refused(
        options.output_path, str(tmp_path / "a.h5")
    )


def test_check_out_is_output_path(tmp_path):
    existing = tmp_path / "a.h5"
    existing.write_bytes(b"")
    h5 = {"suffixes": options.HDF5_SUFFIXES}
    assert options.check_out(argparse.Namespace(out=str(tmp_path / "b.h5")), **h5) == tmp_path / "b.h5"
    with command_line():
        assert "exists; give --overwrite" in _refused(
            options.check_out, argparse.Namespace(out=str(existing)), **h5
        )
    assert options.check_out(argparse.Namespace(out=str(existing), overwrite=True), **h5) == existing
    assert "is a directory" in _refused(
        options.check_out, argparse.Namespace(out=str(tmp_path), overwrite=True), **h5
    )
    assert "must end in .h5 or .hdf5" in _refused(
        options.check_out, argparse.Namespace(out=str(tmp_path / "a.txt")), **h5
    )


@pytest.mark.parametrize(
    ("argv", "option", "suffixes"),
    [
        (["simulate", "--out"], "--out", ".h5 or .hdf5"),
        (["study", "gap", "--values", "0.5 mm", "--out"], "--out", ".h5 or .hdf5"),
        (["continuation", "--param", "fe", "--from", "60", "--to", "61", "--out"], "--out", ".h5 or .hdf5"),
        (
            ["acquire", "dwell", "--backend", "sim", "--fe", "60", "--force", "15", "--out"],
            "--out",
            ".h5 or .hdf5",
        ),
        (["import", "uff", "in.uff"], "OUT", ".h5 or .hdf5"),
        (["export", "uff", "run.h5"], "OUT", ".uff or .unv"),
        (["harmonic", "--out"], "--out", ".csv or .json"),
    ],
)
def test_an_output_named_for_another_format_is_one_line(tmp_path, argv, option, suffixes):
    """``--out a.txt`` of a command writing HDF5, UFF or a table: refused before any work with the
    suffixes its kind takes (HDF5 was written under any name before)."""
    from cli_helpers import run_cli

    out = tmp_path / "a.txt"
    code, stdout, err = run_cli([*argv, out])
    assert (code, stdout, err.strip().splitlines()) == (
        2,
        "",
        [f"rig {argv[0]}: error: {option} = {str(out)!r}: the file name must end in {suffixes}"],
    )
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------ memory (rigtools.memory)
def test_available_memory_matches_meminfo():
    from rigtools.memory import available_memory

    avail = available_memory()
    assert avail is None or avail > 0


def test_memory_refused_above_the_usable_fraction():
    from rigtools.memory import check_memory

    # 10 h at 51.2 kHz, 4 channels, float64: 36000 * 51200 * 4 * 8 B = 59.0 GB
    need = 10 * 3600 * 51200 * 4 * 8
    message = _refused(check_memory, need, "--duration '10 h'", "shorten it", available=8 * 10**9)
    assert message == "--duration '10 h' needs about 59 GB of memory, 8 GB are available: shorten it"
    check_memory(0.79 * 8e9, "fits", "", available=8 * 10**9)  # under 80 % of what is available
    assert "GB of memory" in _refused(check_memory, 0.81 * 8e9, "too much", "", available=8 * 10**9)


# ------------------------------------------------------------------ light import
def test_options_import_is_light():
    code = (
        "import sys, rigtools.options; heavy = {'numpy', 'scipy', 'h5py', 'numba', 'pydantic', "
        "'nidaqmx', 'pyvisa', 'matplotlib'}; print(sorted(heavy & set(sys.modules)))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize("text", ["60 Hz", "60 Hz, 60 Hz", "60 Hz:60 Hz:1 Hz"])
def test_a_sweep_of_one_frequency_is_one_line_naming_the_form(tmp_path, text):
    """``rig acquire sweep --frequencies "60 Hz"``: the option, the value and the form (pydantic's
    "frequencies = [60.0]: Tuple should have at least 2 items after validation, not 1" before;
    "60 Hz, 60 Hz" ran a one-step sweep)."""
    from cli_helpers import run_cli

    argv = ["acquire", "sweep", "--backend", "sim", "--frequencies", text, "--force", "15 N"]
    code, stdout, err = run_cli([*argv, "--out", tmp_path / "s.h5"])
    assert (code, stdout, err.strip().splitlines()) == (
        2,
        "",
        [
            (
                f"rig acquire: error: --frequencies = {text!r}: give at least 2 different frequencies, "
                'as "a,b,c" or "start:stop:step", e.g. "55 Hz:80 Hz:1 Hz"'
            )
        ],
    )
    assert list(tmp_path.iterdir()) == []


def test_a_front_door_sweep_of_one_frequency_is_one_line(tmp_path):
    import rigtools

    for given, words in (
        (["60 Hz"], "frequencies = ('60 Hz',): give at least 2 values"),
        (["60 Hz", "60 Hz"], "a stepped sine needs at least 2 different frequencies"),
    ):
        with pytest.raises(rigtools.UserError) as info:
            rigtools.stepped_sine(given, "15 N", gap="5 mm", out=tmp_path / "s.h5", backend="sim")
        assert words in str(info.value) and "\n" not in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_a_list_where_one_value_is_asked_is_named():
    """``--fe "64 Hz,65 Hz"`` (CBC holds one fe): said to be a list, not an unknown unit 'Hz,65 Hz'."""
    from rigtools.options import quantity

    with pytest.raises(UserError) as info:
        quantity("64 Hz,65 Hz", "frequency", "--fe")
    assert (
        str(info.value)
        == "--fe = '64 Hz,65 Hz': one value here, not a list (a frequency, e.g. '60 Hz', '5 kHz')"
    )


@pytest.mark.parametrize(("text", "value"), [("1 %", 0.01), ("0.5%", 0.005), ("0.02", 0.02)])
def test_cbc_tolerance_reads_a_percentage(text, value):
    """``--tolerance "1 %"`` is 0.01 (argparse's float refused it: 'invalid float value')."""
    from rigtools.cli import build_parser

    args = ["acquire", "cbc", "--fe", "64 Hz", "--amplitude", "0.33 mm", "--tolerance", text, "--out", "x.h5"]
    assert build_parser().parse_args(args).tolerance == pytest.approx(
        value, rel=1e-12
    )  # exact up to rounding


@pytest.mark.parametrize(
    ("text", "empty"),
    [
        ("340 Hz:350 Hz:", "step"),
        (":350 Hz:2 Hz", "start"),
        ("340 Hz::2 Hz", "stop"),
        ("340 Hz: :2 Hz", "stop"),
    ],
)
def test_an_empty_part_of_a_range_names_the_range(text, empty):
    """``"340 Hz:350 Hz:"`` (a step left out) is one line quoting the list given and naming the empty
    part; was ``--frequencies = '': cannot read '' as a quantity`` (the list itself not quoted)."""
    with pytest.raises(UserError) as info:
        options.value_list(text, "frequency", "--frequencies", minimum=2)
    assert str(info.value) == f"--frequencies = {text!r}: the {empty} is empty (write start:stop:step)"


@pytest.mark.parametrize("command", [["acquire", "study"], ["study"]])
@pytest.mark.parametrize(
    ("kind", "values", "option", "value"),
    [
        ("force", "5 N,10 N", "--force", "3 N"),
        ("gap", "0.3 mm,0.5 mm", "--gap", "0.9 mm"),
        ("frequency", "50 Hz,60 Hz", "--fe", "3 Hz"),
    ],
)
def test_a_studys_swept_quantity_given_fixed_is_refused(tmp_path, command, kind, values, option, value):
    """``rig acquire study force --values "5 N,10 N" --force "3 N"``: the fixed --force of a
    force study was ignored silently (the study ran 5 N and 10 N); now one line naming it, exit 2,
    no file (options.swept_not_fixed), in the rig's study and the model's alike."""
    from cli_helpers import run_cli

    out = tmp_path / "s.h5"
    backend = ["--backend", "sim", "--yes"] if command[0] == "acquire" else []
    code, stdout, err = run_cli([*command, kind, "--values", values, option, value, *backend, "--out", out])
    assert (code, stdout) == (2, "")
    plural = {"force": "forces", "gap": "gaps", "frequency": "frequencies"}[kind]
    line = f"rig {command[0]}: error: {option} = {value!r}: a {kind} study sweeps the {plural} given by --values; "
    assert err.strip().splitlines() == [line + f"leave {option} out (it would be ignored)"]
    assert list(tmp_path.iterdir()) == []
