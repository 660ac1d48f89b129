"""Report figures: they draw exactly the given data (in the stated units), label axes with units,
tell the curves apart in legends, and share the time reference in waveform overlays."""

import io

import numpy as np
import pytest
from matplotlib.figure import Figure

from rigtools.analysis.frf import sdof_frf
from rigtools.analysis.plots import (
    force_zero_crossing_time,
    frf_figure,
    harmonic_bars_figure,
    overlay_figure,
    stabilisation_figure,
    trend_figure,
)


def _units(label):
    return "(" in label and label.endswith(")")


def _png_size(fig):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=50)
    return len(buf.getvalue())


def test_frf_figure_magnitude_phase_coherence():
    f = np.linspace(1, 400, 800)
    h1 = sdof_frf(f, 100.0, 0.02, 1.0, "accelerance")
    h2 = 1.05 * h1
    fig = frf_figure(
        f, {"H1": h1, "H2": h2}, coherence={"H1/H2": np.full(f.size, 0.95)}, natural_frequencies_hz=[100.0]
    )
    ax_m, ax_p, ax_c = fig.axes
    np.testing.assert_allclose(ax_m.lines[0].get_ydata(), np.abs(h1))
    np.testing.assert_allclose(ax_p.lines[1].get_ydata(), np.degrees(np.angle(h2)))
    assert ax_m.get_ylabel() == "accelerance magnitude ((m/s²)/N)"
    assert ax_p.get_ylabel() == "phase (degrees)" and ax_c.get_ylabel() == "coherence (-)"
    labels = [t.get_text() for t in ax_m.get_legend().get_texts()]
    assert labels[:2] == ["H1", "H2"]
    assert ax_m.lines[0].get_linestyle() != ax_m.lines[1].get_linestyle()
    assert _png_size(fig) > 10_000


def test_harmonic_bars_show_both_sides():
    em = {"force": np.array([15.0, 1.0, 5.9]), "active_shroud_acceleration": np.array([100.0, 20.0, 34.0])}
    fem = {
        "force": np.array([15.0, 1e-3, 1e-3]),
        "active_shroud_acceleration": np.array([110.0, 10.0, 128.0]),
    }
    fig = harmonic_bars_figure(em, fem, {"force": "N", "active_shroud_acceleration": "m/s^2"}, 60.0)
    ax = fig.axes[1]
    heights = [p.get_height() for p in ax.patches]
    assert heights == [100.0, 20.0, 34.0, 110.0, 10.0, 128.0]
    assert ax.get_ylabel() == "peak amplitude (m/s²)"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["EM (experiment)", "FEM"]
    assert ax.get_title() == "active shroud acceleration"  # full name, not cut


def test_harmonic_bars_of_a_run_without_contact_draw_without_warning():
    """k = 1 alone and equal on both sides (a linear run against its model: a 100 m/s^2 fundamental
    of ``rig compare run.h5 run.h5``, on which matplotlib warned "identical low and high ylims")
    and a channel all zero (the contact force without contact; the demo's bars warned "no
    positive values"): drawn with no warning, the log axis a third of the bar to ten times it,
    the zero channel linear and said."""
    import warnings

    from rigtools.demo.report import spectrum_figure
    from rigtools.sim.channel_names import SHROUD_ACCELS

    em = {"passive_shroud_accel": np.r_[100.00000000000003, 5.6e-14, 2e-13], "contact_force": np.zeros(3)}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig = harmonic_bars_figure(em, em, {"passive_shroud_accel": "m/s^2", "contact_force": "N"}, 61.0)
        _png_size(fig)
        zeros = {"harmonics": {ch: np.zeros(10) for ch in SHROUD_ACCELS}}
        demo = spectrum_figure({"em": zeros, "fem": zeros, "am": zeros}, "no contact")
        _png_size(demo)
    accel, contact = fig.axes
    assert accel.get_yscale() == "log"
    np.testing.assert_allclose(accel.get_ylim(), (100 / 3, 1000.0), rtol=1e-12)
    assert contact.get_yscale() == "linear" and contact.get_ylim() == (0.0, 1.0)
    assert [t.get_text() for t in contact.texts] == ["all harmonics zero"]
    for ax in demo.axes:
        assert ax.get_yscale() == "linear" and [t.get_text() for t in ax.texts] == ["all harmonics zero"]


def test_trend_figure_em_and_fem_on_the_same_axes():
    gaps = np.array([0.7e-3, 0.3e-3, 0.5e-3])
    q = {
        "peak force-sensor signal": {"EM": (gaps, [20.0, 30.0, 25.0]), "FEM": (gaps, [19.0, 31.0, 26.0])},
        "passive shroud 22·fe amplitude": {"EM": (gaps, [5.0, 9.0, 7.0]), "FEM": (gaps, [4.0, 10.0, 6.0])},
    }
    fig = trend_figure("gap", q, {"peak force-sensor signal": "N", "passive shroud 22·fe amplitude": "m/s^2"})
    ax = fig.axes[0]
    np.testing.assert_allclose(ax.lines[0].get_xdata(), [0.3, 0.5, 0.7])
    np.testing.assert_allclose(ax.lines[0].get_ydata(), [30.0, 25.0, 20.0])
    np.testing.assert_allclose(ax.lines[1].get_ydata(), [31.0, 26.0, 19.0])
    assert ax.get_xlabel() == "gap (mm)" and ax.get_ylabel() == "peak force-sensor signal, peak (N)"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["EM", "FEM"]
    assert ax.lines[0].get_linestyle() != ax.lines[1].get_linestyle()
    assert fig.axes[1].get_ylabel() == "passive shroud 22·fe amplitude, peak (m/s²)"


def test_overlay_uses_each_sides_force_zero_crossing_as_time_zero():
    """EM at 51.2 kS/s starting at an arbitrary phase, FEM at 19.68 kS/s: both force waveforms
    start at 0 rising on the plot (the same time reference), and a 0.3 rad response lag shows
    as the same 0.3 / (2 pi fe) delay on both sides."""
    fe = 60.0
    sides = {}
    for name, rate, phase0 in (("EM", 51200.0, 1.234), ("FEM", 19680.0, 0.0)):
        t = np.arange(int(rate * 0.5)) / rate
        sides[name] = {
            "force": 15 * np.sin(2 * np.pi * fe * t + phase0),
            "active_acceleration": 100 * np.sin(2 * np.pi * fe * t + phase0 - 0.3),
        }
    em_ref = force_zero_crossing_time(sides["EM"]["force"], 51200.0, fe)
    assert 15 * np.sin(2 * np.pi * fe * em_ref + 1.234) == pytest.approx(0, abs=1e-9)
    fig = overlay_figure(
        sides["EM"],
        sides["FEM"],
        {"force": "N", "active_acceleration": "m/s^2"},
        fe,
        em_rate=51200.0,
        fem_rate=19680.0,
    )
    ax_force, _ax_fs, ax_acc, ax_as = fig.axes
    for line in ax_force.lines:
        t_ms, y = line.get_xdata(), line.get_ydata()
        np.testing.assert_allclose(
            y, 15 * np.sin(2 * np.pi * fe * t_ms * 1e-3), atol=15 * 2 * np.pi * fe / 19680.0
        )
    for line in ax_acc.lines:
        t_ms, y = line.get_xdata(), line.get_ydata()
        np.testing.assert_allclose(
            y, 100 * np.sin(2 * np.pi * fe * t_ms * 1e-3 - 0.3), atol=100 * 2 * np.pi * fe / 19680.0
        )
    assert [l.get_label() for l in ax_acc.lines] == ["EM", "FEM"]
    assert "zero crossing of the force fundamental (ms)" in ax_acc.get_xlabel()
    assert ax_as.get_ylabel() == "peak amplitude (m/s²)"
    # flattop spectra read the 100 m/s^2 fundamental within its 0.12 % scalloping loss
    assert max(ax_as.lines[0].get_ydata()) == pytest.approx(100.0, rel=2e-3)


def test_stabilisation_figure():
    from rigtools.analysis.modal_id import StabilisationChart

    chart = StabilisationChart(
        np.array([2, 4, 4, 6]),
        np.array([100.0, 100.1, 150.0, 180.0]),
        np.array([0.02, 0.02, 0.1, 0.05]),
        np.array([False, True, False, True]),
        judged=(4, 6),
        mode=np.array([-1, 0, -1, -1]),
    )
    f = np.linspace(1, 200, 200)
    fig = stabilisation_figure(chart, f, sdof_frf(f, 100.0, 0.02), natural_frequencies_hz=[100.1])
    ax = fig.axes[0]
    lines = {line.get_label(): line for line in ax.lines}
    np.testing.assert_array_equal(lines["pole"].get_xdata(), [100.0, 150.0])
    np.testing.assert_array_equal(lines["stable pole (frequency and damping)"].get_xdata(), [180.0])
    np.testing.assert_array_equal(lines["pole of a reported mode"].get_xdata(), [100.1])
    np.testing.assert_array_equal(lines["identified mode"].get_xdata(), [100.1, 100.1])
    assert ax.patches[0].get_label() == "orders judged (4-6)"
    assert ax.get_ylabel() == "model order (-)" and isinstance(fig, Figure)
