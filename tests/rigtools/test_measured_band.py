"""``rig analyze --band`` on a measured FRF follows the band (issue 29).

ufffiles-hammer (../shared/data/ufffiles-hammer, MIT): an analyser's accelerance, 0-800 Hz on
0.5 Hz lines, imported with ``rig import uff``. On the whole grid rig analyze finds six modes in
50-200 Hz; with ``--band "50 Hz:200 Hz"`` it found none (LSCF orders 82-160 on 300 lines) and
``40 Hz:260 Hz`` none, with exit 0. Here each band's modes are held against the whole grid's.

The public data are read from ``../shared/data`` next to the repository; the tests skip, naming
the folder, where it is absent.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_cli
from public_data import PUBLIC_DATA, missing

DATA = PUBLIC_DATA
HAMMER = DATA / "ufffiles-hammer"
BANDS = {"50 Hz:200 Hz": (50.0, 200.0), "40 Hz:260 Hz": (40.0, 260.0), "55 Hz:130 Hz": (55.0, 130.0)}


def _need(folder: Path) -> None:
    if not folder.is_dir():
        missing(f"public data {folder} is absent (a clone without ../shared)", "RIGTOOLS_REQUIRE_DATA")


def _modes(path, *band) -> dict:
    code, out, err = run_cli(["analyze", path, "--json", *(["--band", band[0]] if band else [])])
    assert code == 0, err
    return next(iter(json.loads(out)["points"][0]["frf"]["modes"].values()))


@pytest.fixture(scope="module")
def hammer(tmp_path_factory):
    """The FRF imported, and the whole grid's modes."""
    _need(HAMMER)
    path = tmp_path_factory.mktemp("hammer") / "f.h5"
    code, _, err = run_cli(["import", "uff", HAMMER / "dataset58_FRF.unv", path])
    assert code == 0, err
    return path, _modes(path)


def _pairs(band_modes: dict, full: dict, lo: float, hi: float):
    """(band mode, whole-grid mode) for every whole-grid mode with two half-power bandwidths
    (2 zeta fn) or more inside each band edge (248.8 Hz, zeta 2.3 %, is 1 bandwidth below 260 Hz:
    not held by 40-260 Hz)."""
    inside = [
        m
        for m in full["modes"]
        if lo + 4 * m["damping_ratio"] * m["frequency_hz"]
        <= m["frequency_hz"]
        <= hi - 4 * m["damping_ratio"] * m["frequency_hz"]
    ]
    fb = np.array([m["frequency_hz"] for m in band_modes["modes"]])
    assert fb.size, band_modes["notes"]
    return [(band_modes["modes"][int(np.argmin(np.abs(fb - m["frequency_hz"])))], m) for m in inside]


def _check_frequencies(band: str, hammer) -> None:
    path, full = hammer
    got = _modes(path, band)
    assert got["no_mode"] is None and got["n_modes"] == len(got["modes"])
    pairs = _pairs(got, full, *BANDS[band])
    assert (
        len({id(m) for m, _ in pairs})
        == len(pairs)
        == {"50 Hz:200 Hz": 6, "40 Hz:260 Hz": 7, "55 Hz:130 Hz": 4}[band]
    )
    for m, ref in pairs:
        assert abs(m["frequency_hz"] / ref["frequency_hz"] - 1) < 2e-3, (m, ref)


@pytest.mark.parametrize("band", ["50 Hz:200 Hz", "40 Hz:260 Hz"])
def test_each_band_finds_the_whole_grids_modes_in_it(hammer, band):
    """Every mode of the whole grid the band holds (6 and 7) is found in it, each by one mode of
    the band, its frequency within 0.2 % of the whole grid's (the issue's must-show; the modes'
    own spread over the LSCF orders is up to 0.4 %, and a local SDOF fit on the same FRF differs
    from the whole grid's LSCF by up to 0.2 %: 96.22 against 96.02 Hz)."""
    _check_frequencies(band, hammer)


@pytest.mark.xfail(
    strict=True,
    reason="55-130 Hz: the 4 modes are found, but 81.3 Hz (zeta 2.4 %) at 81.47 Hz, +0.22 % (0.02 % over); "
    "its spread over the orders is 0.22 % in the band and 0.40 % on the whole grid",
)
def test_the_narrowest_band_finds_the_whole_grids_modes_in_it(hammer):
    """As the test above, for 55-130 Hz (4 modes, 0.2 %)."""
    _check_frequencies("55 Hz:130 Hz", hammer)


@pytest.mark.parametrize("band", ["50 Hz:200 Hz", "40 Hz:260 Hz"])
def test_each_band_finds_the_whole_grids_damping(hammer, band):
    """The damping ratios within 20 % of the whole grid's: the whole grid's own spread over the
    orders (interquartile range / median) is 8 % for the 81.3 Hz mode and 18 % for the 140.6 Hz
    one, and a local SDOF fit differs from it by up to 22 % (1.19 against 0.97 % at 175 Hz)."""
    path, full = hammer
    for m, ref in _pairs(_modes(path, band), full, *BANDS[band]):
        assert abs(m["damping_ratio"] / ref["damping_ratio"] - 1) < 0.2, (m, ref)


@pytest.mark.xfail(
    strict=True,
    reason="55-130 Hz: the 125.2 Hz mode's damping comes out 1.58 % against the whole grid's 0.75 % "
    "(+111 %; its frequency is right, +0.03 %): sdypy-EMA's LSCF puts the band's top (130 Hz, 2.5 "
    "half-power bandwidths above the mode) at its Nyquist, next to the strong 140.6 Hz mode outside; "
    "a band-centred (zoomed) LSCF gave 0.72 % in a trial",
)
def test_the_narrowest_band_finds_the_whole_grids_damping(hammer):
    """As the test above, for 55-130 Hz (20 %)."""
    path, full = hammer
    for m, ref in _pairs(_modes(path, "55 Hz:130 Hz"), full, *BANDS["55 Hz:130 Hz"]):
        assert abs(m["damping_ratio"] / ref["damping_ratio"] - 1) < 0.2, (m, ref)


def test_a_band_without_a_mode_says_so_in_the_json(hammer):
    """180-235 Hz lies between the 175.1 and 239.4 Hz modes (peaks of |H| outside it): no mode,
    exit 0 (the analysis ran: other responses and points keep their results), and ``no_mode``
    says what was tried and what would help; ``n_modes`` is 0 and ``tried`` has the band's
    lines (111 of 0.5 Hz)."""
    path, _ = hammer
    got = _modes(path, "180 Hz:235 Hz")
    assert got["n_modes"] == 0 and got["modes"] == []
    assert got["no_mode"].startswith("no mode between 180 and 235 Hz") and "would help" in got["no_mode"]
    assert got["tried"]["lines"] == 111
