"""The paper's gap study at its own point (60 Hz, 15 N) measured on the simulated rig and compared
with the model: with the nominal model the measured force waveform does not help (its 6fe harmonic
drives the FEM's 2nd mode, 1.8 % above the rig's); after `rig update` fits the root stiffness and
damping to an FRF test, the model driven by the measured force agrees best. Issue 10's "measured
better than nominal" at the paper's point, and issue 11's "compare again after updating"."""

from __future__ import annotations

import json
import shutil

import pytest
from cli_helpers import acquire_frf, acquire_gap_study, rig

#: the FRF test (burst, 20 Hz-2 kHz, 8 averages), shared with test_tap_analyze_update.py
FRF = acquire_frf("burst", band="20 Hz:2 kHz", averages=8, seed=1)


@pytest.fixture(scope="module")
def scores(tmp_path_factory, sim_recording):
    cwd = tmp_path_factory.mktemp("cmp60")
    shutil.copy(sim_recording(FRF, "frf.h5"), cwd / "frf.h5")
    rig("update", "frf.h5", "--params", "root.rotational_stiffness,damping.ratio", "--out", "u.toml", cwd=cwd)
    rig(*acquire_gap_study("0.3 mm,0.6 mm,0.9 mm", fe="60"), "--out", "em.h5", cwd=cwd)
    out = {}
    for model in ("nominal", "updated"):
        for excitation in ("measured", "nominal"):
            extra = ["--rig", "u.toml"] if model == "updated" else []
            doc = json.loads(
                rig("compare", "em.h5", "--simulate", "--excitation", excitation, "--json", *extra, cwd=cwd)
            )
            out[model, excitation] = doc["mean_score"]
    print("agreement scores (model rig, excitation):", out)
    return out


def test_measured_force_wins_once_the_model_is_updated(scores):
    # measured on the nominal model: 0.611, nominal 0.619; updated: measured 0.985, nominal 0.738
    assert scores["updated", "measured"] > scores["updated", "nominal"] + 0.1
    assert scores["updated", "measured"] > scores["nominal", "measured"] + 0.2
    assert scores["updated", "measured"] > 0.95


def test_with_the_nominal_model_the_force_waveform_alone_does_not_help(scores):
    """Why the update matters: a super-harmonic near a resonance is very sensitive to a 1 % shift."""
    assert abs(scores["nominal", "measured"] - scores["nominal", "nominal"]) < 0.05
