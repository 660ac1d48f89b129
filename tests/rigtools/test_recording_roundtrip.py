"""Round trip of recordings: every attribute and array written comes back exactly.

References are the inputs themselves (exact equality: float64 samples are stored bit for bit),
and plain h5py reading the documented names of docs/recording-format.md.
"""

from __future__ import annotations

import json
import re
from datetime import UTC, datetime, timedelta
from pathlib import Path

import h5py
import numpy as np
import pytest

import rigtools
from rigtools.recording import ChannelSpec, RecordingError, RecordingWriter, open_recording
from rigtools.recording.schema import CHANNEL_ATTRS, MEASURED_CHANNEL_ATTRS, POINT_ATTRS, ROOT_ATTRS

DOC = Path(__file__).parents[2] / "docs" / "recording-format.md"
RATE = 51200.0
RIG_TEXT = 'name = "test rig"\n[blade]\nlength = "180 mm"\n'
EXPERIMENT = {
    "procedure": "gap study",
    "operator": "tester",
    "gaps_m": [3e-4, 5e-4],
    "nested": {"ok": True, "n": 3},
    "note": "Ünïcode ok",
}


def _channels(rate: float = RATE) -> list[ChannelSpec]:
    return [
        ChannelSpec(
            "force",
            "N",
            "force",
            rate,
            t0=0.0,
            sensitivity=11.24,
            sensitivity_units="mV/N",
            physical_channel="Dev1/ai0",
            location="active blade, x=0.090 m",
        ),
        ChannelSpec(
            "active_shroud_accel",
            "m/s^2",
            "acceleration",
            rate,
            t0=1e-5,
            sensitivity=10.0,
            sensitivity_units="mV/g",
            physical_channel="Dev1/ai1",
            location="active blade, x=0.180 m",
        ),
        ChannelSpec(
            "passive_shroud_accel",
            "m/s^2",
            "acceleration",
            rate,
            sensitivity=9.87,
            sensitivity_units="mV/g",
            physical_channel="Dev1/ai2",
            location="passive blade, x=0.180 m",
        ),
        ChannelSpec("contact_force", "N", "force", rate),  # a simulated, unmeasured channel
    ]


def _write(path: Path, n_points: int = 3, blocks: int = 7, **kwargs) -> dict[int, np.ndarray]:
    """Write points of uneven block sizes; return the full arrays written per point."""
    rng = np.random.default_rng(7)
    written = {}
    with RecordingWriter(path, backend="simulated", rig=RIG_TEXT, experiment=EXPERIMENT, **kwargs) as rec:
        for p in range(n_points):
            point = rec.begin_point(
                params={
                    "fe": 60.0 + p,
                    "force_amplitude": 15.0,
                    "gap": 5e-4,
                    "repeat": p,
                    "label": f"pt{p}",
                    "harmonics": [1, 6, 8],
                },
                channels=_channels(),
            )
            parts = []
            for b in range(blocks):
                block = rng.standard_normal((4, 100 + 997 * b))  # odd sizes cross chunk edges
                point.append(block)
                parts.append(block)
            point.set_attrs(settled=p % 2 == 0, measured_force_amplitude=14.8 + p)
            point.end()
            written[p] = np.hstack(parts)
    return written


def test_every_attribute_and_array_round_trips(tmp_path):
    path = tmp_path / "run.h5"
    before = datetime.now(UTC)
    written = _write(path)
    after = datetime.now(UTC)
    with open_recording(path) as rec:
        assert rec.status == "complete" and rec.complete and not rec.incomplete
        assert rec.abort_reason == ""
        assert rec.schema_version == 1
        assert rec.software_version == rigtools.__version__
        assert rec.backend == "simulated"
        assert rec.rig == RIG_TEXT
        assert rec.experiment == EXPERIMENT
        created = datetime.fromisoformat(rec.created)
        ended = datetime.fromisoformat(rec.ended)
        assert created.utcoffset() == timedelta(0) and ended.utcoffset() == timedelta(0)
        assert before - timedelta(seconds=1) <= created <= ended <= after + timedelta(seconds=1)
        assert rec.opened_as == "clean"
        assert [p.index for p in rec.points] == [0, 1, 2]
        for p, point in enumerate(rec.points):
            assert point.params == {
                "fe": 60.0 + p,
                "force_amplitude": 15.0,
                "gap": 5e-4,
                "repeat": p,
                "label": f"pt{p}",
                "harmonics": [1, 6, 8],
                "settled": p % 2 == 0,
                "force_amplitude_measured": 14.8 + p,
            }  # v1 name read as today's
            assert isinstance(point.params["settled"], bool)
            assert isinstance(point.params["repeat"], int)
            assert point.ended and point.start_time <= point.end_time
            assert list(point.channels) == [c.name for c in _channels()]  # block order kept
            for row, spec in enumerate(_channels()):
                ch = point.channels[spec.name]
                for key in (
                    "units",
                    "quantity",
                    "sample_rate",
                    "t0",
                    "sensitivity",
                    "sensitivity_units",
                    "physical_channel",
                    "location",
                ):
                    assert getattr(ch, key) == getattr(spec, key), key
                np.testing.assert_array_equal(np.asarray(ch), written[p][row])  # exact
                np.testing.assert_array_equal(ch[10:20], written[p][row, 10:20])
                assert len(ch) == written[p].shape[1]
                assert ch.duration == pytest.approx(written[p].shape[1] / RATE, rel=1e-15)
            assert point.n_samples == written[p].shape[1]


def test_plain_h5py_reads_the_documented_names(tmp_path):
    """Only names from docs/recording-format.md and plain h5py: what a MATLAB/h5dump user does."""
    path = tmp_path / "run.h5"
    written = _write(path, n_points=2, blocks=3)
    with h5py.File(path, "r") as f:
        assert f.attrs["schema"] == "rigtools.recording"
        assert f.attrs["schema_version"] == 1
        assert f.attrs["status"] == "complete"
        assert json.loads(f.attrs["experiment"]) == EXPERIMENT
        assert f.attrs["rig"] == RIG_TEXT
        for key in ("created", "software_version", "backend", "abort_reason", "ended"):
            assert isinstance(f.attrs[key], str)
        assert sorted(f["points"]) == ["0000", "0001"]
        g = f["points/0001"]
        assert g.attrs["fe"] == 61.0 and g.attrs["gap"] == 5e-4 and g.attrs["settled"] == False
        ds = f["points/0001/passive_shroud_accel"]
        assert ds.dtype == np.float64 and ds.ndim == 1
        assert ds.attrs["units"] == "m/s^2" and ds.attrs["quantity"] == "acceleration"
        assert ds.attrs["sample_rate"] == RATE and ds.attrs["t0"] == 0.0
        assert ds.attrs["sensitivity"] == 9.87 and ds.attrs["sensitivity_units"] == "mV/g"
        assert ds.attrs["physical_channel"] == "Dev1/ai2"
        assert ds.attrs["location"] == "passive blade, x=0.180 m"
        assert ds.compression == "gzip" and ds.shuffle and ds.chunks is not None
        np.testing.assert_array_equal(ds[:], written[1][2])
        assert "sensitivity" not in f["points/0000/contact_force"].attrs


def test_every_schema_name_is_documented():
    text = DOC.read_text(encoding="utf-8")
    names = set(re.findall(r"`([a-z_0-9]+)`", text))
    for table in (ROOT_ATTRS, POINT_ATTRS, CHANNEL_ATTRS, MEASURED_CHANNEL_ATTRS):
        missing = set(table) - names
        assert not missing, f"not documented in {DOC.name}: {missing}"


def test_whole_array_append_and_uncompressed_option(tmp_path):
    """The fem backend appends a whole run at once; 'none' compression stores the same samples."""
    x = np.linspace(-1, 1, 200_003)[np.newaxis, :] ** 3
    path = tmp_path / "fem.h5"
    with RecordingWriter(path, backend="fem", rig="{}", compression="none") as rec:
        point = rec.begin_point({"fe": 60.0}, [ChannelSpec("active_tip_disp", "m", "displacement", 1e4)])
        point.append(x[0])  # 1-D for a single channel
        point.end()
    with open_recording(path) as back:
        np.testing.assert_array_equal(back.points[0]["active_tip_disp"][:], x[0])
    with h5py.File(path, "r") as f:
        assert f["points/0000/active_tip_disp"].compression is None


def test_dataframes(tmp_path):
    path = tmp_path / "run.h5"
    written = _write(path, n_points=2, blocks=2)
    with open_recording(path) as rec:
        long = rec.to_dataframe()
        n = written[0].shape[1]
        assert list(long.columns) == ["point", "channel", "time", "value"]
        assert len(long) == 2 * 4 * n
        sel = long[(long.point == 1) & (long.channel == "active_shroud_accel")]
        np.testing.assert_array_equal(sel.value.to_numpy(), written[1][1])
        np.testing.assert_allclose(sel.time.to_numpy(), 1e-5 + np.arange(n) / RATE, rtol=0, atol=1e-15)
        wide = rec.points[1].to_dataframe()
        np.testing.assert_array_equal(wide["force"].to_numpy(), written[1][0])
        per_point = rec.to_dataframe(per="point")
        assert list(per_point.fe) == [60.0, 61.0] and list(per_point.n_samples) == [n, n]


def test_never_overwrites_without_permission(tmp_path):
    path = tmp_path / "run.h5"
    path.write_bytes(b"precious")
    with pytest.raises(RecordingError, match="exists; give overwrite=True"):
        RecordingWriter(path, backend="fem", rig="{}")
    assert path.read_bytes() == b"precious"
    with RecordingWriter(path, backend="fem", rig="{}", overwrite=True):
        pass
    assert open_recording(path).status == "complete"
    with pytest.raises(RecordingError, match="does not exist"):
        RecordingWriter(tmp_path / "no" / "dir.h5", backend="fem", rig="{}")


@pytest.mark.parametrize(
    "exc, reason",
    [
        (RuntimeError("amplifier timeout\nsecond line"), "RuntimeError: amplifier timeout second line"),
        (KeyboardInterrupt(), "KeyboardInterrupt: interrupted by the user"),
    ],
)
def test_exception_marks_aborted_with_reason_and_reraises(tmp_path, exc, reason):
    path = tmp_path / "run.h5"
    block = np.arange(8.0).reshape(2, 4)
    with pytest.raises(type(exc)), RecordingWriter(path, backend="simulated", rig="{}") as rec:
        point = rec.begin_point({"fe": 60.0}, _channels()[:2])
        point.append(block)
        point.set_attrs(settled=False)
        raise exc
    with open_recording(path) as back:
        assert back.status == "aborted" and back.abort_reason == reason
        point = back.points[0]
        assert point.ended and point.params["settled"] is False  # data and parameters kept
        np.testing.assert_array_equal(np.asarray(point["active_shroud_accel"]), block[1])


def test_writer_rejects_programming_errors(tmp_path):
    with RecordingWriter(tmp_path / "run.h5", backend="fem", rig="{}") as rec:
        with pytest.raises(ValueError, match="reserved"):
            rec.begin_point({"start_time": 1.0}, _channels())
        with pytest.raises(ValueError, match="sample rate"):
            rec.begin_point({}, [_channels()[0], ChannelSpec("x", "V", "voltage", 1000.0)])
        with pytest.raises(ValueError, match="repeat"):
            rec.begin_point({}, [_channels()[0], _channels()[0]])
        with pytest.raises(ValueError, match="text, numbers"):
            rec.begin_point({"bad": {"a": 1}}, _channels())
        point = rec.begin_point({}, _channels())
        with pytest.raises(ValueError, match=r"expected \(4, n_samples\)"):
            point.append(np.zeros((3, 10)))
        with pytest.raises(RuntimeError, match="still open"):
            rec.begin_point({}, _channels())
        point.end()
        with pytest.raises(RuntimeError, match="ended"):
            point.append(np.zeros((4, 10)))
    with pytest.raises(ValueError):
        ChannelSpec("a/b", "V", "voltage", 1.0)
    with pytest.raises(ValueError):
        ChannelSpec("a", "V", "voltage", 0.0)
