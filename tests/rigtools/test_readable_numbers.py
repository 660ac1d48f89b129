"""Numbers as a person reads them (issue 31, item 4): one rule (:mod:`rigtools.readable`) for the
terminal, the HTML report, ``rig info`` and the monitor; one exit-status table for the README,
``rig --help`` and every command's help."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rigtools import readable
from rigtools.analysis.harmonics import harmonic_amplitudes
from rigtools.errors import EXIT_STATUSES, SIGNAL_NAMES

ROOT = Path(__file__).resolve().parents[2]


def test_a_pure_sines_harmonics_are_shown_as_round_off_its_fundamental_as_a_value():
    """Independent reference: a sampled 15 N sine has exactly zero harmonics k >= 2; the least-
    squares fit leaves only round-off there (a few 1e-15 N), which is shown as round-off."""
    rate, fe = 51200.0, 60.0
    t = np.arange(int(rate)) / rate
    amps = harmonic_amplitudes(15.0 * np.sin(2 * np.pi * fe * t), rate, fe, 10).amplitude
    assert 0 < max(amps[1:]) < 1e-12  # the round-off the issue saw (2.67e-15 N)
    shown = readable.harmonics(amps)
    assert shown[0] == "15"
    assert shown[1:] == [readable.ROUND_OFF_TEXT] * 9
    # a real harmonic a million times below the fundamental stays a value (1e-6 > 1e-9)
    assert readable.harmonic(15e-6, 15.0) == "1.5e-05"


@settings(max_examples=200, deadline=None)
@given(
    x=st.floats(allow_nan=False, allow_infinity=False, min_value=-1e12, max_value=1e12),
    top=st.floats(min_value=1e-6, max_value=1e12),
)
def test_round_off_is_exactly_the_rule_below_1e_9_of_the_channels_largest(x, top):
    shown = readable.harmonic(x, top)
    assert (shown == readable.ROUND_OFF_TEXT) == (abs(x) <= 1e-9 * top)


@settings(max_examples=200, deadline=None)
@given(
    x=st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6),
    spec=st.sampled_from([None, ".1f", "+.1f", ".2f", "+.2f", ".3f", ".0f"]),
)
def test_no_minus_zero_and_the_digits_of_the_rule(x, spec):
    text = readable.number(x, spec)
    assert not re.fullmatch(r"-0(\.0*)?(e[+-]?\d+)?", text)  # never "-0", "-0.0"
    if spec is None and x != 0 and abs(x) < 1e4:
        digits = re.sub(r"e.*", "", text).lstrip("+-").replace(".", "").lstrip("0")
        assert len(digits) <= readable.DIGITS
        assert float(text) == pytest.approx(x, rel=5 * 10.0**-readable.DIGITS)


def test_html_cells_use_the_terminals_digits():
    from rigtools.report.html import Section

    sec = Section("t").table([{"F1 (N)": 14.99132, "diff %": readable.shown(-0.004, "+.1f")}])
    html = sec.blocks[0]
    assert "<td>14.99</td>" in html and "<td>+0.0</td>" in html


# -- exit statuses ----------------------------------------------------------------------------------
def _help(*words: str) -> str:
    run = subprocess.run(
        [sys.executable, "-m", "rigtools.cli", *words, "--help"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=True,
    )
    return " ".join(run.stdout.split())


def test_readme_and_rig_help_show_the_one_exit_status_table():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    top = _help()
    for code, text in EXIT_STATUSES.items():
        assert f"| {code} | {text} |" in readme, code
        assert f"{code} {text}" in top, code


def test_every_command_names_130_143_129_by_signal_and_dwell_names_6():
    from rigtools.cli import build_parser

    parser = build_parser(None)
    skip = ("acquire",)
    names = [n for n in parser.rig_commands.choices if n not in skip] + ["acquire dwell", "acquire sweep"]
    missing = []
    for name in names:
        text = _help(*name.split())
        for code, words in SIGNAL_NAMES.items():
            if f"{code} {words}" not in text:
                missing.append((name, code))
    assert not missing, missing
    dwell = _help("acquire", "dwell")
    assert "6 stopped from the monitor's page" in dwell and "130 for any signal" not in dwell


# -- rig info --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def dwell(tmp_path_factory):
    from rigtools.config import load_rig
    from rigtools.procedures import SineDwell

    out = tmp_path_factory.mktemp("info") / "dwell.h5"
    SineDwell(
        load_rig(), {"fe": 60.0, "force": 15.0, "gap": 5e-4, "record_periods": 20}, out, backend="sim"
    ).run()
    return out


def test_rig_info_is_a_table_with_units_and_no_round_off_value(dwell):
    run = subprocess.run(
        [sys.executable, "-m", "rigtools.cli", "info", str(dwell)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={"COLUMNS": "200", "PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT)},
        check=True,
    )
    out = run.stdout
    assert "control_limited_by=" not in out and "=[" not in out  # no key=value dump
    for heading in ("fe (Hz)", "F0 (N)", "F1 (N)", "gap (mm)", "drive (V)"):
        assert heading in out
    drive = next(line for line in out.splitlines() if "│ drive " in line and "voltage" not in line)
    assert readable.ROUND_OFF_TEXT in drive  # its k >= 2 harmonics of a written sine
    assert not re.search(r"\de-1\d", out)  # no 1e-17-style value anywhere
    assert "-0 " not in out and "-0.0" not in out
