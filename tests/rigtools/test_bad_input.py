"""The careless lab user (issue 8): bad rig files, bad option values, damaged recordings, bad output
paths, two writers on one file, signals, a closed pipe and an ASCII-only console, tried on every
``rig`` command.

Every case asserts the exit status, at most two lines on stderr, no traceback, and that no
existing recording changed: a real recording and a rig file, made once per module in ``lab``,
are hashed (sha256) before and after each case. Cases run ``rigtools.cli.main`` in-process (fast);
only signals, the closed pipe, the console encoding and the concurrent writer use subprocesses.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np
import pytest
import tomli_w
from cli_helpers import acquire_dwell

from rigtools.cli import main
from rigtools.config import default_rig_text
from rigtools.recording import ChannelSpec, RecordingWriter, check_recording, open_recording

RATE = 2000.0
CHANNELS = [
    ChannelSpec("force", "N", "force", RATE),
    ChannelSpec("active_shroud_accel", "m/s^2", "acceleration", RATE),
    ChannelSpec("passive_shroud_accel", "m/s^2", "acceleration", RATE),
    ChannelSpec("drive", "V", "voltage", RATE),
]
RIG = ["--rig"]


# ----------------------------------------------------------------------------------- harness
def _write_recording(path: Path, *, nan: bool = False) -> Path:
    """A small real recording: two points of 60 Hz sines on four channels, written by the writer."""
    t = np.arange(int(RATE)) / RATE
    with RecordingWriter(
        path, backend="simulated", rig=default_rig_text(), experiment={"procedure": "sine dwell"}
    ) as rec:
        for k, fe in enumerate((60.0, 61.0)):
            block = np.vstack(
                [
                    15 * np.sin(2 * np.pi * fe * t),
                    80 * np.sin(2 * np.pi * fe * t + 1),
                    100 * np.sin(2 * np.pi * fe * t + 2),
                    np.sin(2 * np.pi * fe * t),
                ]
            )
            if nan and k == 1:
                block[1, 100:104] = np.nan
            point = rec.begin_point({"fe": fe, "force_amplitude": 15.0}, CHANNELS)
            point.append(block)
            point.set_attrs(settled=True)
            point.end()
    return path


def _digest(folder: Path) -> dict[str, str]:
    return {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.iterdir())
        if p.is_file() and not p.name.startswith(".")
    }


@pytest.fixture(scope="module")
def lab(tmp_path_factory) -> Path:
    """A folder with a real recording ``run.h5``, a copy named ``run.png`` (a recording whose
    name ends in .png), one with NaN samples, and a valid rig file ``rig.toml``."""
    folder = tmp_path_factory.mktemp("lab")
    _write_recording(folder / "run.h5")
    _write_recording(folder / "run.png")
    _write_recording(folder / "nan.h5", nan=True)
    (folder / "rig.toml").write_text(default_rig_text(), encoding="utf-8")
    _write_tdms(folder / "in.tdms")
    return folder


def _write_tdms(path: Path) -> None:
    """A small NI TDMS log: one group, a force and an acceleration channel with units and timing."""
    from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

    rng = np.random.default_rng(3)
    props = lambda unit: {"unit_string": unit, "wf_increment": 1 / RATE, "wf_start_offset": 0.0}
    with TdmsWriter(str(path)) as w:
        w.write_segment(
            [
                RootObject({"name": "log"}),
                GroupObject("Task"),
                ChannelObject("Task", "Dev1/ai0", rng.standard_normal(500), properties=props("Newtons")),
                ChannelObject("Task", "Dev1/ai1", rng.standard_normal(500), properties=props("g")),
            ]
        )


@pytest.fixture(scope="module")
def lab_digest(lab) -> dict[str, str]:
    return _digest(lab)


def run_cli(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:  # --help and argparse's own exits
            code = exc.code if isinstance(exc.code, int) else 0
    return code, out.getvalue(), err.getvalue()


def assert_clean_failure(code: int, err: str, expected: int, lab: Path, digest: dict) -> None:
    lines = [line for line in err.splitlines() if line.strip()]
    assert "Traceback" not in err
    assert code == expected, err
    assert len(lines) <= 2, err
    if expected not in (0, 1):
        assert lines and "error" in lines[0] or any("interrupt" in x for x in lines), err
    now = _digest(lab)  # files a case adds beside them are allowed (derived files)
    assert {name: now.get(name) for name in digest} == digest, "an existing recording or rig file changed"


@dataclass
class Case:
    """``argv`` with ``{lab}`` (the shared folder), ``{tmp}`` (this case's folder) and ``{rig}``
    (a rig file ``setup`` wrote, default ``{lab}/rig.toml``) filled in."""

    id: str
    argv: list[str]
    code: int = 2
    setup: Callable[[Path], None] | None = None
    expect: str | None = None  # text the stderr line must contain
    marks: list = field(default_factory=list)


def _fill(argv: list[str], lab: Path, tmp: Path) -> list[str]:
    rig = tmp / "rig.toml" if (tmp / "rig.toml").exists() else lab / "rig.toml"
    return [a.format(lab=lab, tmp=tmp, rig=rig) for a in argv]


def _param(cases: list[Case]):
    return [pytest.param(c, id=c.id, marks=c.marks) for c in cases]


def run_case(case: Case, lab: Path, digest: dict, tmp: Path) -> str:
    if case.setup:
        case.setup(tmp)
    code, _, err = run_cli(_fill(case.argv, lab, tmp))
    assert_clean_failure(code, err, case.code, lab, digest)
    if case.expect:
        assert case.expect.format(lab=lab, tmp=tmp) in err, err
    return err


# ------------------------------------------------------------------------------- rig files
def _rig_with(change: Callable[[dict], None]) -> Callable[[Path], None]:
    def setup(tmp: Path) -> None:
        data = tomllib.loads(default_rig_text())
        change(data)
        (tmp / "rig.toml").write_text(tomli_w.dumps(data), encoding="utf-8")

    return setup


def _set(section: str, key: str, value) -> Callable[[Path], None]:
    def change(data: dict) -> None:
        node = data
        parts = section.split(".")
        for part in parts:
            node = node.setdefault(part, {})
        node[key] = value

    return _rig_with(change)


def _raw_rig(data: bytes | Callable[[], bytes]) -> Callable[[Path], None]:
    def setup(tmp: Path) -> None:
        (tmp / "rig.toml").write_bytes(data() if callable(data) else data)

    return setup


def _replace_in_rig(old: str, new: str) -> Callable[[Path], None]:
    def setup(tmp: Path) -> None:
        text = default_rig_text()
        assert old in text
        (tmp / "rig.toml").write_text(text.replace(old, new, 1), encoding="utf-8")

    return setup


BAD_VALUES = [
    ("blade", "length", -0.1),
    ("blade", "length", "0.5 MM"),
    ("blade", "length", "1e400 m"),
    ("blade", "width", 0),
    ("blade", "thickness", "2 kg"),
    ("blade", "elements", 1),
    ("blade", "elements", 10**7),
    ("blade", "youngs_modulus", "200 gpa"),
    ("blade", "youngs_modulus", "200 mPa"),
    ("blade", "density", 1e9),
    ("blade", "poisson", 0.7),
    ("blade", "theory", "bernoulli"),
    ("blade", "colour", "blue"),
    ("passive_blade", "length", 100.0),
    ("passive_blade", "thickness", -1e-3),
    ("passive_blade", "elements", 0),
    ("passive_blade", "youngs_modulus", "1e400 Pa"),
    ("passive_blade", "density", "nan"),
    ("passive_blade", "poisson", -0.1),
    ("passive_blade", "mass", "1 kg"),
    ("root", "kind", "welded"),
    ("root", "rotational_stiffness", "1e18 N*m/rad"),
    ("root", "translational_stiffness", 1e24),
    ("root", "rotational_stiffness", -5.0),
    ("shroud", "mass", 0),
    ("shroud", "mass", "1e400 g"),
    ("shroud", "rotary_inertia", -1.0),
    ("contact", "gap", 0.5),
    ("contact", "gap", "-0.1 mm"),
    ("contact", "gap", "0.5 MM"),
    ("contact", "stiffness", 0),
    ("contact", "stiffness", "1e13 N/m"),
    ("contact", "damping", "1e5 N*s/m"),
    ("contact", "law", "elastic"),
    ("damping", "alpha", float("inf")),
    ("damping", "alpha", -1.0),
    ("damping", "beta", 1.0),
    ("damping", "ratio", 1.5),
    ("force_sensor", "position", "2 m"),
    ("force_sensor", "mass", "-3 g"),
]


def _value_id(section, key, value) -> str:
    return f"{section}.{key}={value!r}"[:60].replace(" ", "_")


RIG_FILE_CASES = [
    Case(f"rig:{_value_id(s, k, v)}", ["modal", "--rig", "{rig}"], setup=_set(s, k, v))
    for s, k, v in BAD_VALUES
] + [
    # root springs so soft the blade is almost free: the FEM reduction failed with a LinAlgError
    Case(
        "rig:root-springs-soft-rotation",
        ["simulate", "--rig", "{rig}", "--out", "{tmp}/s.h5"],
        expect="root",
        setup=_rig_with(
            lambda d: d["root"].update(kind="springs", rotational_stiffness=1e-4, translational_stiffness=1e3)
        ),
    ),
    Case(
        "rig:root-springs-soft-translation",
        ["simulate", "--rig", "{rig}", "--out", "{tmp}/s.h5"],
        expect="root",
        setup=_rig_with(
            lambda d: d["root"].update(
                kind="springs", rotational_stiffness=1e7, translational_stiffness="1 N/m"
            )
        ),
    ),
    Case(
        "rig:root-springs-free",
        ["harmonic", "--rig", "{rig}", "--out", "{tmp}/h.csv"],
        expect="root",
        setup=_rig_with(
            lambda d: d["root"].update(
                kind="springs", rotational_stiffness="1e-12 N*m/rad", translational_stiffness=1e-9
            )
        ),
    ),
    # a Hertz law's stiffness is in N/m^1.5 (the rig file's own comment): a linear unit is refused
    Case(
        "rig:hertz-with-linear-unit",
        ["modal", "--rig", "{rig}"],
        expect="hertz stiffness",
        setup=_rig_with(lambda d: d["contact"].update(law="hertz", stiffness="1e6 N/m")),
    ),
    Case(
        "rig:linear-with-hertz-unit",
        ["modal", "--rig", "{rig}"],
        expect="hertz stiffness",
        setup=_rig_with(lambda d: d["contact"].update(law="linear", stiffness="1e9 N/m^1.5")),
    ),
    Case("rig:unknown-section", ["modal", "--rig", "{rig}"], setup=_set("blades", "length", 0.1)),
    Case(
        "rig:inf-literal",
        ["modal", "--rig", "{rig}"],
        expect="contact.stiffness",
        setup=_replace_in_rig('stiffness = "1e6 N/m"', "stiffness = inf"),
    ),
    Case(
        "rig:1e400-literal",
        ["modal", "--rig", "{rig}"],
        expect="contact.gap",
        setup=_replace_in_rig('gap = "0.5 mm"', "gap = 1e400"),
    ),
    Case(
        "rig:nan-literal",
        ["modal", "--rig", "{rig}"],
        expect="contact.damping",
        setup=_replace_in_rig('damping = "200 N*s/m"', "damping = nan"),
    ),
    Case(
        "rig:latin-1",
        ["modal", "--rig", "{rig}"],
        setup=_raw_rig(lambda: ("# réglage du banc\n" + default_rig_text()).encode("latin-1", "replace")),
        expect="not UTF-8",
    ),
    Case(
        "rig:utf-16",
        ["modal", "--rig", "{rig}"],
        setup=_raw_rig(lambda: default_rig_text().encode("utf-16")),
        expect="UTF-16",
    ),
    Case(
        "rig:bom",
        ["modal", "--rig", "{rig}"],
        setup=_raw_rig(lambda: b"\xef\xbb\xbf" + default_rig_text().encode()),
        expect="BOM",
    ),
    Case("rig:empty", ["modal", "--rig", "{rig}"], setup=_raw_rig(b""), expect="empty"),
    Case("rig:not-toml", ["modal", "--rig", "{rig}"], setup=_raw_rig(b"blade = [[[\n")),
    Case("rig:binary", ["modal", "--rig", "{rig}"], setup=_raw_rig(bytes(range(256)) * 4)),
    Case("rig:a-recording", ["modal", "--rig", "{lab}/run.h5"], expect="HDF5"),
    Case("rig:a-directory", ["modal", "--rig", "{lab}"], expect="directory"),
    Case("rig:missing", ["modal", "--rig", "{tmp}/nope.toml"]),
    Case("rig:simulate-recording-as-rig", ["simulate", "--rig", "{lab}/run.h5", "--out", "{tmp}/s.h5"]),
    Case(
        "rig:harmonic-bad-rig",
        ["harmonic", "--rig", "{rig}", "--out", "{tmp}/h.csv"],
        setup=_set("contact", "gap", 0.5),
    ),
    Case(
        "rig:study-bad-rig",
        ["study", "gap", "--values", "0.5 mm", "--rig", "{rig}", "--out", "{tmp}/s.h5"],
        setup=_set("damping", "alpha", float("nan")),
    ),
    Case(
        "rig:acquire-bad-rig",
        [
            "acquire",
            "dwell",
            "--backend",
            "sim",
            "--fe",
            "60 Hz",
            "--force",
            "15 N",
            "--rig",
            "{rig}",
            "--out",
            "{tmp}/a.h5",
        ],
        setup=_set("passive_blade", "youngs_modulus", "-1 GPa"),
    ),
    Case(
        "rig:import-bad-rig",
        ["import", "tdms", "{lab}/in.tdms", "{tmp}/o.h5", "--rig", "{rig}"],
        setup=_set("blade", "length", "1e400 m"),
    ),
]


@pytest.mark.parametrize("case", _param(RIG_FILE_CASES))
def test_rig_file(case, lab, lab_digest, tmp_path):
    run_case(case, lab, lab_digest, tmp_path)


# ----------------------------------------------------------------------------- option values
def _sim(*extra: str) -> list[str]:
    return ["simulate", *extra, "--out", "{tmp}/s.h5", "--no-plot"]


def _study(*extra: str) -> list[str]:
    return ["study", *extra, "--out", "{tmp}/s.h5"]


def _harm(*extra: str) -> list[str]:
    return ["harmonic", *extra, "--out", "{tmp}/h.csv"]


_DWELL = ["acquire", "dwell", "--backend", "sim", "--out", "{tmp}/a.h5"]
_CBC = [
    "acquire",
    "cbc",
    "--backend",
    "sim",
    "--fe",
    "64 Hz",
    "--amplitude",
    "0.32 mm",
    "--out",
    "{tmp}/c.h5",
]
_PLL = ["acquire", "pll", "--backend", "sim", "--force", "0.2 N", "--out", "{tmp}/p.h5"]


def _dwell(fe="60 Hz", force="15 N", *extra: str) -> list[str]:
    return [*_DWELL, "--fe", fe, "--force", force, *extra]


OPTION_CASES = [
    # rig simulate
    Case("simulate:gap-plain-0.5", _sim("--gap", "0.5"), expect="mm"),
    Case("simulate:gap-negative", _sim("--gap", "-0.5 mm")),
    Case("simulate:gap-MM", _sim("--gap", "0.5 MM")),
    Case("simulate:gap-inf", _sim("--gap", "inf")),
    Case("simulate:gap-nan", _sim("--gap", "nan mm")),
    Case("simulate:gap-kg", _sim("--gap", "0.5 kg")),
    Case("simulate:fe-zero", _sim("--fe", "0 Hz")),
    Case("simulate:fe-negative", _sim("--fe", "-60 Hz")),
    Case("simulate:fe-1e400", _sim("--fe", "1e400")),
    Case("simulate:fe-MHz", _sim("--fe", "60 MHz")),
    Case("simulate:fe-wrong-case", _sim("--fe", "60 hz")),
    Case("simulate:force-text", _sim("--force", "fifteen N")),
    Case("simulate:force-negative", _sim("--force", "-15 N")),
    Case("simulate:force-volts", _sim("--force", "15 V")),
    Case("simulate:force-huge", _sim("--force", "1e9 N")),
    Case("simulate:duration-zero", _sim("--duration", "0 s")),
    Case("simulate:duration-negative", _sim("--duration", "-1 s")),
    Case("simulate:duration-memory", _sim("--duration", "1e7 h")),
    Case("simulate:duration-hz", _sim("--duration", "1 Hz")),
    Case("simulate:max-settle-nan", _sim("--max-settle", "nan")),
    Case("simulate:steps-zero", _sim("--steps-per-period", "0")),
    Case("simulate:steps-negative", _sim("--steps-per-period", "-100")),
    Case("simulate:steps-huge", _sim("--steps-per-period", "999999999999")),
    Case("simulate:steps-float", _sim("--steps-per-period", "1.5")),
    Case("simulate:model-unknown", _sim("--model", "xfem")),
    Case("simulate:unknown-option", _sim("--gapp", "0.5 mm")),
    # rig study
    Case("study:values-empty", _study("gap", "--values", "")),
    Case("study:values-plain-gap", _study("gap", "--values", "0.5,0.6")),
    Case("study:values-nan", _study("force", "--values", "nan N,15 N")),
    Case("study:values-negative-force", _study("force", "--values", "-5 N:15 N:5 N")),
    Case("study:values-zero-step", _study("frequency", "--values", "50 Hz:70 Hz:0 Hz")),
    Case("study:values-too-many", _study("frequency", "--values", "1 Hz:1000 Hz:0.0001 Hz")),
    Case("study:values-wrong-units", _study("frequency", "--values", "1 N,2 N")),
    Case("study:fe-inf", _study("gap", "--values", "0.5 mm", "--fe", "inf Hz")),
    Case("study:kind-unknown", _study("stiffness", "--values", "1,2")),
    Case("study:direction-unknown", _study("gap", "--values", "0.5 mm", "--direction", "sideways")),
    # rig harmonic
    Case("harmonic:force-zero", _harm("--force", "0 N")),
    Case("harmonic:fmin-above-fmax", _harm("--fmin", "500 Hz", "--fmax", "100 Hz")),
    Case("harmonic:fmin-negative", _harm("--fmin", "-10 Hz")),
    Case("harmonic:fmax-inf", _harm("--fmax", "inf")),
    Case("harmonic:points-zero", _harm("--points", "0")),
    Case("harmonic:points-huge", _harm("--points", "100000000000")),
    Case("harmonic:points-text", _harm("--points", "many")),
    Case("harmonic:fmax-mm", _harm("--fmax", "5 mm")),
    # rig modal
    Case("modal:modes-zero", ["modal", "--modes", "0"]),
    Case("modal:modes-negative", ["modal", "--modes", "-3"]),
    Case("modal:modes-huge", ["modal", "--modes", "100000000"]),
    Case("modal:modes-text", ["modal", "--modes", "eight"]),
    # rig acquire dwell/sweep/study/frf --backend sim
    Case("dwell:fe-zero", _dwell("0 Hz")),
    Case("dwell:fe-nan", _dwell("nan")),
    Case("dwell:force-negative", _dwell("60 Hz", "-15 N")),
    Case("dwell:force-volts", _dwell("60 Hz", "15 V")),
    Case("dwell:gap-plain", _dwell("60 Hz", "15 N", "--gap", "0.5")),
    Case("dwell:seed-negative", _dwell("60 Hz", "15 N", "--seed", "-1")),
    Case("dwell:seed-huge", _dwell("60 Hz", "15 N", "--seed", str(2**70))),
    Case("dwell:periods-zero", _dwell("60 Hz", "15 N", "--periods", "0")),
    Case("dwell:periods-memory", _dwell("60 Hz", "15 N", "--periods", "10000000000000")),
    Case("dwell:max-updates-negative", _dwell("60 Hz", "15 N", "--max-updates", "-1")),
    Case("dwell:fault-unknown", _dwell("60 Hz", "15 N", "--fault", "meltdown@1")),
    Case(
        "dwell:fault-nidaq",
        [
            "acquire",
            "dwell",
            "--fe",
            "60 Hz",
            "--force",
            "15 N",
            "--fault",
            "overload@0.5",
            "--out",
            "{tmp}/a.h5",
        ],
    ),
    Case(
        "sweep:frequencies-bad",
        [
            "acquire",
            "sweep",
            "--backend",
            "sim",
            "--force",
            "15 N",
            "--frequencies",
            "340:380",
            "--out",
            "{tmp}/a.h5",
        ],
    ),
    Case(
        "sweep:too-many-points",
        [
            "acquire",
            "sweep",
            "--backend",
            "sim",
            "--force",
            "15 N",
            "--frequencies",
            "10 Hz:1000 Hz:0.00001 Hz",
            "--out",
            "{tmp}/a.h5",
        ],
    ),
    Case(
        "sweep:jump-threshold-nan",
        [
            "acquire",
            "sweep",
            "--backend",
            "sim",
            "--force",
            "15 N",
            "--frequencies",
            "50 Hz:60 Hz:5 Hz",
            "--jump-threshold",
            "nan",
            "--out",
            "{tmp}/a.h5",
        ],
    ),
    Case(
        "astudy:values-plain-gap",
        [
            "acquire",
            "study",
            "gap",
            "--backend",
            "sim",
            "--values",
            "0.4,0.5",
            "--fe",
            "60 Hz",
            "--force",
            "15 N",
            "--out",
            "{tmp}/a.h5",
        ],
    ),
    Case(
        "frf:band-reversed",
        [
            "acquire",
            "frf",
            "--backend",
            "sim",
            "--band",
            "500 Hz:20 Hz",
            "--level",
            "0.3 V",
            "--out",
            "{tmp}/a.h5",
        ],
    ),
    Case(
        "frf:level-vpp-negative",
        [
            "acquire",
            "frf",
            "--backend",
            "sim",
            "--band",
            "20 Hz:500 Hz",
            "--level",
            "-1 Vpp",
            "--out",
            "{tmp}/a.h5",
        ],
    ),
    Case(
        "frf:level-newton",
        [
            "acquire",
            "frf",
            "--backend",
            "sim",
            "--band",
            "20 Hz:500 Hz",
            "--level",
            "0.3 N",
            "--out",
            "{tmp}/a.h5",
        ],
    ),
    Case(
        "frf:frame-memory",
        [
            "acquire",
            "frf",
            "--backend",
            "sim",
            "--band",
            "20 Hz:500 Hz",
            "--level",
            "0.3 V",
            "--frame",
            "1e6 h",
            "--out",
            "{tmp}/a.h5",
        ],
    ),
    Case(
        "frf:averages-zero",
        [
            "acquire",
            "frf",
            "--backend",
            "sim",
            "--band",
            "20 Hz:500 Hz",
            "--level",
            "0.3 V",
            "--averages",
            "0",
            "--out",
            "{tmp}/a.h5",
        ],
    ),
    Case("acquire:no-procedure", ["acquire"]),
    # the line names the command's option, not the Python parameter behind it
    Case(
        "dwell:force-negative",
        [*_DWELL, "--fe", "60 Hz", "--force", "-5 N"],
        expect="--force = -5.0: outside",
    ),
    Case(
        "dwell:periods-zero",
        [*_DWELL, "--fe", "60 Hz", "--force", "1 N", "--periods", "0"],
        expect="--periods = 0",
    ),
    *(
        Case(f"cbc:{cid}", [*_CBC, *extra], expect=expect)
        for cid, extra, expect in [
            ("gains-negative", ["--gains=-5,0"], "--gains = '-5,0': gains are >= 0"),
            ("kd-negative", ["--gains", "2000,-3"], "--gains = '2000,-3': gains are >= 0"),
            ("iterations-zero", ["--max-iterations", "0"], "--max-iterations = 0: outside"),
            ("release-long", ["--release", "100 s"], "--release = 100.0: outside"),
            # was two lines: the NI backend's note on the buffered loop, then the error
            ("pace-nidaq", ["--backend", "nidaq", "--pace"], "--pace: for the simulated rig only"),
            # a plain 0.32 is 0.32 m: it was walked to in 5 um steps (minutes) until lost
            (
                "amplitude-metres",
                ["--amplitude", "0.32"],
                "--amplitude = [0.32]: a target must be at most 50 mm",
            ),
        ]
    ),
    *(
        Case(f"pll:{cid}", [*_PLL, *extra], expect=expect)
        for cid, extra, expect in [
            ("max-below-lock", ["--max-periods", "10"], "--max-periods 10 is below --lock-periods 20"),
            (
                "start-outside",
                ["--fe-start", "30 Hz", "--f-min", "40 Hz"],
                "--fe-start 30 Hz must lie inside",
            ),
            ("kp-large", ["--kp", "5"], "--kp = 5.0: outside"),
            ("phase-positive", ["--phase", "200 deg"], "--phase = 200 deg: use -180 < phase < 0"),
            ("seed-nidaq", ["--backend", "nidaq", "--seed", "3"], "--seed: for the simulated rig only"),
        ]
    ),
    # rig export / import / devices
    Case("export:what-unknown", ["export", "uff", "{lab}/run.h5", "{tmp}/o.uff", "--what", "movies"]),
    Case(
        "export:frame-samples-three",
        ["export", "uff", "{lab}/run.h5", "{tmp}/o.uff", "--excitation", "random", "--frame-samples", "3"],
        expect="--frame-samples = 3: an FRF frame needs at least 64 samples (N samples give N/2 + 1 lines",
    ),
    Case(
        "export:frame-samples-text",
        ["export", "uff", "{lab}/run.h5", "{tmp}/o.uff", "--frame-samples", "1 s"],
        expect="expected a whole number",
    ),
    # FRF options that would not change anything: a sine-dwell recording has no broadband point
    Case(
        "export:excitation-without-broadband",
        ["export", "uff", "{lab}/run.h5", "{tmp}/o.uff", "--excitation", "random", "--frame-samples", "256"],
        expect="--excitation and --frame-samples: {lab}/run.h5 holds no broadband point to estimate",
    ),
    Case(
        "export:excitation-what-time",
        ["export", "uff", "{lab}/run.h5", "{tmp}/o.uff", "--what", "time", "--excitation", "burst"],
        expect="--excitation: --what time writes no FRF, so it would be ignored",
    ),
    Case(
        "analyze:excitation-without-broadband",
        ["analyze", "{lab}/run.h5", "--excitation", "random", "--band", "10 Hz:100 Hz"],
        expect="--excitation and --band: {lab}/run.h5 holds no broadband point",
    ),
    Case(
        "analyze:band-reversed",
        ["analyze", "{lab}/run.h5", "--band", "4 kHz:100 Hz"],
        expect="--band = '4 kHz:100 Hz': need 0 <= LOW < HIGH",
    ),
    Case("analyze:band-one-value", ["analyze", "{lab}/run.h5", "--band", "4 kHz"], expect="write LOW:HIGH"),
    Case(
        "analyze:force-window-over-one",
        ["analyze", "{lab}/run.h5", "--force-window", "2"],
        expect="--force-window = '2': must be in (0, 1]",
    ),
    Case("analyze:fe-zero", ["analyze", "{lab}/run.h5", "--fe", "0 Hz"], expect="--fe = '0 Hz': must be > 0"),
    Case("export:format-unknown", ["export", "csv", "{lab}/run.h5", "{tmp}/o.csv"]),
    Case(
        "import:sample-rate-negative",
        ["import", "tdms", "{lab}/in.tdms", "{tmp}/o.h5", "--sample-rate", "-5 kHz"],
    ),
    Case("import:rename-bad", ["import", "tdms", "{lab}/in.tdms", "{tmp}/o.h5", "--rename", "a==b,c"]),
    Case(
        "import:rename-unknown-channel",
        ["import", "tdms", "{lab}/in.tdms", "{tmp}/o.h5", "--rename", "Dev1/ai9=force"],
        expect="Dev1/ai9",
    ),
    Case(
        "import:rename-unstorable-name",
        ["import", "tdms", "{lab}/in.tdms", "{tmp}/o.h5", "--rename", "Dev1/ai0=a/b"],
    ),
    Case(
        "import:rename-two-to-one",
        ["import", "tdms", "{lab}/in.tdms", "{tmp}/o.h5", "--rename", "Dev1/ai0=x,Dev1/ai1=x"],
    ),
    Case("import:missing-source", ["import", "tdms", "{tmp}/in.tdms", "{tmp}/o.h5"]),
    Case("import:source-is-recording", ["import", "tdms", "{lab}/run.h5", "{tmp}/o.h5"]),
    Case("devices:unknown-option", ["devices", "--colour"]),
    Case("rig:unknown-command", ["fly"]),
]


@pytest.mark.parametrize("case", _param(OPTION_CASES))
def test_option_value(case, lab, lab_digest, tmp_path):
    run_case(case, lab, lab_digest, tmp_path)


# ------------------------------------------------------------------------------- recordings
def _truncated(tmp: Path) -> None:
    data = (LAB_SOURCE / "run.h5").read_bytes()
    (tmp / "r.h5").write_bytes(data[: len(data) // 3])


def _text(tmp: Path) -> None:
    (tmp / "r.h5").write_text("time,force\n0,1\n", encoding="utf-8")


def _empty(tmp: Path) -> None:
    (tmp / "r.h5").write_bytes(b"")


def _foreign(tmp: Path) -> None:
    with h5py.File(tmp / "r.h5", "w") as f:
        f["data"] = np.arange(10.0)
        f.attrs["schema"] = "someone-elses-format"


def _plain_hdf5(tmp: Path) -> None:
    with h5py.File(tmp / "r.h5", "w") as f:
        f["data"] = np.arange(10.0)


def _newer(tmp: Path) -> None:
    (tmp / "r.h5").write_bytes((LAB_SOURCE / "run.h5").read_bytes())
    with h5py.File(tmp / "r.h5", "r+") as f:
        f.attrs["schema_version"] = 99


def _dir(tmp: Path) -> None:
    (tmp / "r.h5").mkdir()


LAB_SOURCE: Path = Path()  # set by the fixture below for the setups


@pytest.fixture(autouse=True)
def _lab_source(lab):
    """Points the setups at the lab; after each case puts the lab back as it was (so one broken
    case cannot make the following ones fail), removing files a case left there."""
    global LAB_SOURCE
    LAB_SOURCE = lab
    pristine = {p.name: p.read_bytes() for p in lab.iterdir() if p.is_file()}
    yield
    for p in lab.iterdir():
        if p.is_file() and p.name not in pristine:
            p.unlink()
    for name, data in pristine.items():
        if not (lab / name).is_file() or (lab / name).read_bytes() != data:
            (lab / name).write_bytes(data)


DAMAGED = {
    "truncated": _truncated,
    "text": _text,
    "empty": _empty,
    "foreign-schema": _foreign,
    "plain-hdf5": _plain_hdf5,
    "newer-schema": _newer,
    "directory": _dir,
}
READERS = {
    "info": ["info", "{tmp}/r.h5"],
    "info-json": ["info", "--json", "{tmp}/r.h5"],
    "check": ["check", "{tmp}/r.h5"],
    "export": ["export", "uff", "{tmp}/r.h5", "{tmp}/o.uff"],
}
RECORDING_CASES = [
    Case(
        f"{reader}:{damage}",
        argv,
        setup=setup,
        # rig check reports a file that is HDF5 but not a recording as invalid (1), documented
        code=1 if reader == "check" and damage in ("foreign-schema", "plain-hdf5") else 2,
    )
    for damage, setup in DAMAGED.items()
    for reader, argv in READERS.items()
] + [
    Case("info:missing", ["info", "{tmp}/none.h5"]),
    Case("check:missing", ["check", "{tmp}/none.h5"]),
    Case("check:nan-samples", ["check", "{lab}/nan.h5"], code=1),
    Case("info:nan-samples", ["info", "{lab}/nan.h5"], code=2),  # the reader contract (issue 30)
    Case("info:nan-samples-skipped", ["info", "--skip-damaged", "{lab}/nan.h5"], code=0),
    Case("info:png-named-recording", ["info", "{lab}/run.png"], code=0),
    Case("check:rig-file", ["check", "{lab}/rig.toml"]),
]


@pytest.mark.parametrize("case", _param(RECORDING_CASES))
def test_damaged_recording(case, lab, lab_digest, tmp_path):
    run_case(case, lab, lab_digest, tmp_path)


# ------------------------------------------------------------------------------ output paths
WRITERS = {
    "simulate": lambda out, *x: ["simulate", "--out", out, "--no-plot", *x],
    "study": lambda out, *x: ["study", "gap", "--values", "0.5 mm", "--out", out, *x],
    "harmonic": lambda out, *x: ["harmonic", "--out", out, *x],
    "dwell": lambda out, *x: [
        "acquire",
        "dwell",
        "--backend",
        "sim",
        "--fe",
        "60 Hz",
        "--force",
        "15 N",
        "--out",
        out,
        *x,
    ],
    "export": lambda out, *x: ["export", "uff", "{lab}/run.h5", out, *x],
    "import": lambda out, *x: ["import", "tdms", "{lab}/in.tdms", out, *x],
}
_SUFFIX = {"harmonic": ".csv", "export": ".uff"}


def _out_cases() -> list[Case]:
    cases = []
    for name, make in WRITERS.items():
        suffix = _SUFFIX.get(name, ".h5")
        cases += [
            Case(f"{name}:out-directory", make("{tmp}")),
            Case(f"{name}:out-trailing-slash", make("{tmp}/new/")),
            Case(f"{name}:out-missing-folder", make("{tmp}/no/such/folder/x" + suffix)),
            Case(f"{name}:out-is-recording", make("{lab}/run.h5")),
        ]
        if name in ("harmonic", "export"):  # derived files: never over a recording
            cases.append(Case(f"{name}:out-is-recording-overwrite", make("{lab}/run.h5", "--overwrite")))
        cases += [
            Case(f"{name}:out-empty", make("")),
            Case(f"{name}:out-under-a-file", make("{lab}/run.h5/x" + suffix)),
        ]
    cases += [
        Case("simulate:out-png-exists", ["simulate", "--out", "{lab}/run.png"]),
        Case("harmonic:out-png", ["harmonic", "--out", "{tmp}/x.png"]),
        Case(
            "harmonic:existing-without-overwrite",
            ["harmonic", "--out", "{tmp}/h.csv"],
            setup=lambda tmp: (tmp / "h.csv").write_text("f,a\n1,2\n"),
        ),
        Case("export:out-is-input", ["export", "uff", "{lab}/run.h5", "{lab}/run.h5", "--overwrite"]),
        Case(
            "import:out-is-rig",
            ["import", "tdms", "{lab}/in.tdms", "{lab}/rig.toml", "--rig", "{lab}/rig.toml", "--overwrite"],
            expect="input",
        ),
        Case(
            "import:out-is-source",
            ["import", "tdms", "{lab}/in.tdms", "{lab}/in.tdms", "--overwrite"],
            expect="input",
        ),
        Case(
            "import:out-existing-recording",
            ["import", "tdms", "{lab}/in.tdms", "{lab}/run.h5"],
            expect="--overwrite",
        ),
    ]
    return cases


@pytest.mark.parametrize("case", _param(_out_cases()))
def test_output_path(case, lab, lab_digest, tmp_path):
    run_case(case, lab, lab_digest, tmp_path)


@pytest.mark.parametrize("name", sorted(WRITERS))
def test_read_only_folder(name, lab, lab_digest, tmp_path, monkeypatch):
    """A read-only folder (as root chmod does not stop writes: os.access says no instead)."""
    real = os.access
    ro = tmp_path / "ro"
    ro.mkdir()
    monkeypatch.setattr(
        os,
        "access",
        lambda p, mode, **kw: (
            False if (mode & os.W_OK and Path(p).resolve() in (ro, ro.resolve())) else real(p, mode, **kw)
        ),
    )
    suffix = _SUFFIX.get(name, ".h5")
    case = Case(f"{name}:read-only", WRITERS[name]("{tmp}/ro/x" + suffix), expect="writable")
    run_case(case, lab, lab_digest, tmp_path)


# ------------------------------------------------------------------ controls (the good inputs)
@pytest.mark.parametrize(
    "argv",
    [
        ["check", "{lab}/run.h5"],
        ["info", "--json", "{lab}/run.png"],
        ["export", "uff", "{lab}/run.h5", "{tmp}/ok.uff"],
        ["import", "tdms", "{lab}/in.tdms", "{tmp}/ok.h5", "--rig", "{lab}/rig.toml"],
    ],
    ids=["check", "info-png-named", "export", "import"],
)
def test_the_lab_files_are_good(argv, lab, lab_digest, tmp_path):
    """The cases above fail for the reason they name: the same commands on good input succeed."""
    code, _, err = run_cli(_fill(argv, lab, tmp_path))
    assert_clean_failure(code, err, 0, lab, lab_digest)


def test_a_plot_never_lands_on_a_recording(lab, lab_digest, tmp_path):
    """``rig harmonic --out run.csv`` beside the recording ``run.png``: the plot takes another name."""
    code, _out, err = run_cli(["harmonic", "--points", "3", "--out", str(lab / "run.csv")])
    assert_clean_failure(code, err, 0, lab, lab_digest)
    assert (lab / "run.plot.png").is_file() and check_recording(lab / "run.png").valid


def test_hertz_units_are_read(lab, lab_digest, tmp_path):
    """``stiffness = "1e9 N/m^1.5"`` with ``law = "hertz"`` is 1e9 SI (was refused as unknown)."""
    from rigtools.config import load_rig

    _rig_with(lambda d: d["contact"].update(law="hertz", stiffness="1e3 N/mm^1.5"))(tmp_path)
    assert load_rig(tmp_path / "rig.toml").contact.stiffness == pytest.approx(1e3 / 1e-3**1.5, rel=1e-12)


def test_a_recording_named_png_survives_a_plot(lab, lab_digest, tmp_path):
    """A recording named run.png (another program's, or an older rigtools') beside run.h5 keeps
    its bytes when rig simulate plots run.h5: the plot takes run.plot.png. rig simulate itself
    names a recording .h5 or .hdf5 only (--out run.png: one line, nothing written)."""
    code, _, err = run_cli(["simulate", "--out", str(tmp_path / "run.png"), "--duration", "0.05 s"])
    assert code == 2 and "the file name must end in .h5 or .hdf5" in err and not any(tmp_path.iterdir())
    shutil.copy(lab / "run.png", tmp_path / "run.png")
    out = tmp_path / "run.h5"
    code, _, err = run_cli(["simulate", "--out", str(out), "--duration", "0.05 s"])
    assert_clean_failure(code, err, 0, lab, lab_digest)
    assert check_recording(out).valid and check_recording(tmp_path / "run.png").valid
    assert (tmp_path / "run.png").read_bytes() == (lab / "run.png").read_bytes()
    assert (tmp_path / "run.plot.png").is_file()


# --------------------------------------------------------- subprocesses: signals, pipes, console
RIG_CMD = [sys.executable, "-m", "rigtools.cli"]
PACED_DWELL = acquire_dwell(fe="60 Hz", gap=None, pace=True)


def _env(**extra: str) -> dict[str, str]:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", COLUMNS="100")
    env.update(extra)
    return env


def _spawn(argv: list[str], cwd: Path, **env: str) -> subprocess.Popen:
    return subprocess.Popen(
        [*RIG_CMD, *argv],
        cwd=cwd,
        env=_env(**env),
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_for(condition: Callable[[], bool], proc: subprocess.Popen, limit: float = 60.0) -> None:
    """Poll until ``condition()`` (not a timing assertion: the limit only stops a hung test)."""
    end = time.monotonic() + limit
    while not condition():
        assert proc.poll() is None, f"rig ended early: {proc.communicate()}"
        assert time.monotonic() < end, "gave up waiting"
        time.sleep(0.05)


def _writing(path: Path) -> Callable[[], bool]:
    """True once the recording holds at least one point with samples."""

    def ready() -> bool:
        if not path.exists():
            return False
        try:
            with open_recording(path) as rec:
                return bool(rec.points) and rec.points[0].n_samples > 0
        except Exception:  # noqa: BLE001 - the writer is mid-update: any read error means "not yet"
            return False

    return ready


def _finish(proc: subprocess.Popen) -> tuple[int, str, str]:
    out, err = proc.communicate(timeout=120)
    return proc.returncode, out, err


SIGNALS = [signal.SIGINT, signal.SIGTERM, signal.SIGHUP]


@pytest.mark.parametrize("sig", SIGNALS, ids=lambda s: s.name)
def test_signal_during_start_up(sig, lab, lab_digest, tmp_path):
    """A signal while ``rig`` is still importing: one line at most, its documented status (the
    shell's 128 + n, or the signal itself if it landed before Python could take it)."""
    proc = _spawn(["simulate", "--out", str(tmp_path / "s.h5")], tmp_path)
    time.sleep(0.3)
    proc.send_signal(sig)
    code, _, err = _finish(proc)
    assert code in (128 + sig, -sig), err
    assert "Traceback" not in err and len(err.strip().splitlines()) <= 2, err
    assert _digest(lab) == lab_digest


@pytest.mark.parametrize("sig", SIGNALS, ids=lambda s: s.name)
def test_signal_during_a_simulated_acquisition(sig, lab, lab_digest, tmp_path):
    """The recording being written ends ``aborted`` with the signal named, samples kept, the
    drive back at zero at its end; one line; exit 128 + n."""
    out = tmp_path / "run.h5"
    proc = _spawn([*PACED_DWELL, "--periods", "3000", "--out", str(out)], tmp_path)
    _wait_for(_writing(out), proc)
    proc.send_signal(sig)
    code, _, err = _finish(proc)
    assert code == 128 + sig, err
    lines = err.strip().splitlines()
    assert "Traceback" not in err and 1 <= len(lines) <= 2 and sig.name in lines[-1], err
    with open_recording(out) as rec:
        assert rec.status == "aborted" and sig.name in str(rec.attrs.get("abort_reason"))
        point = rec.points[-1]
        assert point.n_samples > 0
        drive = point.channels["drive"].read()
        assert np.all(np.isfinite(drive)) and abs(drive[-1]) < 1e-3 * np.max(np.abs(drive))
    assert check_recording(out).valid
    assert _digest(lab) == lab_digest


def test_sigterm_during_a_model_study_keeps_finished_points(lab, lab_digest, tmp_path):
    out = tmp_path / "study.h5"
    proc = _spawn(
        ["study", "frequency", "--values", "50 Hz:70 Hz:0.25 Hz", "--duration", "0.2 s", "--out", str(out)],
        tmp_path,
    )
    _wait_for(_writing(out), proc)
    proc.send_signal(signal.SIGTERM)
    code, _, err = _finish(proc)
    assert code == 143 and "Traceback" not in err and len(err.strip().splitlines()) <= 2, err
    with open_recording(out) as rec:
        assert len(rec.points) >= 1 and rec.status == "aborted"
    assert check_recording(out).valid


def test_closed_pipe(lab, tmp_path):
    """``rig info --json FILE | head -1``: the reader goes away; no traceback, status 0 or 141."""
    shell = subprocess.run(
        f"{' '.join(RIG_CMD)} info --json {lab / 'run.h5'} | head -1; echo status ${{PIPESTATUS[0]}} >&2",
        shell=True,
        executable="/bin/bash",
        capture_output=True,
        text=True,
        env=_env(),
        timeout=120,
        check=False,
    )
    assert shell.stdout.count("\n") == 1
    status = [line for line in shell.stderr.splitlines() if line.startswith("status")]
    assert status in (["status 0"], ["status 141"]) and "Traceback" not in shell.stderr, shell.stderr
    # a reader that closed before anything was written: the write fails, 141, nothing on stderr
    proc = _spawn(["info", "--json", str(lab / "run.h5")], tmp_path)
    proc.stdout.close()
    err = proc.stderr.read()
    assert proc.wait(timeout=120) == 141 and "Traceback" not in err and err.strip() == "", err


@pytest.mark.parametrize(
    "argv, code",
    [
        (["info", "{lab}/run.h5"], 0),
        (["modal", "--modes", "3"], 0),
        (["simulate", "--gap", "0.5 µM", "--out", "{tmp}/s.h5"], 2),
        (["modal", "--rig", "{tmp}/réglage.toml"], 2),
    ],
    ids=["info-table", "modal-table", "micro-sign-error", "accented-path-error"],
)
def test_ascii_only_console(argv, code, lab, lab_digest, tmp_path):
    """A console that cannot print non-ASCII (Windows ``> log.txt``): no UnicodeEncodeError."""
    proc = _spawn(_fill(argv, lab, tmp_path), tmp_path, PYTHONIOENCODING="ascii")
    got, out, err = _finish(proc)
    assert got == code and "Traceback" not in err and len(err.strip().splitlines()) <= 2, err
    assert out.isascii() and err.isascii()
    if code == 0:
        assert out.strip()
    assert _digest(lab) == lab_digest


def test_two_writers_on_one_path(lab, lab_digest, tmp_path):
    """While a paced acquisition writes run.h5, every other writer is refused with one line
    (``--overwrite`` included), readers say it is being written, and the first file ends valid
    (stopped by Ctrl-C once the others were refused, to keep the test short)."""
    out = tmp_path / "run.h5"
    first = _spawn([*PACED_DWELL, "--periods", "6000", "--out", str(out)], tmp_path)
    _wait_for(_writing(out), first)
    seconds = [
        [
            "acquire",
            "dwell",
            "--backend",
            "sim",
            "--fe",
            "60 Hz",
            "--force",
            "15 N",
            "--out",
            str(out),
            "--overwrite",
        ],
        ["simulate", "--out", str(out), "--overwrite", "--no-plot"],
        ["study", "gap", "--values", "0.5 mm", "--out", str(out), "--overwrite"],
        ["import", "tdms", str(lab / "in.tdms"), str(out), "--overwrite"],
    ]
    for argv in seconds:
        code, _, err = run_cli(argv)
        assert code in (2, 4) and "Traceback" not in err and len(err.strip().splitlines()) <= 2, (argv, err)
        assert "being written" in err or "in use" in err or "another" in err, (argv, err)
    code, info, err = run_cli(["info", str(out)])
    assert code == 0 and "Traceback" not in err and "being written" in info + err, info + err
    code, report, err = run_cli(["check", str(out)])
    assert code == 0 and "Traceback" not in err, report + err
    code, _, err = run_cli(["export", "uff", str(out), str(tmp_path / "partial.uff"), "--what", "time"])
    assert code in (0, 2) and "Traceback" not in err and len(err.strip().splitlines()) <= 2, err
    assert first.poll() is None, "the first run ended before the others were tried"
    first.send_signal(signal.SIGINT)
    code, _, err = _finish(first)
    assert code == 130, err
    assert check_recording(out).valid
    with open_recording(out) as rec:
        assert rec.status == "aborted" and rec.experiment["procedure"] == "sine dwell"
        assert rec.points[0].n_samples > 0
    assert _digest(lab) == lab_digest
