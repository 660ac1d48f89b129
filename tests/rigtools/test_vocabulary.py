"""One vocabulary for EM and FEM recordings: every writer uses its names and units, old v1
names map to the current ones, and force_amplitude_measured is the force's fundamental."""

import numpy as np
import pytest

from rigtools.analysis.harmonics import harmonic_amplitudes
from rigtools.config import load_rig
from rigtools.recording import RecordingWriter, open_recording
from rigtools.simulation import (
    MODEL_OUTPUTS,
    RunSettings,
    channel_specs,
    end_attrs,
    load_system,
    point_params,
    simulate_point,
    write_point,
)
from rigtools.vocabulary import (
    CHANNELS,
    EM,
    FEM,
    PARAMETERS,
    V1_PARAMETER_RENAMES,
    channel_names,
    current_parameters,
    source_of,
    unknown_parameters,
)


@pytest.fixture(scope="module")
def run():
    cfg, system = load_system(None, "fem")
    return cfg, simulate_point(system.with_contact(gap=0.5e-3), 60.0, 15.0, RunSettings(0.1, 4.0))


def test_model_channels_are_the_vocabulary_fem_channels_with_its_units(run):
    _, r = run
    assert sorted(MODEL_OUTPUTS) == sorted(channel_names(FEM))
    for spec in channel_specs(r.sample_rate):
        term = CHANNELS[spec.name]
        assert (spec.units, spec.quantity, spec.location) == (term.units, term.quantity, term.location)


def test_rig_inputs_are_vocabulary_channels_with_the_same_units():
    """The default rig's DAQ inputs are named and scaled as the model's channels of the same name."""
    specs = load_rig().daq.input_specs()
    assert {s.name for s in specs} == {"force", "active_shroud_accel", "passive_shroud_accel"}
    for s in specs:
        assert EM in CHANNELS[s.name].sources and FEM in CHANNELS[s.name].sources
        assert s.quantity == CHANNELS[s.name].quantity
    assert channel_names(EM) == ["force", "active_shroud_accel", "passive_shroud_accel", "drive"]


def test_model_point_parameters_are_all_vocabulary_terms(run):
    _, r = run
    params = {**point_params(r, "fem"), "direction": "up", "study_value": 1.0, **end_attrs(r)}
    assert unknown_parameters(params) == []
    assert {k for k, t in PARAMETERS.items() if t.at == "end" and FEM in t.sources} == set(end_attrs(r))


def test_force_amplitude_measured_is_the_fundamental_of_the_recorded_force(run, tmp_path):
    cfg, r = run
    out = tmp_path / "p.h5"
    with RecordingWriter(out, backend="fem", rig=cfg.to_json()) as rec:
        write_point(rec, r, "fem")
    with open_recording(out) as rec:
        p = rec.points[0]
        fund = harmonic_amplitudes(p["force"][:], p.sample_rate, p.params["fe"], 1).at(1)
        assert p.params["force_amplitude_measured"] == pytest.approx(fund, rel=1e-12)
        assert fund == pytest.approx(15.0, rel=1e-12)  # the model's force is F0 sin(2 pi fe t)
        assert "measured_force_amplitude" not in p.params


def test_v1_names_map_to_current_ones():
    assert V1_PARAMETER_RENAMES == {"measured_force_amplitude": "force_amplitude_measured"}
    assert current_parameters({"fe": 60.0, "measured_force_amplitude": 14.8}) == {
        "fe": 60.0,
        "force_amplitude_measured": 14.8,
    }
    # a current name present wins over its old alias
    assert current_parameters({"measured_force_amplitude": 1.0, "force_amplitude_measured": 2.0}) == {
        "force_amplitude_measured": 2.0
    }


@pytest.mark.parametrize("n", [120, 121, 123, 150, 327])
def test_v1_fem_max_abs_force_is_the_fundamental_within_the_stated_bound(n):
    """FEM v1 files stored max|F| of F0 sin(2 pi i / n): within 1 - cos(pi / n) <= 0.034 % of F0."""
    f0 = 15.0
    x = f0 * np.sin(2 * np.pi * np.arange(3 * n) / n)
    fund = harmonic_amplitudes(x, 60.0 * n, 60.0, 1).at(1)
    assert fund == pytest.approx(f0, rel=1e-12)
    rel = (fund - np.max(np.abs(x))) / fund
    assert 0 <= rel <= 1 - np.cos(np.pi / n) + 1e-15 and rel <= 3.5e-4


def test_backends_map_to_sources():
    assert [source_of(b) for b in ("fem", "simulated", "nidaqmx", "uff")] == [FEM, EM, EM, EM]
