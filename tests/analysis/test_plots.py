"""rigtools.analysis.plots: the figures hold exactly the data they were given (scaled to the stated
units), label every axis with its units, and mark k*fe and natural frequencies where asked.

References are the input arrays themselves and known synthetic signals: a sine of amplitude A
on a bin of a whole-period record reads A in the boxcar and flattop spectra (rigtools.analysis.spectra's
documented scaling), checked to 1e-9 relative.
"""

import numpy as np
import pytest
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure

from rigtools.analysis.plots import (
    amplitude_frequency_figure,
    study_figure,
    time_and_spectrum_figure,
    vibro_impact_figure,
)

FE = 50.0
RATE = 200 * FE  # 200 samples per period
N = 10 * 200  # 10 whole periods


def _signals():
    t = 0.25 + np.arange(N) / RATE
    w = 2 * np.pi * FE
    ua = 1.2e-3 * np.sin(w * t)
    up = 0.4e-3 * np.sin(w * t - 0.3)
    fc = np.clip(2e4 * (ua - up - 5e-4), 0.0, None)
    aa = 30.0 * np.sin(w * t) + 4.0 * np.sin(3 * w * t + 0.2)
    ap = 10.0 * np.sin(w * t) + 2.5 * np.sin(5 * w * t)
    return t, ua, up, fc, aa, ap


def _value_at(line, f):
    x, y = np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
    return y[np.argmin(np.abs(x - f))]


def _has_units(label: str) -> bool:
    return label.endswith(")") and "(" in label


def test_vibro_impact_figure_plots_the_inputs_in_mm_n_and_reads_the_spectra():
    t, ua, up, fc, aa, ap = _signals()
    fig = vibro_impact_figure(
        t,
        ua,
        up,
        fc,
        aa,
        ap,
        FE,
        periods=3,
        k_max=10,
        gap=5e-4,
        natural_frequencies_hz={"active": np.array([80.0, 420.0]), "passive": np.array([95.0])},
    )
    assert isinstance(fig, Figure) and len(fig.axes) == 4
    ax_u, ax_f, ax_sa, ax_sp = fig.axes
    last = slice(N - 600, N)  # 3 periods of 200 samples
    np.testing.assert_array_equal(ax_u.lines[0].get_xdata(), t[last])
    np.testing.assert_allclose(ax_u.lines[0].get_ydata(), ua[last] * 1e3, rtol=0, atol=0)
    np.testing.assert_allclose(ax_u.lines[1].get_ydata(), up[last] * 1e3, rtol=0, atol=0)
    np.testing.assert_allclose(ax_u.lines[2].get_ydata(), (up[last] + 5e-4) * 1e3, rtol=1e-15)
    np.testing.assert_array_equal(ax_f.lines[0].get_ydata(), fc[last])
    assert ax_u.get_ylabel() == "displacement (mm)" and ax_f.get_ylabel() == "contact force (N)"
    assert ax_f.get_xlabel() == "time (s)"
    # spectra of whole periods (boxcar): harmonic amplitudes read exactly (1e-9)
    spec_a, spec_p = ax_sa.lines[0], ax_sp.lines[0]
    assert _value_at(spec_a, FE) == pytest.approx(30.0, rel=1e-9)
    assert _value_at(spec_a, 3 * FE) == pytest.approx(4.0, rel=1e-9)
    assert _value_at(spec_p, 5 * FE) == pytest.approx(2.5, rel=1e-9)
    assert max(np.asarray(spec_a.get_xdata())) <= 11 * FE  # up to (k_max + 1) fe
    for ax in (ax_sa, ax_sp):
        assert ax.get_yscale() == "log"
        assert (
            ax.get_xlabel() == "frequency (Hz)" and ax.get_ylabel() == "acceleration, peak amplitude (m/s²)"
        )
        np.testing.assert_allclose(ax.lines[1].get_xdata(), FE * np.arange(1, 11))  # k*fe markers
        assert ax.get_legend() is not None
    # natural frequencies: one dashed vertical line each, per blade
    assert [line.get_xdata()[0] for line in ax_sa.lines[2:]] == [80.0, 420.0]
    assert [line.get_xdata()[0] for line in ax_sp.lines[2:]] == [95.0]


def test_vibro_impact_figure_without_gap_or_natural_frequencies():
    t, ua, up, fc, aa, ap = _signals()
    fig = vibro_impact_figure(t, ua, up, fc, aa, ap, FE, periods=20)  # more periods than recorded
    ax_u, _, ax_sa, _ = fig.axes
    assert len(ax_u.lines) == 2 and len(ax_u.lines[0].get_ydata()) == N
    assert len(ax_sa.lines) == 2  # spectrum and k*fe markers only


def test_study_figure_separates_sweeps_and_maps_the_harmonics():
    values = [3e-4, 5e-4, 7e-4, 5e-4, 3e-4]
    dirs = ["up", "up", "up", "down", "down"]
    force = [10.0, 20.0, 30.0, 22.0, 12.0]
    rng = np.random.default_rng(0)
    act = 10 ** rng.uniform(-1, 2, size=(5, 30))
    pas = 10 ** rng.uniform(-1, 2, size=(5, 30))
    fig = study_figure(
        "gap",
        values,
        dirs,
        force,
        {"active shroud": act, "passive shroud": pas},
        fixed={"fe": 60.0, "force": 15.0},
    )
    ax = fig.axes[0]
    up, down = ax.lines
    np.testing.assert_allclose(up.get_xdata(), [0.3, 0.5, 0.7], rtol=1e-12)
    np.testing.assert_array_equal(up.get_ydata(), [10.0, 20.0, 30.0])
    np.testing.assert_allclose(down.get_xdata(), [0.5, 0.3], rtol=1e-12)
    np.testing.assert_array_equal(down.get_ydata(), [22.0, 12.0])
    assert up.get_linestyle() != down.get_linestyle() and up.get_marker() != down.get_marker()
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["sweep up ↑", "sweep down ↓"]
    assert ax.get_xlabel() == "gap (mm)" and ax.get_ylabel() == "peak contact force (N)"
    for hm, amp in zip(fig.axes[1::2], (act, pas), strict=True):  # each heat map followed by its colour bar
        mesh = hm.collections[0]
        assert isinstance(mesh.norm, LogNorm)
        np.testing.assert_array_equal(np.asarray(mesh.get_array()).reshape(30, 5), amp.T)
        assert hm.get_ylabel() == "harmonic k (× fe)" and "(mm)" in hm.get_xlabel()
        assert [t.get_text() for t in hm.get_xticklabels()] == ["0.3↑", "0.5↑", "0.7↑", "0.5↓", "0.3↓"]
    assert [cb.get_ylabel() for cb in fig.axes[2::2]] == ["peak amplitude (m/s²)"] * 2
    assert "fe = 60 Hz" in fig.get_suptitle() and "F0 = 15 N" in fig.get_suptitle()


def test_study_figure_with_silent_points_and_bad_kind():
    """Points without contact have (near) zero harmonics: the log colour scale still spans
    at most 4 decades below the largest amplitude instead of failing on zeros."""
    amp = np.zeros((2, 30))
    amp[1, :] = np.linspace(1.0, 100.0, 30)
    fig = study_figure("frequency", [60.0, 70.0], ["up", "up"], [0.0, 5.0], {"passive shroud": amp})
    norm = fig.axes[1].collections[0].norm
    assert (norm.vmin, norm.vmax) == (pytest.approx(1.0), pytest.approx(100.0))
    assert fig.axes[0].get_xlabel() == "frequency (Hz)" and len(fig.axes[0].lines) == 1
    with pytest.raises(ValueError, match="kind"):
        study_figure("speed", [1.0], ["up"], [0.0], {})


def test_time_and_spectrum_figure_per_channel():
    rate, fe = 51200.0, 64.0  # 800 samples per period, bins on k*fe for whole periods
    n = 800 * 32
    t = np.arange(n) / rate
    force = 12.0 * np.sin(2 * np.pi * fe * t) + 0.6 * np.sin(2 * np.pi * 2 * fe * t)
    accel = 150.0 * np.cos(2 * np.pi * 4 * fe * t)
    fig = time_and_spectrum_figure(
        {"force": force, "active_shroud_accel": accel},
        {"force": "N", "active_shroud_accel": "m/s^2"},
        rate,
        fe,
        t0=1.5,
        periods=5,
    )
    assert len(fig.axes) == 4
    ax_ft, ax_fs, ax_at, ax_as = fig.axes
    # time from the upward zero crossing of the force fundamental (ms), 5 periods: the force's
    # fundamental 12 sin starts at 0 rising; the same reference on every channel
    xt, yt = ax_ft.lines[0].get_xdata(), ax_ft.lines[0].get_ydata()
    dt_ms = 1e3 / rate
    assert 0 <= xt[0] < dt_ms and xt[-1] == pytest.approx(5e3 / fe, abs=dt_ms)
    i0 = round((1.5 + xt[0] * 1e-3 - 1.5) * rate) % 800  # sample within the period
    np.testing.assert_allclose(
        yt, force[n - 4800 :][(np.arange(4800) % 800 == i0).argmax() :][: yt.size], atol=1e-12
    )
    assert (
        abs(yt[0] - 0.6 * np.sin(2 * np.pi * 2 * fe * xt[0] * 1e-3)) < 12 * 2 * np.pi * fe / rate
        and yt[1] > yt[0]
    )
    np.testing.assert_array_equal(ax_at.lines[0].get_xdata(), xt)
    assert ax_ft.get_ylabel() == "force (N)" and ax_at.get_ylabel() == "active_shroud_accel (m/s²)"
    assert ax_fs.get_ylabel() == "peak amplitude (N)" and ax_as.get_ylabel() == "peak amplitude (m/s²)"
    assert ax_at.get_xlabel() == "time from the upward zero crossing of the force fundamental (ms)"
    assert ax_as.get_xlabel() == "frequency (Hz)"
    # flattop, tones on bins: the documented peak scaling (1e-9)
    assert _value_at(ax_fs.lines[0], fe) == pytest.approx(12.0, rel=1e-9)
    assert _value_at(ax_fs.lines[0], 2 * fe) == pytest.approx(0.6, rel=1e-9)
    assert _value_at(ax_as.lines[0], 4 * fe) == pytest.approx(150.0, rel=1e-9)
    assert max(ax_as.lines[0].get_xdata()) <= 31 * fe


def test_amplitude_frequency_figure_plots_each_curve():
    f = np.linspace(10.0, 500.0, 50)
    locs = ("active_shroud", "active_force_point", "passive_shroud", "passive_force_point")
    curves = {
        model: {
            "displacement": {loc: (i + 1) * scale * 1e-4 / f for i, loc in enumerate(locs)},
            "acceleration": {loc: (i + 1) * scale * f for i, loc in enumerate(locs)},
        }
        for model, scale in (("FEM", 1.0), ("AM", 1.01))
    }
    fig = amplitude_frequency_figure(f, curves, force_amplitude=15.0, title="rig")
    axes = fig.axes
    assert len(axes) == 4
    # axes order: row-major (displacement active, displacement passive, acceleration ...)
    for ax, quantity, blade in (
        (axes[0], "displacement", "active"),
        (axes[1], "displacement", "passive"),
        (axes[2], "acceleration", "active"),
        (axes[3], "acceleration", "passive"),
    ):
        expected = [
            curves[m][quantity][f"{blade}_{loc}"] for loc in ("shroud", "force_point") for m in ("FEM", "AM")
        ]
        assert len(ax.lines) == 4
        for line, y in zip(ax.lines, expected, strict=True):
            np.testing.assert_array_equal(line.get_xdata(), f)
            np.testing.assert_array_equal(line.get_ydata(), y)
        assert ax.get_yscale() == "log" and _has_units(ax.get_ylabel())
    assert axes[0].get_ylabel() == "displacement, peak amplitude (m)"
    assert (
        axes[2].get_ylabel() == "acceleration, peak amplitude (m/s²)"
        and axes[2].get_xlabel() == "frequency (Hz)"
    )
    # every curve of an axes told apart: distinct (colour, line style, marker) and legend labels
    for ax in axes:
        styles = {(l.get_color(), l.get_linestyle(), l.get_marker()) for l in ax.lines}
        assert len(styles) == 4
        assert len({t.get_text() for t in ax.get_legend().get_texts()}) == 4
    assert fig.get_suptitle() == "rig: linear response to F0 = 15 N"


def test_vibro_impact_figure_times_from_the_force_zero_crossing():
    """With the force given, the time axis is the one of every other waveform plot: ms from the
    upward zero crossing of the force fundamental (a force 0.7 rad ahead of sin(w t))."""
    t, ua, up, fc, aa, ap = _signals()
    force = 15.0 * np.sin(2 * np.pi * FE * t + 0.7)
    fig = vibro_impact_figure(t, ua, up, fc, aa, ap, FE, periods=3, force=force)
    ax_u, ax_f = fig.axes[:2]
    x = np.asarray(ax_u.lines[0].get_xdata())
    assert 0 <= x[0] < 1e3 / RATE and x[-1] == pytest.approx(3e3 / FE, abs=1e3 / RATE)
    # at the time origin the force is zero and rising: ua = 1.2e-3 sin(w t) there reads 1.2 sin(-0.7) mm
    assert ax_u.lines[0].get_ydata()[0] == pytest.approx(
        1.2 * np.sin(2 * np.pi * FE * x[0] * 1e-3 - 0.7), abs=1.2 * 2 * np.pi * FE / RATE
    )
    assert ax_f.get_xlabel() == "time from the upward zero crossing of the force fundamental (ms)"


def test_log_spectrum_ticks_are_plain_text_powers_of_ten():
    """``10⁻³`` drawn from the font, not mathtext's ``$10^{-3}$`` (no TeX parser built)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from rigtools.analysis.plots import power_label

    assert [power_label(v) for v in (1e-3, 1.0, 10.0, 1e12, 2e-3, 0.0, -1.0, np.inf)] == [
        "10⁻³", "1", "10¹", "10¹²", "0.002", "", "", "",
    ]  # fmt: skip
    fig = vibro_impact_figure(*_signals(), FE, k_max=10)
    FigureCanvasAgg(fig).draw()
    for ax in fig.axes[2:]:
        labels = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
        assert len(labels) >= 3 and all(s == "1" or s.startswith("10") and "$" not in s for s in labels)
        values = [float(t.get_position()[1]) for t in ax.get_yticklabels() if t.get_text()]
        assert labels == [power_label(v) for v in values]
