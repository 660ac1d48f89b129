"""The second hostile run (issue 19): faults the first bad-input suite did not cover.

Reuses the harness of ``test_bad_input.py`` (the ``lab`` folder of real recordings, ``Case``,
``run_cli``). Every case asserts its exit status, at most two lines on stderr, no traceback, and
that every file existing before it -- in the shared ``lab`` and in the case's own folder, device
nodes, FIFOs and links included -- is unchanged afterwards (content hash, or type and device
number). Device nodes are private ``mknod`` copies inside the case's folder (root only), never
the real ``/dev/null``; a full disk is ``RLIMIT_FSIZE`` lowered around the in-process case.
Subprocesses only where a stream needs one (closed or full stdout, an ASCII locale); two demos
into one folder: tests/rigtools/test_demo_report.py (beside the README's demo run).
"""

from __future__ import annotations

import hashlib
import json
import os
import resource
import signal
import stat
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
import pytest
from test_bad_input import Case, _fill, _param, _write_recording, _write_tdms, run_cli

from rigtools.config import default_rig_text
from rigtools.recording import check_recording

ROOT = os.geteuid() == 0 if hasattr(os, "geteuid") else False
needs_root = pytest.mark.skipif(not ROOT, reason="mknod of a device node needs root")


# ----------------------------------------------------------------------------------- harness
@pytest.fixture(scope="module")
def lab(tmp_path_factory) -> Path:
    """The lab of ``test_bad_input.py``: real recordings ``run.h5``, ``run.png`` (a recording named
    .png), ``nan.h5`` (NaN samples), a rig file and a TDMS log."""
    folder = tmp_path_factory.mktemp("lab")
    _write_recording(folder / "run.h5")
    _write_recording(folder / "run.png")
    _write_recording(folder / "nan.h5", nan=True)
    (folder / "rig.toml").write_text(default_rig_text(), encoding="utf-8")
    _write_tdms(folder / "in.tdms")
    return folder


def snapshot(*folders: Path) -> dict[str, tuple]:
    """Every entry of ``folders`` (not recursing): regular files by content hash, links by
    target, device nodes and FIFOs by type and device number."""
    out: dict[str, tuple] = {}
    for folder in folders:
        for p in sorted(folder.iterdir()):
            st = os.lstat(p)
            if stat.S_ISLNK(st.st_mode):
                out[str(p)] = ("link", os.readlink(p))
            elif stat.S_ISREG(st.st_mode):
                out[str(p)] = ("file", hashlib.sha256(p.read_bytes()).hexdigest())
            elif not stat.S_ISDIR(st.st_mode):
                out[str(p)] = ("special", stat.S_IFMT(st.st_mode), st.st_rdev)
    return out


def check_case(code: int, err: str, expected: int | tuple[int, ...], before: dict, *folders: Path) -> None:
    lines = [line for line in err.splitlines() if line.strip()]
    assert "Traceback" not in err, err
    assert code in (expected if isinstance(expected, tuple) else (expected,)), (code, err)
    assert len(lines) <= 2, err
    now = snapshot(*folders)
    assert {k: now.get(k) for k in before} == before, "a file that existed before the case changed"
    leftovers = [k for k in now if k.endswith(".tmp") and k not in before]
    assert not leftovers, f"temporary files left behind: {leftovers}"


def run(case: Case, lab: Path, tmp: Path) -> str:
    if case.setup:
        case.setup(tmp)
    before = snapshot(lab, tmp)
    code, _, err = run_cli(_fill(case.argv, lab, tmp))
    check_case(code, err, case.code, before, lab, tmp)
    if case.expect:
        assert case.expect in err, err
    return err


def _device(name: str, minor: int = 3) -> Callable[[Path], None]:
    def setup(tmp: Path) -> None:
        os.mknod(tmp / name, stat.S_IFCHR | 0o666, os.makedev(1, minor))

    return setup


def _fifo(name: str) -> Callable[[Path], None]:
    return lambda tmp: os.mkfifo(tmp / name)


def _link_out(name: str) -> Callable[[Path], None]:
    def setup(tmp: Path) -> None:
        (tmp / "elsewhere").mkdir()
        (tmp / "elsewhere" / "victim").write_text("precious\n")
        (tmp / name).symlink_to(tmp / "elsewhere" / "victim")

    return setup


def _rig_copy(tmp: Path) -> None:
    (tmp / "rig.toml").write_text(default_rig_text(), encoding="utf-8")


# --------------------------------------------------------------- items 1, 4: the output-path guard
WRITERS: dict[str, tuple[Callable[..., list[str]], str]] = {
    "simulate": (lambda out, *x: ["simulate", "--out", out, "--no-plot", "--duration", "0.05 s", *x], ".h5"),
    "study": (lambda out, *x: ["study", "gap", "--values", "0.5 mm", "--out", out, *x], ".h5"),
    "harmonic": (lambda out, *x: ["harmonic", "--points", "3", "--out", out, *x], ".csv"),
    "dwell": (
        lambda out, *x: (
            ["acquire", "dwell", "--backend", "sim", "--fe", "60 Hz", "--force", "15 N"] + ["--out", out, *x]
        ),
        ".h5",
    ),
    "export": (lambda out, *x: ["export", "uff", "{lab}/run.h5", out, *x], ".uff"),
    "import": (lambda out, *x: ["import", "tdms", "{lab}/in.tdms", out, *x], ".h5"),
    "update": (lambda out, *x: ["update", "{lab}/run.h5", "--out", out, *x], ".toml"),
}


def _guard_cases() -> list[Case]:
    cases: list[Case] = []
    for name, (make, suffix) in WRITERS.items():
        target = "x" + suffix
        cases += [
            Case(f"{name}:device", make("{tmp}/" + target), setup=_device(target), marks=[needs_root]),
            Case(
                f"{name}:device-overwrite",
                make("{tmp}/" + target, "--overwrite"),
                setup=_device(target),
                expect="device",
                marks=[needs_root],
            ),
            Case(
                f"{name}:full-device-overwrite",
                make("{tmp}/" + target, "--overwrite"),
                setup=_device(target, 7),
                marks=[needs_root],
            ),
            Case(f"{name}:fifo-overwrite", make("{tmp}/" + target, "--overwrite"), setup=_fifo(target)),
            Case(f"{name}:proc", make("/proc/self/" + target), expect="kernel"),
            Case(f"{name}:sys", make("/sys/" + target), expect="kernel"),
            Case(
                f"{name}:symlink-out-overwrite",
                make("{tmp}/" + target, "--overwrite"),
                setup=_link_out(target),
                expect="symbolic link",
            ),
            Case(f"{name}:name-300-chars", make("{tmp}/" + "n" * 300 + suffix), expect="longer"),
        ]
    rig_in = ["--rig", "{tmp}/rig.toml"]
    cases += [
        Case(
            "simulate:out-is-its-rig",
            ["simulate", *rig_in, "--out", "{tmp}/rig.toml", "--overwrite", "--no-plot"],
            setup=_rig_copy,
            expect="input",
        ),
        Case(
            "study:out-is-its-rig",
            ["study", "gap", "--values", "0.5 mm", *rig_in, "--out", "{tmp}/rig.toml", "--overwrite"],
            setup=_rig_copy,
            expect="input",
        ),
        Case(
            "dwell:out-is-its-rig",
            WRITERS["dwell"][0]("{tmp}/rig.toml", *rig_in, "--overwrite"),
            setup=_rig_copy,
            expect="input",
        ),
        Case(
            "update:out-is-its-rig",
            ["update", "{lab}/run.h5", *rig_in, "--out", "{tmp}/rig.toml", "--overwrite"],
            setup=_rig_copy,
            expect="input",
        ),
        Case(
            "update:out-is-the-test",
            ["update", "{lab}/run.h5", "--out", "{lab}/run.h5", "--overwrite"],
        ),
    ]
    for name, argv in {
        "analyze": ["analyze", "{lab}/run.h5", "--out"],
        "compare": ["compare", "{lab}/run.h5", "{lab}/run.h5", "--out"],
        "report": ["report", "{lab}/run.h5", "--out"],
        "demo": ["demo", "--quick", "--out"],
    }.items():
        cases += [
            Case(f"{name}:folder-in-proc", [*argv, "/proc/self/rigout"]),
            Case(f"{name}:folder-in-sys", [*argv, "/sys/rigout"]),
            Case(f"{name}:folder-is-device", [*argv, "{tmp}/dev"], setup=_device("dev"), marks=[needs_root]),
            Case(f"{name}:folder-empty-name", [*argv, ""]),
        ]
    return cases


@pytest.mark.parametrize("case", _param(_guard_cases()))
def test_output_path_guard(case, lab, tmp_path):
    run(case, lab, tmp_path)


# -------------------------------------------------------------------------- item 6: disk full
LIMIT = 64 * 1024  # bytes: more than a rig file, less than any output below


def _limited(argv: list[str]) -> tuple[int, str, str]:
    """``rig ARGV`` in this process with RLIMIT_FSIZE lowered (writes past it fail with EFBIG)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    old = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (LIMIT, hard))
    try:
        return run_cli(argv)
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        signal.signal(signal.SIGXFSZ, old)


def _old_uff(tmp: Path) -> None:
    (tmp / "old.uff").write_text("an older export the user keeps\n")


FULL_DISK = [
    Case(
        "export:new", ["export", "uff", "{lab}/run.h5", "{tmp}/o.uff"], code=4, expect="; o.uff not written"
    ),
    Case(
        "export:over-existing",
        ["export", "uff", "{lab}/run.h5", "{tmp}/old.uff", "--overwrite"],
        code=4,
        setup=_old_uff,
        expect="; old.uff not written (the one there is unchanged)",
    ),
    Case("harmonic:csv", ["harmonic", "--points", "400", "--out", "{tmp}/h.csv"], code=4),
    Case("harmonic:json", ["harmonic", "--points", "400", "--out", "{tmp}/h.json"], code=4),
    Case("report", ["report", "{lab}/run.h5", "--out", "{tmp}/rep"], code=4),
    Case("analyze-out", ["analyze", "{lab}/run.h5", "--out", "{tmp}/figs"], code=4),
    Case("compare-out", ["compare", "{lab}/run.h5", "{lab}/run.h5", "--out", "{tmp}/cmp"], code=4),
    Case("simulate", ["simulate", "--duration", "0.5 s", "--out", "{tmp}/s.h5"], code=4),
]


@pytest.mark.parametrize("case", _param(FULL_DISK))
def test_disk_full(case, lab, tmp_path):
    if case.setup:
        case.setup(tmp_path)
    before = snapshot(lab, tmp_path)
    code, _, err = _limited(_fill(case.argv, lab, tmp_path))
    check_case(code, err, case.code, before, lab, tmp_path)
    assert "error" in err and ("too large" in err.lower() or "space" in err.lower()), err
    assert case.expect is None or case.expect in err, err
    for folder in [tmp_path, *(p for p in tmp_path.iterdir() if p.is_dir())]:
        partial = [p.name for p in folder.iterdir() if p.suffix in (".uff", ".html") and str(p) not in before]
        assert not partial, f"a partial file was left: {partial}"


# ---------------------------------------------- item 5: rig check means what the readers rely on
def _attr(where: str, key: str, value) -> Callable[[h5py.File], None]:
    def change(f: h5py.File) -> None:
        f[where].attrs[key] = value

    return change


def _int16(f: h5py.File) -> None:
    data = f["points/0000/force"][...]
    attrs = dict(f["points/0000/force"].attrs)
    del f["points/0000/force"]
    ds = f["points/0000"].create_dataset("force", data=data.astype(np.int16))
    ds.attrs.update(attrs)


def _rename(new: str) -> Callable[[h5py.File], None]:
    def change(f: h5py.File) -> None:
        f["points/0000"].move("active_shroud_accel", new)
        f["points/0001"].move("active_shroud_accel", new)

    return change


def _no_fe(f: h5py.File) -> None:
    del f["points/0000"].attrs["fe"]


def _empty(*names: str) -> Callable[[h5py.File], None]:
    def change(f: h5py.File) -> None:
        for name in names:
            attrs = dict(f[f"points/0000/{name}"].attrs)
            del f[f"points/0000/{name}"]
            f["points/0000"].create_dataset(name, shape=(0,), dtype=float).attrs.update(attrs)

    return change


DEFECTS: dict[str, Callable[[h5py.File], None]] = {
    "fe-missing": _no_fe,  # a sine dwell's point without its excitation frequency (issue 30)
    "fe-zero": _attr("points/0000", "fe", 0.0),
    "channel-empty": _empty("active_shroud_accel"),
    "channels-empty": _empty("force", "active_shroud_accel", "passive_shroud_accel", "drive"),
    "fe-nan": _attr("points/0000", "fe", np.nan),
    "fe-negative": _attr("points/0000", "fe", -60.0),
    "fe-text": _attr("points/0000", "fe", "sixty"),
    "fe-list": _attr("points/0000", "fe", [60.0, 61.0]),
    "fe-above-nyquist": _attr("points/0001", "fe", 1500.0),
    "fe-inf": _attr("points/0001", "fe", np.inf),
    "force-negative": _attr("points/0000", "force_amplitude", -15.0),
    "force-nan": _attr("points/0000", "force_amplitude", np.nan),
    "record-start-nan": _attr("points/0000", "record_start", np.nan),
    "rig-garbage": _attr("/", "rig", "{{not json nor toml"),
    "rig-a-number": _attr("/", "rig", "42"),
    "rig-bad-value": _attr("/", "rig", json.dumps({"contact": {"gap": -1}})),
    "units-g": _attr("points/0000/active_shroud_accel", "units", "g"),
    "units-unknown": _attr("points/0000/force", "units", "furlongs"),
    "int16-channel": _int16,
    "name-with-space": _rename("active shroud"),
    "name-leading-dot": _rename(".hidden"),
}
# a defect check reports; the readers that need the defective part refuse it in one line (2),
# those that do not need it (a rig attribute for analyze) go on (0)
READERS = {
    "check": (["check", "{tmp}/bad.h5"], 1),
    "info": (["info", "--json", "{tmp}/bad.h5"], 2),
    "analyze": (["analyze", "--json", "{tmp}/bad.h5"], 2),
    "compare": (["compare", "--json", "{tmp}/bad.h5", "{lab}/run.h5"], 2),
    "export": (["export", "uff", "{tmp}/bad.h5", "{tmp}/o.uff"], 2),
    "update": (["update", "{tmp}/bad.h5", "--out", "{tmp}/u.toml"], 2),
}
NEEDS_RIG = {"compare", "update"}
# defects of one point: every reader refuses the file (the reader contract, issue 30), and
# --skip-damaged reads the rest leaving the point out with a note
LEFT_OUT = {"fe-missing", "fe-zero", "channel-empty", "channels-empty"}


def _bad_file(defect: str) -> Callable[[Path], None]:
    def setup(tmp: Path) -> None:
        _write_recording(tmp / "bad.h5")
        with h5py.File(tmp / "bad.h5", "r+") as f:
            DEFECTS[defect](f)

    return setup


def _reader_cases() -> list[Case]:
    cases = []
    for defect in DEFECTS:
        for reader, (argv, code) in READERS.items():
            if defect.startswith("rig-") and reader not in ("check",) and reader not in NEEDS_RIG:
                code = 0  # the rig attribute is not needed: info and analyze read on
            cases.append(Case(f"{reader}:{defect}", argv, code=code, setup=_bad_file(defect)))
    return cases


@pytest.mark.parametrize("case", _param(_reader_cases()))
def test_a_file_check_refuses_is_refused_by_every_reader(case, lab, tmp_path):
    run(case, lab, tmp_path)


@pytest.mark.parametrize("defect", sorted(DEFECTS))
def test_check_names_the_defect(defect, tmp_path):
    _bad_file(defect)(tmp_path)
    result = check_recording(tmp_path / "bad.h5")
    assert not result.valid and any(p.severity == "error" for p in result.problems)


@pytest.fixture(scope="module")
def sim_recordings(tmp_path_factory) -> Path:
    """A simulated dwell ``dwell.h5`` and FRF test ``frf.h5`` (the simulated rig), and a rig file."""
    folder = tmp_path_factory.mktemp("sim")
    for argv in (
        ["acquire", "dwell", "--backend", "sim", "--fe", "60 Hz", "--force", "2 N", "--periods", "5"],
        ["acquire", "frf", "--backend", "sim", "--band", "20 Hz:500 Hz", "--level", "0.5 V"],
    ):
        code, _, err = run_cli([*argv, "--seed", "1", "--json", "--out", str(folder / f"{argv[1]}.h5")])
        assert code == 0, err
    (folder / "rig.toml").write_text(default_rig_text(), encoding="utf-8")
    return folder


# fe = 0 means "no single excitation frequency" (an FRF test; rigtools.vocabulary.excitation_frequency):
# legal, so check passes; no reader analyses the point at a frequency. Each reader ends in one line
# naming why, or reads on: (argv, exit status, text on stderr or in the --json document).
DAMAGED = "z.h5 is damaged: /points/0000: a sine point that has fe = 0"
FE_ZERO_READERS = {  # an error of check (issue 30): every reader refuses the file (--skip-damaged reads on)
    "check": (["check", "{tmp}/z.h5"], 1, ""),
    "info": (["info", "{tmp}/z.h5"], 2, DAMAGED),
    "analyze": (["analyze", "--json", "{tmp}/z.h5"], 2, DAMAGED),
    "report": (["report", "{tmp}/z.h5", "--out", "{tmp}/r.html"], 2, DAMAGED),
    "compare-em": (["compare", "--json", "{tmp}/z.h5", "{sim}/dwell.h5"], 2, DAMAGED),
    "compare-model": (["compare", "--json", "{sim}/dwell.h5", "{tmp}/z.h5"], 2, DAMAGED),
    "export": (["export", "uff", "{tmp}/z.h5", "{tmp}/o.uff"], 2, DAMAGED),
    "update": (["update", "{tmp}/z.h5", "--rig", "{sim}/rig.toml", "--out", "{tmp}/u.toml"], 2, DAMAGED),
}


@pytest.mark.parametrize("reader", list(FE_ZERO_READERS))
def test_fe_zero_on_a_dwell_point_is_one_line_in_every_reader(reader, sim_recordings, tmp_path):
    """fe = 0 on a simulated dwell's point (written there with h5py) crashed analyze, compare and
    report (ZeroDivisionError): now one line naming why, or the reader goes on; nothing existing
    changes, no partial output."""
    import shutil

    shutil.copy(sim_recordings / "dwell.h5", tmp_path / "z.h5")
    with h5py.File(tmp_path / "z.h5", "r+") as f:
        f["points/0000"].attrs["fe"] = 0.0
    argv, expected, text = FE_ZERO_READERS[reader]
    before = snapshot(sim_recordings, tmp_path)
    code, _, err = run_cli([a.format(tmp=tmp_path, sim=sim_recordings) for a in argv])
    check_case(code, err, expected, before, sim_recordings, tmp_path)
    assert text in err
    if expected != 0:
        assert sorted(p.name for p in tmp_path.iterdir()) == ["z.h5"]


def test_fe_zero_beside_a_periodic_point_is_left_out_with_a_note(lab, tmp_path):
    """A two-point dwell file, fe = 0 on the first: analyze reads the second at its 61 Hz and says
    why it left the first out; compare leaves it out with a note and pairs the other."""
    _write_recording(tmp_path / "z.h5")
    with h5py.File(tmp_path / "z.h5", "r+") as f:
        f["points/0000"].attrs["fe"] = 0.0
    code, out, err = run_cli(["analyze", "--json", "--skip-damaged", str(tmp_path / "z.h5")])
    assert code == 0, err
    doc = json.loads(out)
    assert [(p["point"], p["kind"]) for p in doc["points"]] == [(1, "periodic")]
    assert doc["points"][0]["params"]["fe"] == 61.0
    assert any(n.startswith("point 0 left out: a sine point that has fe = 0") for n in doc["notes"])
    code, out, err = run_cli(
        ["compare", "--json", "--skip-damaged", str(tmp_path / "z.h5"), str(lab / "run.h5")]
    )
    assert code == 0, err
    doc = json.loads(out)
    assert any("EM: point 0 left out: a sine point that has fe = 0" in n for n in doc["notes"])


def test_fe_zero_on_frames_stays_legal(sim_recordings, tmp_path):
    """The FRF test's framed point with fe = 0 (no single excitation frequency): check passes,
    analyze reads it as broadband, with the same modes as without it."""
    import shutil

    shutil.copy(sim_recordings / "frf.h5", tmp_path / "z.h5")
    with h5py.File(tmp_path / "z.h5", "r+") as f:
        f["points/0000"].attrs["fe"] = 0.0
    assert check_recording(tmp_path / "z.h5").valid
    peaks = []
    for path in (sim_recordings / "frf.h5", tmp_path / "z.h5"):
        code, out, err = run_cli(["analyze", "--json", str(path)])
        assert code == 0, err
        doc = json.loads(out)
        assert doc["points"][0]["kind"] == "broadband"
        peaks.append({k: v for k, v in doc["points"][0].items() if k != "params"})
    assert peaks[0] == peaks[1] and peaks[0]["frf"]["modes"]["active_shroud_accel"]


# ------------------------------------------- items 7, 8: incomplete points, JSON always valid
def _strict_json(text: str):
    def bad(token: str):
        raise ValueError(f"bare {token} in JSON")

    return json.loads(text, parse_constant=bad)


def _cut_off(tmp: Path) -> None:
    _write_recording(tmp / "cut.h5")
    with h5py.File(tmp / "cut.h5", "r+") as f:
        f["points/0001"].attrs["end_time"] = ""
        f["points/0001"].attrs["point_complete"] = False
        f.attrs["status"] = "aborted"
        f.attrs["abort_reason"] = "aborted: test"


def test_export_never_passes_a_cut_off_point_as_complete(lab, tmp_path):
    _cut_off(tmp_path)
    before = snapshot(lab, tmp_path)
    code, out, err = run_cli(["export", "uff", str(tmp_path / "cut.h5"), str(tmp_path / "c.uff"), "--json"])
    check_case(code, err, 0, before, lab, tmp_path)
    doc = _strict_json(out)
    assert doc["skipped_incomplete_points"] == [1]
    import pyuff

    names = [s["id1"] for s in pyuff.UFF(str(tmp_path / "c.uff")).read_sets() if s["type"] == 58]
    assert names and all(n.startswith("point 0000") for n in names)


def test_json_helper_writes_nulls_with_a_note():
    from rigtools.json_values import dumps

    doc = _strict_json(dumps({"a": [1.0, float("nan")], "b": {"c": float("-inf")}, "d": np.float64(2)}))
    assert doc["a"] == [1.0, None] and doc["b"] == {"c": None} and doc["d"] == 2.0
    assert len(doc["json_notes"]) == 2 and "a[1]" in doc["json_notes"][0]


@pytest.mark.parametrize(
    "argv",
    [
        ["compare", "--json", "--skip-damaged", "{lab}/nan.h5", "{lab}/run.h5"],
        ["analyze", "--json", "--skip-damaged", "{lab}/nan.h5"],
        ["info", "--json", "--skip-damaged", "{lab}/nan.h5"],
        ["check", "--json", "{lab}/nan.h5"],
    ],
    ids=["compare", "analyze", "info", "check"],
)
def test_json_output_is_valid_with_nan_samples(argv, lab, tmp_path):
    before = snapshot(lab, tmp_path)
    code, out, err = run_cli(_fill(argv, lab, tmp_path))
    check_case(code, err, (0, 1), before, lab, tmp_path)
    _strict_json(out)


# ------------------------- items 8, 9, 10: plausibility, options before the first sample, mistakes
_DW = ["acquire", "dwell", "--backend", "sim", "--out", "{tmp}/a.h5"]
_TAP = ["acquire", "tap", "--backend", "sim", "--position", "85 mm", "--out", "{tmp}/t.h5"]
_FRF = [
    "acquire",
    "frf",
    "--backend",
    "sim",
    "--band",
    "20 Hz:500 Hz",
    "--level",
    "0.5 V",
    "--out",
    "{tmp}/f.h5",
]
LONG = "{tmp}/" + "x" * 300
OPTION_CASES = [
    Case(
        "sweep:frequencies-above-nyquist",
        ["acquire", "sweep", "--backend", "sim", "--force", "15 N", "--frequencies", "20 kHz,30 kHz"]
        + ["--out", "{tmp}/s.h5"],
        expect="--frequencies",
    ),
    Case("dwell:fe-above-nyquist", [*_DW, "--fe", "24 kHz", "--force", "15 N"], expect="--fe"),
    Case(
        "astudy:values-above-nyquist",
        ["acquire", "study", "frequency", "--backend", "sim", "--values", "60 Hz,30 kHz", "--force", "15 N"]
        + ["--gap", "0.5 mm", "--yes", "--out", "{tmp}/s.h5"],
        expect="--values",
    ),
    Case("frf:band-above-nyquist", [*_FRF[:5], "20 Hz:40 kHz", *_FRF[6:]], expect="--band"),
    Case("frf:frame-1us", [*_FRF, "--frame", "1 us"], expect="--frame"),
    Case("tap:frame-1us", [*_TAP, "--frame", "1 us"], expect="--frame"),
    Case("tap:hits-1", [*_TAP, "--hits", "1"], expect="--hits"),
    Case("tap:hits-0", [*_TAP, "--hits", "0"], expect="--hits"),
    Case("tap:f-max-40kHz", [*_TAP, "--f-max", "40 kHz"], expect="--f-max"),
    Case("tap:f-max-0", [*_TAP, "--f-max", "0 Hz"], expect="--f-max"),
    Case("dwell:force-unreachable", [*_DW, "--fe", "60 Hz", "--force", "1 kN"], code=5, expect="reached"),
    Case(
        "study:scheduler-not-an-address",
        ["study", "gap", "--values", "0.5 mm", "--scheduler", "nope"] + ["--out", "{tmp}/s.h5"],
        expect="--scheduler",
    ),
    Case(
        "study:scheduler-no-scheme",
        ["study", "gap", "--values", "0.5 mm", "--scheduler", "10.0.0.5:8786"] + ["--out", "{tmp}/s.h5"],
        expect="--scheduler",
    ),
    Case(
        "export:frame-samples-0",
        ["export", "uff", "{lab}/run.h5", "{tmp}/o.uff", "--excitation", "random", "--frame-samples", "0"],
        expect="--frame-samples",
    ),
    Case(
        "simulate:steps-per-period-120",
        ["simulate", "--steps-per-period", "120", "--out", "{tmp}/s.h5"],
        expect="--steps-per-period",
    ),
    Case(
        "simulate:force-1MN",
        ["simulate", "--force", "1 MN", "--out", "{tmp}/s.h5", "--no-plot"],
        expect="--force",
    ),
    Case("info:empty-path", ["info", ""], expect="file"),
    Case("check:empty-path", ["check", ""], expect="file"),
    Case("analyze:empty-path", ["analyze", ""], expect="file"),
    Case("export:empty-input", ["export", "uff", "", "{tmp}/o.uff"], expect="file"),
    Case("info:long-name", ["info", LONG + ".h5"]),
    Case("check:long-name", ["check", LONG + ".h5"]),
    Case("modal:long-rig-name", ["modal", "--rig", LONG + ".toml"]),
]


def _tiny_damping(tmp: Path) -> None:
    text = default_rig_text()
    import tomllib

    import tomli_w

    data = tomllib.loads(text)
    data["damping"] = {"ratio": 1e-9}
    (tmp / "rig.toml").write_text(tomli_w.dumps(data), encoding="utf-8")


OPTION_CASES += [
    Case(
        "harmonic:tiny-damping-flagged",
        ["harmonic", "--rig", "{tmp}/rig.toml", "--points", "400", "--out", "{tmp}/h.csv"],
        code=0,
        setup=_tiny_damping,
        expect="not physical",
    ),
    Case(
        "harmonic:plausible-not-flagged",
        ["harmonic", "--points", "5", "--out", "{tmp}/h.csv"],
        code=0,
    ),
]


@pytest.mark.parametrize("case", _param(OPTION_CASES))
def test_options_and_mistakes(case, lab, tmp_path):
    run(case, lab, tmp_path)
    assert not (tmp_path / "s.h5").exists() or case.code == 5  # refused before the first sample


_SW = ["acquire", "sweep", "--backend", "sim", "--periods", "5", "--out", "{tmp}/a.h5"]
_ST = ["acquire", "study", "force", "--backend", "sim", "--periods", "5", "--out", "{tmp}/a.h5"]


@pytest.mark.parametrize(
    ("argv", "points"),
    [
        ([*_DW, "--fe", "60 Hz", "--force", "1 kN"], 1),
        ([*_SW, "--frequencies", "58 Hz,60 Hz,62 Hz", "--force", "1 kN"], 1),  # stops at the first step
        ([*_ST, "--fe", "60 Hz", "--values", "10 N,1 kN,2 kN"], 2),  # the reached point is kept
    ],
    ids=["dwell", "sweep", "study"],
)
def test_an_unreachable_force_ends_failed_with_its_reason(argv, points, lab, tmp_path):
    """The dwell's rule for every force-controlled procedure: exit 5, status failed with the
    reason, the run stops at the first point the rig's limits stop short, every point written
    kept, the drive at zero at the end of the last one."""
    code, _, err = run_cli(_fill(argv, lab, tmp_path))
    assert code == 5, err
    assert len(err.strip().splitlines()) == 1 and "cannot be reached" in err and "Traceback" not in err
    from rigtools.recording import open_recording

    with open_recording(tmp_path / "a.h5") as rec:
        assert rec.attrs["end_status"] == "failed" and "cannot be reached" in rec.attrs["end_reason"]
        assert len(rec.points) == points
        assert all(bool(p.params["point_complete"]) for p in rec.points)
        assert [bool(p.params["settled"]) for p in rec.points] == [True] * (points - 1) + [False]
        drive = rec.points[-1].channels["drive"].read()
        assert drive[-1] == 0.0
    assert check_recording(tmp_path / "a.h5").valid


@pytest.mark.parametrize("procedure", ["dwell", "sweep", "study"])
def test_the_unreachable_force_status_is_documented(procedure):
    code, out, _ = run_cli(["acquire", procedure, "--help"])
    assert code == 0 and "5 the force target cannot be" in " ".join(out.split())


# ---------------------------------------------------------------- item 10: the output streams
RIG = [sys.executable, "-m", "rigtools.cli"]


def _env(**extra: str) -> dict[str, str]:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", COLUMNS="100")
    env.update(extra)
    return env


@pytest.mark.parametrize(
    "argv",
    [["modal", "--modes", "3"], ["info", "{lab}/run.h5"], ["info", "--json", "{lab}/run.h5"]],
    ids=["modal", "info", "info-json"],
)
def test_closed_stdout(argv, lab, tmp_path):
    """``rig modal >&-``: quietly (status 0 or 141), never a traceback."""
    before = snapshot(lab)
    proc = subprocess.run(  # noqa: PLW1510 - the status is what the test asserts
        [*RIG, *_fill(argv, lab, tmp_path)],
        stdout=subprocess.DEVNULL,
        stdin=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
        timeout=120,
        close_fds=True,
        preexec_fn=lambda: os.close(1),
    )
    check_case(proc.returncode, proc.stderr, (0, 120, 141), before, lab)


@needs_root
@pytest.mark.parametrize("argv", [["modal", "--modes", "3"], ["info", "{lab}/run.h5"]], ids=["modal", "info"])
def test_stdout_on_a_full_device(argv, lab, tmp_path):
    """``> /dev/full`` (a private copy, char device 1,7): one line, non-zero, no traceback."""
    _device("full", 7)(tmp_path)
    before = snapshot(lab, tmp_path)
    with open(tmp_path / "full", "w") as full:
        proc = subprocess.run(  # noqa: PLW1510 - the status is what the test asserts
            [*RIG, *_fill(argv, lab, tmp_path)],
            stdout=full,
            stderr=subprocess.PIPE,
            stdin=subprocess.DEVNULL,
            text=True,
            env=_env(),
            timeout=120,
        )
    check_case(proc.returncode, proc.stderr, (4, 141), before, lab, tmp_path)


@pytest.mark.parametrize(
    "argv, code",
    [(["info", "{lab}/run.h5"], 0), (["modal", "--modes", "3"], 0), (["simulate", "--gap", "0.5 µm"], 2)],
    ids=["info", "modal", "micro-sign"],
)
def test_plain_c_locale_without_coercion(argv, code, lab, tmp_path):
    env = _env(LANG="C", LC_ALL="C", PYTHONCOERCECLOCALE="0", PYTHONUTF8="0")
    env.pop("PYTHONIOENCODING", None)
    before = snapshot(lab)
    proc = subprocess.run(  # noqa: PLW1510 - the status is what the test asserts
        [*RIG, *_fill(argv, lab, tmp_path)],
        capture_output=True,
        env=env,
        timeout=120,
        cwd=tmp_path,
        stdin=subprocess.DEVNULL,
    )
    err = proc.stderr.decode("ascii", "replace")
    check_case(proc.returncode, err, code, before, lab)
    assert proc.stdout.isascii() and proc.stderr.isascii()
