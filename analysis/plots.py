"""Figures of the rig's results, built from arrays: each function returns a
:class:`matplotlib.figure.Figure` and never shows or saves it (the caller does, e.g.
``fig.savefig("run.png")``).

Figures are made with :class:`matplotlib.figure.Figure` directly, not through pyplot, so they need
no GUI backend and leave pyplot's figure list alone. Every axis label carries its units;
displacements are plotted in mm, forces in N, accelerations in m/s², frequencies in Hz, times in s.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, NullLocator

from rigtools.analysis.harmonics import harmonic_amplitudes, without_round_off
from rigtools.analysis.spectra import amplitude_spectrum
from rigtools.sim.channel_names import FORCE

BLADES = ("active", "passive")
SPECTRUM_FLOOR = 1e-5  # spectra on a log axis: show down to this fraction of the largest peak
STUDY_UNITS = {  # swept parameter -> (display unit, factor from SI)
    "gap": ("mm", 1e3),
    "force": ("N", 1.0),
    "frequency": ("Hz", 1.0),
}


_SUPERSCRIPT = str.maketrans(
    "-0123456789", "\u207b\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079"
)


def power_label(value: float, _position: object = None) -> str:
    """A log axis's tick label in plain text: ``10⁻³`` for a power of ten, else ``%g``.

    matplotlib's default (mathtext) builds a TeX parser on its first use, a sixth of a
    figure's drawing time; these labels look the same in the fonts every machine has."""
    if value <= 0 or not np.isfinite(value):
        return ""
    exponent = round(float(np.log10(value)))
    if abs(value / 10.0**exponent - 1.0) < 1e-9:
        return "1" if exponent == 0 else "10" + str(exponent).translate(_SUPERSCRIPT)
    return f"{value:g}"


def _suptitle(fig: Figure, text: str, width: int = 110) -> None:
    """A figure title wrapped over lines (never cut at the figure's edge)."""
    import textwrap

    fig.suptitle("\n".join(textwrap.wrap(text, width)) or text)


def _last_periods(n: int, sample_rate: float, fe: float, periods: float) -> slice:
    """The last ``periods`` excitation periods of an ``n``-sample record (all of it if shorter)."""
    m = round(periods * sample_rate / fe)
    return slice(max(n - m, 0), n)


def _mark_harmonics(ax, fe: float, k_max: int, f_max: float, size: float, **label: str) -> None:
    """``k fe`` (k = 1..k_max, up to ``f_max``) marked by ticks along the top edge of ``ax``."""
    harmonics = fe * np.arange(1, k_max + 1)
    harmonics = harmonics[harmonics <= f_max]
    ax.plot(
        harmonics,
        np.ones_like(harmonics),
        ls="none",
        marker="v",
        ms=size,
        color="0.35",
        transform=ax.get_xaxis_transform(),
        clip_on=False,
        **label,
    )


def _spectrum_axes(
    ax,
    freqs: np.ndarray,
    amplitude: np.ndarray,
    fe: float,
    k_max: int,
    f_max: float,
    natural_hz: np.ndarray | None,
    ylabel: str,
    color: str = "C0",
) -> None:
    """A log-amplitude spectrum with k*fe marked by ticks along the top edge and natural
    frequencies by labelled dashed lines."""
    keep = freqs <= f_max
    ax.semilogy(freqs[keep], amplitude[keep], color=color, lw=0.9, label="spectrum")
    # unlabelled minor ticks of eight decades: a third of the drawing time, no information
    ax.yaxis.set_minor_locator(NullLocator())
    ax.yaxis.set_major_formatter(FuncFormatter(power_label))
    top = float(np.max(amplitude[keep][1:])) if np.count_nonzero(keep) > 1 else 1.0
    top = top if top > 0 else 1.0
    ax.set_ylim(top * SPECTRUM_FLOOR, top * 3.0)
    ax.set_xlim(0.0, f_max)
    _mark_harmonics(ax, fe, k_max, f_max, 4, label=f"k·fe (fe = {fe:g} Hz)")
    if natural_hz is not None:
        shown = [f for f in np.asarray(natural_hz, dtype=float) if 0 < f <= f_max]
        for i, f in enumerate(shown):
            ax.axvline(
                f,
                color="C3",
                ls="--",
                lw=0.8,
                alpha=0.8,
                label="flexural natural frequencies" if i == 0 else None,
            )
            ax.text(
                f,
                0.93,
                f" {f:.0f} Hz",
                color="C3",
                fontsize=7,
                rotation=90,
                va="top",
                ha="right",
                transform=ax.get_xaxis_transform(),
            )
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")


def amplitude_frequency_figure(
    frequency_hz: np.ndarray,
    curves: Mapping[str, Mapping[str, Mapping[str, np.ndarray]]],
    *,
    force_amplitude: float | None = None,
    title: str = "",
) -> Figure:
    """Linear amplitude-frequency curves of both blades (the paper's Figure 7).

    Parameters
    ----------
    frequency_hz
        (n,) excitation frequencies, Hz.
    curves
        ``curves[model][quantity][location]`` -> (n,) peak amplitude, with ``model`` a label such
        as ``"FEM"`` or ``"AM"`` (the first model is drawn in colour, the others dashed black),
        ``quantity`` ``"displacement"`` (m) or ``"acceleration"`` (m/s²) and ``location`` one of
        ``"<blade>_shroud"``, ``"<blade>_force_point"`` for blade ``"active"``, ``"passive"``.
    force_amplitude
        F0, N, for the title.
    title
        Prefix of the figure title (e.g. the rig's name).

    Returns
    -------
    Figure
        2 x 2 axes: rows displacement (m), acceleration (m/s²); columns active, passive blade;
        log amplitude axes. Line order per axes: for each location (shroud, excitation point),
        each model in ``curves`` order.
    """
    fig = Figure(figsize=(12, 8), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True)
    f = np.asarray(frequency_hz, dtype=float)
    models = list(curves)
    rows = (
        ("displacement", "displacement, peak amplitude (m)"),
        ("acceleration", "acceleration, peak amplitude (m/s²)"),
    )
    for col, blade in enumerate(BLADES):
        for row, (quantity, ylabel) in enumerate(rows):
            ax = axes[row, col]
            for loc, color, marker in ((f"{blade}_shroud", "C0", "o"), (f"{blade}_force_point", "C1", "s")):
                where = "shroud" if loc.endswith("shroud") else "excitation point"
                for i, model in enumerate(models):
                    # the first model solid; the others dashed/dotted in the location's colour with
                    # open markers, so every curve is told apart in colour, line style and marker
                    style = (
                        dict(color=color, lw=1.4)
                        if i == 0
                        else dict(
                            color=color,
                            ls=("--", ":", "-.")[(i - 1) % 3],
                            lw=1.1,
                            marker=marker,
                            mfc="none",
                            ms=4,
                            markevery=max(1, f.size // 25),
                        )
                    )
                    ax.semilogy(f, curves[model][quantity][loc], label=f"{model}, {where}", **style)
            ax.set_ylabel(ylabel)
            ax.grid(True, which="both", alpha=0.3)
            if row == 0:
                ax.set_title(
                    f"{blade} blade" + (" (with force sensor)" if blade == "active" else " (no sensor)")
                )
            else:
                ax.set_xlabel("frequency (Hz)")
            ax.legend(fontsize=8)
    head = f"{title}: " if title else ""
    force = f" to F0 = {force_amplitude:g} N" if force_amplitude is not None else ""
    _suptitle(fig, f"{head}linear response{force}")
    return fig


def vibro_impact_figure(
    time: np.ndarray,
    active_displacement: np.ndarray,
    passive_displacement: np.ndarray,
    contact_force: np.ndarray,
    active_acceleration: np.ndarray,
    passive_acceleration: np.ndarray,
    fe: float,
    *,
    periods: float = 3.0,
    k_max: int = 30,
    gap: float | None = None,
    natural_frequencies_hz: Mapping[str, np.ndarray] | np.ndarray | None = None,
    window: str = "boxcar",
    title: str = "",
    force: np.ndarray | None = None,
) -> Figure:
    """One vibro-impact run in the style of the paper's Figure 9.

    Parameters
    ----------
    time
        (n,) uniformly spaced sample times, s.
    active_displacement, passive_displacement
        (n,) shroud displacements in the impact direction, m (plotted in mm).
    contact_force
        (n,) contact force between the shrouds, N.
    active_acceleration, passive_acceleration
        (n,) shroud accelerations, m/s²; their spectra use the whole record.
    fe
        Excitation frequency, Hz.
    periods
        How many of the last excitation periods the time histories show.
    k_max
        Harmonics ``k*fe``, k = 1..k_max, are marked; the spectra extend to ``(k_max + 1) * fe``
        (or the Nyquist frequency if lower).
    gap
        Shroud gap, m: drawn as the level the relative displacement must exceed, and in the title.
    natural_frequencies_hz
        Flexural natural frequencies (Hz) to mark: one array for both spectra, or
        ``{"active": ..., "passive": ...}`` per blade.
    window
        Spectrum window (:func:`rigtools.analysis.spectra.amplitude_spectrum`); ``"boxcar"`` is exact for a
        record of whole periods of a periodic response, use ``"flattop"`` otherwise.
    title
        Prefix of the figure title.
    force
        (n,) excitation force, N. When given, the time histories are drawn against the time from
        the upward zero crossing of its fundamental in ms (the reference of every other waveform
        plot: :func:`time_and_spectrum_figure`, :func:`overlay_figure`); otherwise against ``time``.

    Returns
    -------
    Figure
        Four axes, in ``fig.axes`` order: displacements (lines: active, passive, mm), contact
        force (N), active shroud acceleration spectrum, passive shroud acceleration spectrum
        (m/s², peak amplitude).
    """
    t = np.asarray(time, dtype=float)
    if t.size < 2:
        raise ValueError("need at least 2 samples")
    rate = 1.0 / float(t[1] - t[0])
    win: slice | np.ndarray = _last_periods(t.size, rate, fe, periods)  # or a mask, below
    t_label = "time (s)"
    if force is not None:
        w = _last_periods(t.size, rate, fe, periods + 1)
        t_ref = force_zero_crossing_time(np.asarray(force, dtype=float)[w], rate, fe, float(t[w.start]))
        t = (t - t_ref) * 1e3
        win = (t >= 0) & (t <= periods / fe * 1e3 * (1 + 1e-9))
        t_label = "time from the upward zero crossing of the force fundamental (ms)"
    # fixed margins instead of the constrained layout: the same look at half the drawing time
    # (the layout engine measures every text artist; this figure is drawn after every simulation)
    fig = Figure(figsize=(12, 9))
    grid = fig.add_gridspec(3, 2, left=0.07, right=0.98, top=0.91, bottom=0.06, hspace=0.38, wspace=0.2)
    ax_u = fig.add_subplot(grid[0, :])
    ax_f = fig.add_subplot(grid[1, :], sharex=ax_u)
    ax_sa = fig.add_subplot(grid[2, 0])
    ax_sp = fig.add_subplot(grid[2, 1], sharey=None)

    ax_u.plot(t[win], np.asarray(active_displacement)[win] * 1e3, color="C0", lw=1.2, label="active shroud")
    ax_u.plot(t[win], np.asarray(passive_displacement)[win] * 1e3, color="C1", lw=1.2, label="passive shroud")
    if gap is not None:
        # contact when u_active - u_passive > gap: show the active shroud's contact level
        # relative to the passive shroud
        ax_u.plot(
            t[win],
            (np.asarray(passive_displacement)[win] + gap) * 1e3,
            color="0.5",
            lw=0.8,
            ls=":",
            label="passive shroud + gap (contact above)",
        )
    ax_u.set_ylabel("displacement (mm)")
    ax_u.set_title("shroud displacements (impact direction)")
    ax_u.grid(True, alpha=0.3)
    ax_u.legend(fontsize=8, loc="upper right")
    ax_u.tick_params(labelbottom=False)

    ax_f.plot(t[win], np.asarray(contact_force)[win], color="C3", lw=1.2)
    ax_f.set_ylabel("contact force (N)")
    ax_f.set_xlabel(t_label)
    ax_f.set_title("contact force")
    ax_f.grid(True, alpha=0.3)

    f_max = min((k_max + 1) * fe, rate / 2)
    freqs, amp = amplitude_spectrum(np.vstack([active_acceleration, passive_acceleration]), rate, window)
    for ax, blade, row, color in ((ax_sa, "active", 0, "C0"), (ax_sp, "passive", 1, "C1")):
        natural = natural_frequencies_hz
        if isinstance(natural, Mapping):
            natural = natural.get(blade)
        _spectrum_axes(
            ax, freqs, amp[row], fe, k_max, f_max, natural, "acceleration, peak amplitude (m/s²)", color
        )
        ax.set_title(f"{blade} shroud acceleration spectrum")

    head = f"{title}: " if title else ""
    gap_text = f", gap {gap * 1e3:g} mm" if gap is not None else ""
    _suptitle(fig, f"{head}vibro-impact response, fe = {fe:g} Hz{gap_text}")
    return fig


def study_figure(
    kind: str,
    values: Sequence[float] | np.ndarray,
    directions: Sequence[str],
    peak_contact_force: Sequence[float] | np.ndarray,
    harmonics: Mapping[str, np.ndarray],
    *,
    fixed: Mapping[str, float] | None = None,
    title: str = "",
) -> Figure:
    """A gap, force or frequency study: peak contact force and shroud acceleration harmonics.

    Parameters
    ----------
    kind
        The swept parameter: ``"gap"`` (values in m, plotted in mm), ``"force"`` (N) or
        ``"frequency"`` (Hz).
    values, directions
        (p,) swept value (SI) and sweep direction (``"up"`` / ``"down"``) of each point, in run order.
    peak_contact_force
        (p,) peak contact force per point, N.
    harmonics
        ``{label: (p, k_max) array}``: peak amplitude of harmonic k = 1..k_max per point, m/s²
        (e.g. ``{"active shroud": ..., "passive shroud": ...}``), one heat map each.
    fixed
        The fixed parameters (``fe`` Hz, ``force`` N, ``gap`` m) for the title.
    title
        Prefix of the figure title.

    Returns
    -------
    Figure
        ``fig.axes``: the peak contact force axes first (one line per direction present, up then
        down, x in display units), then per ``harmonics`` entry its heat map (x: point in run
        order, y: k, colour: log amplitude) followed by its colour bar.
    """
    if kind not in STUDY_UNITS:
        raise ValueError(f"kind must be one of {', '.join(STUDY_UNITS)}, got {kind!r}")
    unit, scale = STUDY_UNITS[kind]
    x = np.asarray(values, dtype=float) * scale
    force = np.asarray(peak_contact_force, dtype=float)
    dirs = np.asarray(directions)
    n_maps = len(harmonics)
    fig = Figure(figsize=(11, 3.6 + 3.2 * n_maps), layout="constrained")
    grid = fig.add_gridspec(1 + n_maps, 1, height_ratios=[1.1] + [1.0] * n_maps)
    ax = fig.add_subplot(grid[0])
    styles: dict[str, dict[str, Any]] = {
        "up": dict(marker="o", ls="-", color="C0"),
        "down": dict(marker="s", ls="--", color="C3", mfc="none"),
    }
    for direction, style in styles.items():
        sel = dirs == direction
        if np.any(sel):
            arrow = "↑" if direction == "up" else "↓"
            ax.plot(x[sel], force[sel], label=f"sweep {direction} {arrow}", ms=5, **style)
    ax.set_xlabel(f"{kind} ({unit})")
    ax.set_ylabel("peak contact force (N)")
    ax.set_title(f"peak contact force versus {kind}")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)

    point_labels = [f"{v:.4g}{'↑' if d == 'up' else '↓'}" for v, d in zip(x, dirs, strict=True)]
    for i, (label, amp) in enumerate(harmonics.items()):
        amp = np.asarray(amp, dtype=float)
        k = np.arange(1, amp.shape[1] + 1)
        positive = amp[amp > 0]
        vmax = float(positive.max()) if positive.size else 1.0
        vmin = max(float(positive.min()) if positive.size else vmax, vmax * 1e-4)
        hm = fig.add_subplot(grid[1 + i])
        mesh = hm.pcolormesh(
            np.arange(len(x) + 1) - 0.5,
            np.append(k, k[-1] + 1) - 0.5,
            np.clip(amp.T, vmin, None),
            norm=LogNorm(vmin=vmin, vmax=vmax),
            cmap="viridis",
            shading="flat",
        )
        hm.set_ylabel("harmonic k (× fe)")
        hm.set_title(f"{label} acceleration harmonics")
        hm.set_yticks([1, *range(5, k[-1] + 1, 5)] if k[-1] >= 10 else list(k))
        ticks = np.unique(np.linspace(0, len(x) - 1, min(len(x), 16)).round().astype(int))
        hm.set_xticks(
            ticks, [point_labels[j] for j in ticks], fontsize=8, rotation=45 if len(ticks) > 8 else 0
        )
        hm.set_xlabel(f"{kind} ({unit}) in run order (↑ up, ↓ down sweep)")
        fig.colorbar(mesh, ax=hm, label="peak amplitude (m/s²)", pad=0.01)
    fixed_text = ""
    if fixed:
        parts = {
            "fe": lambda v: f"fe = {v:g} Hz",
            "force": lambda v: f"F0 = {v:g} N",
            "gap": lambda v: f"gap = {v * 1e3:g} mm",
        }
        fixed_text = " (" + ", ".join(parts[k](v) for k, v in fixed.items() if k in parts) + ")"
    head = f"{title}: " if title else ""
    _suptitle(fig, f"{head}{kind} study{fixed_text}")
    return fig


def time_and_spectrum_figure(
    channels: Mapping[str, np.ndarray],
    units: Mapping[str, str],
    sample_rate: float,
    fe: float,
    *,
    t0: float = 0.0,
    periods: float = 5.0,
    k_max: int = 30,
    window: str = "flattop",
    title: str = "",
    force_channel: str = FORCE,
) -> Figure:
    """A measured dwell: each channel's time history (last periods) and amplitude spectrum.

    Parameters
    ----------
    channels
        ``{name: (n,) samples}`` in the channel's units, all at ``sample_rate``.
    units
        ``{name: units}``, e.g. ``"N"``, ``"m/s^2"``, ``"V"`` (``^2`` is shown as ²).
    sample_rate
        Samples per second, Hz.
    fe
        Excitation frequency, Hz: the time histories show the last ``periods`` periods, the
        spectra (whole record) mark ``k*fe`` and extend to ``(k_max + 1) * fe`` (at most Nyquist).
    t0
        Time of the first sample, s (e.g. its position in the recording).
    window
        Spectrum window (:func:`rigtools.analysis.spectra.amplitude_spectrum`).
    title
        Prefix of the figure title.
    force_channel
        When ``channels`` holds it, every time history is drawn against the time from the first
        upward zero crossing of this channel's fundamental in the window shown, in ms (the time
        reference of :func:`overlay_figure`); otherwise against ``t0 + i / sample_rate`` in s.

    Returns
    -------
    Figure
        One row per channel: ``fig.axes[2 * i]`` its time history (one line, samples unscaled),
        ``fig.axes[2 * i + 1]`` its peak-amplitude spectrum (log axis).
    """
    names = list(channels)
    if not names:
        raise ValueError("need at least one channel")
    fig = Figure(figsize=(12, 2.4 * len(names) + 1.0), layout="constrained")
    axes = fig.subplots(len(names), 2, squeeze=False, width_ratios=[1.0, 1.2])
    f_max = min((k_max + 1) * fe, sample_rate / 2)
    t_ref, t_scale, t_label = 0.0, 1.0, "time (s)"
    if force_channel in channels:
        n_f = np.asarray(channels[force_channel]).size
        w = _last_periods(n_f, sample_rate, fe, periods + 1)
        t_ref = force_zero_crossing_time(
            np.asarray(channels[force_channel], dtype=float)[w], sample_rate, fe, t0 + w.start / sample_rate
        )
        t_scale, t_label = 1e3, "time from the upward zero crossing of the force fundamental (ms)"
    for i, name in enumerate(names):
        x = np.asarray(channels[name], dtype=float)
        unit = units[name].replace("^2", "²")
        t = (t0 + np.arange(x.size) / sample_rate - t_ref) * t_scale
        win: slice | np.ndarray = _last_periods(x.size, sample_rate, fe, periods)  # or a mask, below
        if force_channel in channels:
            win = (t >= 0) & (t <= periods / fe * t_scale * (1 + 1e-9))
        ax_t, ax_s = axes[i]
        ax_t.plot(t[win], x[win], color=f"C{i}", lw=1.0)
        ax_t.set_ylabel(f"{name} ({unit})")
        ax_t.grid(True, alpha=0.3)
        freqs, amp = amplitude_spectrum(x, sample_rate, window)
        _spectrum_axes(ax_s, freqs, amp, fe, k_max, f_max, None, f"peak amplitude ({unit})", f"C{i}")
        ax_s.set_title(name, fontsize=9)
        if i < len(names) - 1:
            ax_t.tick_params(labelbottom=False)
            ax_s.set_xlabel("")
            ax_s.tick_params(labelbottom=False)
        else:
            ax_t.set_xlabel(t_label)
    axes[0, 0].set_title(f"last {periods:g} periods", fontsize=9)
    head = f"{title}: " if title else ""
    _suptitle(fig, f"{head}sine dwell, fe = {fe:g} Hz ({x.size / sample_rate:g} s analysed)")
    return fig


# ---------------------------------------------------------------------------------------------
# Report figures: FRF, stabilisation chart, EM-vs-FEM harmonic bars, trends and overlays
# ---------------------------------------------------------------------------------------------

FRF_UNITS = {"receptance": "m/N", "mobility": "(m/s)/N", "accelerance": "(m/s²)/N"}
SOURCE_STYLES = {  # EM solid with filled markers, FEM dashed with open markers, AM dotted
    "EM": dict(color="C0", ls="-", marker="o", mfc="C0"),
    "FEM": dict(color="C3", ls="--", marker="s", mfc="none"),
    "AM": dict(color="C2", ls=":", marker="^", mfc="none"),
}


def _style(label: str, i: int) -> dict:
    return dict(SOURCE_STYLES.get(label, dict(color=f"C{i + 4}", ls="-.", marker="d", mfc="none")))


def frf_figure(
    frequency_hz: np.ndarray,
    frfs: Mapping[str, np.ndarray],
    *,
    coherence: Mapping[str, np.ndarray] | None = None,
    kind: str = "accelerance",
    natural_frequencies_hz: Sequence[float] | None = None,
    title: str = "",
) -> Figure:
    """FRF magnitude and phase, with the coherence below.

    Parameters
    ----------
    frequency_hz
        (n,) grid, Hz.
    frfs
        ``{label: (n,) complex FRF}`` in ``kind`` units, e.g. ``{"H1": ..., "H2": ...}`` or
        ``{"EM": ..., "FEM": ...}``; one line each, in order.
    coherence
        ``{label: (n,) coherence}`` (0..1), drawn in the bottom axes.
    kind
        ``"receptance"`` (m/N), ``"mobility"`` ((m/s)/N) or ``"accelerance"`` ((m/s²)/N).
    natural_frequencies_hz
        Identified natural frequencies to mark (dashed vertical lines).
    title
        Figure title.

    Returns
    -------
    Figure
        ``fig.axes``: magnitude (log), phase (degrees), coherence (if given); x shared.
    """
    if kind not in FRF_UNITS:
        raise ValueError(f"kind must be one of {', '.join(FRF_UNITS)}, got {kind!r}")
    f = np.asarray(frequency_hz, dtype=float)
    rows = 3 if coherence else 2
    fig = Figure(figsize=(11, 3.0 * rows + 0.8), layout="constrained")
    axes = fig.subplots(rows, 1, sharex=True, height_ratios=[2.0, 1.2, 1.0][:rows])
    ax_m, ax_p = axes[0], axes[1]
    styles = ("-", "--", ":", "-.")
    for i, (label, h) in enumerate(frfs.items()):
        h = np.asarray(h)
        ls = styles[i % len(styles)]
        ax_m.semilogy(f, np.abs(h), ls=ls, lw=1.1, color=f"C{i}", label=label)
        ax_p.plot(f, np.degrees(np.angle(h)), ls=ls, lw=1.0, color=f"C{i}", label=label)
    ax_m.set_ylabel(f"{kind} magnitude ({FRF_UNITS[kind]})")
    ax_p.set_ylabel("phase (degrees)")
    ax_p.set_ylim(-180, 180)
    ax_p.set_yticks([-180, -90, 0, 90, 180])
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    if natural_frequencies_hz is not None:
        for j, fn in enumerate(natural_frequencies_hz):
            for ax in axes:
                ax.axvline(
                    fn,
                    color="0.4",
                    ls="--",
                    lw=0.8,
                    label=("identified natural frequencies" if j == 0 and ax is ax_m else None),
                )
            ax_m.text(
                fn,
                0.98,
                f" {fn:.1f} Hz",
                rotation=90,
                va="top",
                ha="right",
                fontsize=7,
                transform=ax_m.get_xaxis_transform(),
            )
    ax_m.legend(fontsize=8)
    if len(frfs) > 1:
        ax_p.legend(fontsize=7, loc="lower left")
    if coherence:
        ax_c = axes[2]
        for i, (label, c) in enumerate(coherence.items()):
            ax_c.plot(
                f,
                np.asarray(c),
                lw=1.0,
                color=f"C{i}",
                ls=styles[i % len(styles)],
                label=f"coherence {label}",
            )
        ax_c.set_ylim(0, 1.05)
        ax_c.set_ylabel("coherence (-)")
        ax_c.legend(fontsize=8)
    axes[-1].set_xlabel("frequency (Hz)")
    _suptitle(fig, title or f"frequency response ({kind})")
    return fig


def stabilisation_figure(
    chart,
    frequency_hz: np.ndarray,
    h: np.ndarray,
    *,
    natural_frequencies_hz: Sequence[float] | None = None,
    title: str = "",
    kind: str = "accelerance",
) -> Figure:
    """Stabilisation chart: LSCF poles per model order over ``|H|``, the selection marked.

    ``kind`` names the FRF's kind and so the units of its right axis (:data:`FRF_UNITS`).

    ``chart`` is a :class:`rigtools.analysis.stabilisation.StabilisationChart`. Unstable poles are
    open, stable ones filled; the poles that make the reported modes (``chart.mode``) are drawn
    as "pole of a reported mode", the converged orders judged (``chart.judged``) shaded, and each
    of ``natural_frequencies_hz`` as a dashed line. ``fig.axes[0]`` holds the poles (left axis:
    model order), ``fig.axes[1]`` the FRF magnitude (right axis, log).
    """
    fig = Figure(figsize=(11, 5), layout="constrained")
    ax = fig.add_subplot()
    st = np.asarray(chart.stable, bool)
    kept = np.zeros_like(st) if chart.mode is None else np.asarray(chart.mode) >= 0
    lo, hi = chart.judged
    if hi > 0:
        ax.axhspan(lo - 1, hi + 1, color="0.92", zorder=0, label=f"orders judged ({lo}-{hi})")
    ax.plot(chart.frequency_hz[~st], chart.orders[~st], "o", ms=3, mfc="none", color="0.6", label="pole")
    ax.plot(
        chart.frequency_hz[st & ~kept],
        chart.orders[st & ~kept],
        "o",
        ms=3,
        color="C0",
        label="stable pole (frequency and damping)",
    )
    ax.plot(
        chart.frequency_hz[kept], chart.orders[kept], "o", ms=4, color="C3", label="pole of a reported mode"
    )
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("model order (-)")
    ax2 = ax.twinx()
    ax2.semilogy(frequency_hz, np.abs(h), color="k", lw=0.8, label="|H|")
    if kind not in FRF_UNITS:
        raise ValueError(f"kind must be one of {', '.join(FRF_UNITS)}, got {kind!r}")
    ax2.set_ylabel(f"|H|, {kind} ({FRF_UNITS[kind]})")
    if natural_frequencies_hz is not None:
        for j, fn in enumerate(natural_frequencies_hz):
            ax.axvline(fn, color="C3", ls="--", lw=0.9, label="identified mode" if j == 0 else None)
    ax.legend(fontsize=8, loc="upper left")
    _suptitle(fig, title or "stabilisation chart (LSCF)")
    return fig


def log_bar_axis(ax, heights: Sequence[np.ndarray] | np.ndarray) -> bool:
    """Put the bars of ``heights`` (every bar drawn on ``ax``) on a log y axis, limits a third of
    the smallest positive height to ten times the largest (room for the legend).

    Matplotlib's autoscaling of a log axis warns and draws a meaningless range when every bar has
    one height (a run without contact compared with its model: k = 1 alone, equal on both sides)
    or none is positive (all harmonics zero); the limits are set here before the scale, so it
    never autoscales. Without a positive finite height the axis stays linear, 0 to 1, and says
    "all harmonics zero".

    Returns
    -------
    bool
        True if the axis is logarithmic.
    """
    values = np.concatenate([np.ravel(np.asarray(h, dtype=float)) for h in heights] + [np.empty(0)])
    positive = values[np.isfinite(values) & (values > 0)]
    if positive.size == 0:
        ax.set_ylim(0.0, 1.0)
        ax.text(0.5, 0.5, "all harmonics zero", transform=ax.transAxes, ha="center", va="center")
        return False
    ax.set_ylim(float(positive.min()) / 3.0, float(positive.max()) * 10.0)  # room for the legend
    ax.set_yscale("log")
    return True


def harmonic_bars_figure(
    em: Mapping[str, np.ndarray],
    fem: Mapping[str, np.ndarray],
    units: Mapping[str, str],
    fe: float,
    *,
    k_max: int = 30,
    model_label: str = "FEM",
    title: str = "",
) -> Figure:
    """Harmonic amplitudes EM versus a model as grouped bars, one axes per channel.

    Parameters
    ----------
    em, fem
        ``{channel: (K,) peak amplitudes of k = 1..K}``; channels in ``em`` order, those in both.
    units
        ``{channel: unit}`` (``"N"``, ``"m/s^2"``).
    fe
        Excitation frequency, Hz (for the title and the secondary labels).
    k_max
        Harmonics shown.
    model_label
        Legend label of the model bars.

    Returns
    -------
    Figure
        One axes per channel: ``patches`` hold EM's bars first (k = 1..K) then the model's.
    """
    channels = [c for c in em if c in fem]
    if not channels:
        raise ValueError("no channel present in both em and fem")
    fig = Figure(figsize=(12, 2.8 * len(channels) + 0.8), layout="constrained")
    axes = fig.subplots(len(channels), 1, squeeze=False)[:, 0]
    for ax, ch in zip(axes, channels, strict=True):
        a = without_round_off(em[ch])[:k_max]  # a zero harmonic's round-off is no bar on a log axis
        b = without_round_off(fem[ch])[:k_max]
        n = min(a.size, b.size)
        k = np.arange(1, n + 1)
        ax.bar(k - 0.2, a[:n], width=0.4, color="C0", label="EM (experiment)")
        ax.bar(
            k + 0.2, b[:n], width=0.4, color="C3", alpha=0.8, label=model_label, hatch="//", edgecolor="C3"
        )
        log_bar_axis(ax, [a[:n], b[:n]])
        unit = units.get(ch, "").replace("^2", "²")
        ax.set_ylabel(f"peak amplitude ({unit})")
        ax.set_title(ch.replace("_", " "), fontsize=9)
        ax.set_xticks(k[:: max(1, n // 15)] if n > 15 else k)
        ax.grid(True, axis="y", which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    axes[-1].set_xlabel(f"harmonic order k (frequency k·fe, fe = {fe:g} Hz)")
    _suptitle(fig, title or f"harmonic amplitudes, EM versus {model_label}")
    return fig


def trend_figure(
    kind: str,
    quantities: Mapping[str, Mapping[str, tuple[np.ndarray, np.ndarray]]],
    units: Mapping[str, str],
    *,
    title: str = "",
) -> Figure:
    """Trends of a study with EM and the models on the same axes (one axes per quantity).

    Parameters
    ----------
    kind
        Swept parameter: ``"gap"`` (m, shown in mm), ``"force"`` (N) or ``"frequency"`` (Hz).
    quantities
        ``{quantity label: {source: (values, y)}}`` with ``source`` ``"EM"``, ``"FEM"``, ``"AM"``
        (or any label) and ``values`` the swept value (SI) of each point, e.g.
        ``{"peak force-sensor signal": {"EM": (gaps, f_em), "FEM": (gaps, f_fem)},
        "active shroud 6·fe": {...}}``. Quantities are peak values.
    units
        ``{quantity label: unit}``.

    Returns
    -------
    Figure
        One axes per quantity, one line per source in the given order, x in display units.
    """
    if kind not in STUDY_UNITS:
        raise ValueError(f"kind must be one of {', '.join(STUDY_UNITS)}, got {kind!r}")
    unit_x, scale = STUDY_UNITS[kind]
    names = list(quantities)
    cols = 2 if len(names) > 1 else 1
    rows = int(np.ceil(len(names) / cols))
    fig = Figure(figsize=(6.0 * cols, 3.2 * rows + 0.8), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False).ravel())
    for ax, name in zip(axes[: len(names)], names, strict=True):  # a grid cell left over is hidden below
        for i, (src, (x, y)) in enumerate(quantities[name].items()):
            x = np.asarray(x, dtype=float) * scale
            order = np.argsort(x, kind="stable")
            ax.plot(x[order], np.asarray(y, dtype=float)[order], ms=5, lw=1.2, label=src, **_style(src, i))
        unit = units.get(name, "").replace("^2", "²")
        ax.set_ylabel(f"{name}, peak ({unit})")
        ax.set_xlabel(f"{kind} ({unit_x})")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    _suptitle(fig, title or f"{kind} study: experiment (EM) and models")
    return fig


def force_zero_crossing_time(force: np.ndarray, sample_rate: float, fe: float, t0: float = 0.0) -> float:
    """Time (s, on the record's clock starting at ``t0``) of the first upward zero crossing of the
    force's fundamental at or after ``t0``: the common time origin of waveform overlays."""
    fit = harmonic_amplitudes(np.asarray(force, dtype=float), sample_rate, fe, 1)
    # F1 cos(w (t - t0) + phi): upward zero crossing where w (t - t0) + phi = -pi/2 (mod 2 pi)
    return t0 + float(np.mod(-np.pi / 2 - fit.phase[0], 2 * np.pi)) / (2 * np.pi * fe)


def overlay_figure(
    em: Mapping[str, np.ndarray],
    fem: Mapping[str, np.ndarray],
    units: Mapping[str, str],
    fe: float,
    *,
    em_rate: float,
    fem_rate: float,
    periods: float = 3.0,
    k_max: int = 30,
    force_channel: str = FORCE,
    window: str = "flattop",
    model_label: str = "FEM",
    title: str = "",
) -> Figure:
    """EM and model waveforms and spectra overlaid, in the layout of the paper's Figures 8-16.

    Rows: one per channel present in both (e.g. force, active shroud acceleration, passive shroud
    acceleration). Left: waveforms over ``periods`` periods; both sides share one time reference,
    ``t = 0`` at an upward zero crossing of each side's own force fundamental
    (:func:`force_zero_crossing_time`), so a phase difference between EM and model shows.
    Right: peak-amplitude spectra (``window``, whole record) on a log axis with ``k fe`` marked.

    Parameters
    ----------
    em, fem
        ``{channel: (n,) samples}``; each side must hold ``force_channel``.
    units
        ``{channel: unit}``.
    fe
        Excitation frequency, Hz.
    em_rate, fem_rate
        Sample rates of the two sides, Hz (they may differ).

    Returns
    -------
    Figure
        ``fig.axes[2 i]`` waveform axes of channel ``i`` (lines: EM, model),
        ``fig.axes[2 i + 1]`` its spectrum axes (lines: EM, model).
    """
    channels = [c for c in em if c in fem]
    if force_channel not in em or force_channel not in fem:
        raise ValueError(f"both sides need the {force_channel!r} channel for the common time reference")
    fig = Figure(figsize=(13, 2.8 * len(channels) + 1.0), layout="constrained")
    axes = fig.subplots(len(channels), 2, squeeze=False, width_ratios=[1.0, 1.2])
    f_max = min((k_max + 1) * fe, em_rate / 2, fem_rate / 2)
    window_s = periods / fe
    sides = []
    for label, data, rate, style in (
        ("EM", em, em_rate, dict(color="C0", lw=1.2, ls="-")),
        (model_label, fem, fem_rate, dict(color="C3", lw=1.1, ls="--")),
    ):
        n = np.asarray(data[force_channel]).size
        # reference in the last part of the record (settled), leaving room for the window
        start = max(n - int(np.ceil((periods + 1) * rate / fe)), 0)
        t_ref = force_zero_crossing_time(np.asarray(data[force_channel])[start:], rate, fe, start / rate)
        sides.append((label, data, rate, style, t_ref))
    for i, ch in enumerate(channels):
        ax_t, ax_s = axes[i]
        unit = units.get(ch, "").replace("^2", "²")
        for label, data, rate, style, t_ref in sides:
            x = np.asarray(data[ch], dtype=float)
            t = np.arange(x.size) / rate - t_ref
            sel = (t >= 0) & (t <= window_s)
            ax_t.plot(t[sel] * 1e3, x[sel], label=label, **style)
            freqs, amp = amplitude_spectrum(x, rate, window)
            keep = freqs <= f_max
            ax_s.semilogy(freqs[keep], amp[keep], label=label, **{**style, "lw": 0.9})
        ax_t.set_ylabel(f"{ch.replace('_', ' ')} ({unit})")
        ax_s.set_ylabel(f"peak amplitude ({unit})")
        ax_s.set_xlim(0, f_max)
        top = max(float(np.max(line.get_ydata()[1:])) for line in ax_s.lines)
        if top > 0:
            ax_s.set_ylim(top * SPECTRUM_FLOOR, top * 3.0)
        for ax in (ax_t, ax_s):
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=7, loc="upper right")
        _mark_harmonics(ax_s, fe, k_max, f_max, 3)
    axes[-1, 0].set_xlabel("time from the upward zero crossing of the force fundamental (ms)")
    axes[-1, 1].set_xlabel(f"frequency (Hz); ▼ marks k·fe, fe = {fe:g} Hz")
    _suptitle(fig, title or f"EM versus {model_label}: waveforms and spectra, fe = {fe:g} Hz")
    return fig
