"""Derived files (plots) never overwrite the recording they describe, nor any file not a plot."""

from __future__ import annotations

import numpy as np
import pytest

from rigtools.derived_files import derived_path, is_derived_plot, plot_path, png_software, write_derived
from rigtools.errors import UserError
from rigtools.figures import save_figure
from rigtools.recording import ChannelSpec, RecordingWriter, open_recording


def _recording(path):
    with RecordingWriter(path, backend="simulated", rig="{}") as rec:
        point = rec.begin_point({"fe": 60.0}, [ChannelSpec("force", "N", "force", 1000.0)])
        point.append(np.sin(np.arange(500) / 10.0))
    return path.read_bytes()


def _figure():
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2, 2))
    fig.add_subplot().plot([0, 1], [1, 0])
    return fig


@pytest.mark.parametrize(
    "name", ["x.png", "x.PNG", "run.h5", "run", "a.b.png", ".png", "x.plot.png", "run.hdf5"]
)
def test_plot_path_is_never_the_output(tmp_path, name):
    out = tmp_path / name
    assert plot_path(out) != out
    assert plot_path(out).name.lower() != name.lower()
    assert plot_path(out).suffix == ".png"


def test_plain_rule_keeps_stem_png(tmp_path):
    assert plot_path(tmp_path / "run.h5") == tmp_path / "run.png"
    assert plot_path(tmp_path / "x.png") == tmp_path / "x.plot.png"


@pytest.mark.parametrize("name", ["x.png", "x.PNG", "sweep.plot.png", "noext"])
def test_recording_survives_its_own_plot(tmp_path, name):
    rec_path = tmp_path / name
    data = _recording(rec_path)
    written = save_figure(_figure(), plot_path(rec_path))
    assert written != rec_path and is_derived_plot(written)
    assert rec_path.read_bytes() == data
    with open_recording(rec_path) as rec:
        assert rec.complete and len(rec.points[0]["force"]) == 500


def test_plot_never_replaces_another_recording_or_user_file(tmp_path):
    other = tmp_path / "run.png"  # another recording, named like run.h5's plot
    other_data = _recording(other)
    _recording(tmp_path / "run.h5")
    first = save_figure(_figure(), plot_path(tmp_path / "run.h5"))
    assert first == tmp_path / "run.plot.png" and other.read_bytes() == other_data
    user = tmp_path / "run.plot.png"
    second = save_figure(_figure(), plot_path(tmp_path / "run.h5"))  # replaces its own plot
    assert second == first
    user.write_bytes(b"my notes")  # a user's file takes the name: next name used
    assert plot_path(tmp_path / "run.h5") == tmp_path / "run.plot-2.png"
    with pytest.raises(UserError, match="not made by rigtools"):
        save_figure(_figure(), other)
    with pytest.raises(UserError, match="not made by rigtools"):
        save_figure(_figure(), user)
    assert other.read_bytes() == other_data and user.read_bytes() == b"my notes"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.h5", "run.plot.png", "run.png"]


def test_write_derived_refuses_its_source_and_is_atomic(tmp_path):
    src = tmp_path / "data.csv"
    src.write_text("1,2\n")
    with pytest.raises(UserError, match="derived from"):
        write_derived(src, lambda tmp: tmp.write_text("x"), source=src, replaceable=lambda p: True)

    def failing(tmp):
        tmp.write_text("half")
        raise RuntimeError("disk full")

    target = derived_path(src, ".txt", "summary", replaceable=lambda p: True)
    assert target == tmp_path / "data.txt"
    with pytest.raises(RuntimeError):
        write_derived(target, failing, source=src, replaceable=lambda p: True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data.csv"]  # no half file, no temp


def test_plots_are_marked(tmp_path):
    path = save_figure(_figure(), tmp_path / "f.png")
    assert png_software(path).startswith("rigtools ")
    assert png_software(tmp_path / "absent.png") is None


def test_a_read_only_plot_is_kept_and_the_next_name_used(tmp_path):
    """A rigtools plot made read-only (-r--r--r--, kept as it was): the new plot takes the next
    name, as for a file rigtools did not make; rig simulate refused after the whole run (exit 2,
    no summary) because the name was chosen without the rule that then refused to write it."""
    kept = save_figure(_figure(), tmp_path / "run.png")
    kept.chmod(0o444)
    data = kept.read_bytes()
    assert plot_path(tmp_path / "run.h5") == tmp_path / "run.plot.png"
    assert save_figure(_figure(), plot_path(tmp_path / "run.h5")) == tmp_path / "run.plot.png"
    assert kept.read_bytes() == data
