"""Report sections and figures built from :class:`rigtools.recording_analysis.results.RecordingAnalysis`.

:func:`analysis_figures` makes the figures of one analysed recording (``rig analyze --out`` saves
them as PNG, :func:`add_analysis` embeds them in a :class:`rigtools.report.html.Report`):

- periodic points: waveforms (time from the upward zero crossing of the force fundamental, the
  same reference in every waveform plot) and peak-amplitude spectra with k·fe marked;
- stepped sines and studies: the first-harmonic FRF (magnitude and phase) over fe and the
  6·fe, 8·fe, 22·fe amplitudes against the swept value;
- broadband points: H1, H2, Hv magnitude and phase with the coherence, and the stabilisation
  chart of each response with identified modes.

Every amplitude is a peak amplitude and says so.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rigtools.readable import FREQUENCY_TABLE, shown
from rigtools.recording.schema import CONTROLLED_PROCEDURES
from rigtools.recording_analysis.results import TABLE_HARMONICS, RecordingAnalysis
from rigtools.recording_analysis.samples import point_window
from rigtools.report.branches import add_recording_branches, study_axis
from rigtools.report.controlled_branch import add_controlled_points

MAX_WAVEFORM_FIGURES = 4  # periodic points drawn as waveforms (first, last and between)
WAVEFORM_CHANNELS = ("force", "active_shroud_accel", "passive_shroud_accel", "contact_force")


@dataclass
class NamedFigure:
    """A figure with a file-name stem and a caption."""

    name: str
    figure: Any
    caption: str


def _pick(n: int, m: int) -> list[int]:
    if n <= m:
        return list(range(n))
    return sorted({round(i) for i in np.linspace(0, n - 1, m)})


def analysis_figures(
    analysis: RecordingAnalysis, *, max_waveforms: int = MAX_WAVEFORM_FIGURES
) -> list[NamedFigure]:
    """The figures of one analysed recording (see the module docstring)."""
    from rigtools.analysis.plots import (
        frf_figure,
        stabilisation_figure,
        time_and_spectrum_figure,
        trend_figure,
    )

    figs: list[NamedFigure] = []
    stem = Path(analysis.path).stem
    periodic = analysis.periodic
    for i in _pick(len(periodic), max_waveforms):
        p = periodic[i]
        point_fe = float(p.params["fe"])  # every periodic point has one
        data, rate, t0, units = point_window(analysis.path, p.index)
        data = {c: data[c] for c in WAVEFORM_CHANNELS if c in data and c in p.units} or data
        with warnings.catch_warnings():  # a channel at rest (passive blade, gap open) is all zero
            warnings.filterwarnings("ignore", "Data has no positive values")
            fig = time_and_spectrum_figure(
                data,
                {c: units[c] for c in data},
                rate,
                point_fe,
                t0=t0,
                k_max=min(30, int(rate / 2 / point_fe) - 1),
                title=f"{stem} point {p.index}",
            )
        figs.append(
            NamedFigure(
                f"point{p.index}-waveforms",
                fig,
                f"Point {p.index}: waveforms over the last periods (time from the upward zero "
                f"crossing of the force fundamental) and peak-amplitude spectra (flat-top "
                f"window, k·fe marked), fe = {point_fe:g} Hz.",
            )
        )
    curves = analysis.response_curves()
    axis = study_axis(analysis)
    if curves is not None and curves["frf"] and axis is not None and axis[0] == "frequency":
        order = np.argsort(curves["fe"], kind="stable")
        fe = curves["fe"][order]
        frfs = {f"X1/F1 {c.replace('_', ' ')}": h[order] for c, h in curves["frf"].items()}
        fig = frf_figure(
            fe, frfs, kind=analysis.frf_kind, title=f"{stem}: first-harmonic FRF over fe (stepped sine)"
        )
        for ax in fig.axes:
            for line in ax.lines:
                line.set_marker("o")
                line.set_markersize(3)
        figs.append(
            NamedFigure(
                "stepped-sine-frf",
                fig,
                f"Stepped sine: first-harmonic response over force X1/F1 as {analysis.frf_kind}, "
                "magnitude and phase, one marker per step.",
            )
        )
    if curves is not None and axis is not None:
        kind, values = axis
        direction = curves["direction"]
        quantities: dict[str, dict[str, tuple[np.ndarray, np.ndarray]]] = {}
        units = {}
        sources = {}
        for c, arr in curves["harmonics"].items():
            if c not in ("force", "active_shroud_accel", "passive_shroud_accel"):
                continue
            ks = (1,) if c == "force" else TABLE_HARMONICS
            for k in ks:
                if k > arr.shape[1]:
                    continue
                label = f"{c.replace('_', ' ')} {k}·fe"
                units[label] = curves["units"].get(c, "")
                quantities[label] = {}
                for d in dict.fromkeys(direction):
                    sel = np.array([x == d for x in direction])
                    name = (
                        f"{analysis.source.upper()} {d}"
                        if d and len(set(direction)) > 1
                        else analysis.source.upper()
                    )
                    quantities[label][name] = (values[sel], arr[sel, k - 1])
                    sources[name] = True
        if quantities:
            fig = trend_figure(kind, quantities, units, title=f"{stem}: harmonic amplitudes against {kind}")
            figs.append(
                NamedFigure(
                    "harmonic-trends",
                    fig,
                    f"Peak amplitudes of the force fundamental and of the shroud accelerations' "
                    f"{', '.join(f'{k}·fe' for k in TABLE_HARMONICS)} harmonics against {kind}, "
                    "one line per sweep direction.",
                )
            )
    for p in analysis.broadband:
        est = p.frf.estimate
        band = p._band()
        charts: list = []  # responses identified together share one chart: drawn once
        f = est.frequency_hz[band]
        for i, r in enumerate(p.frf.responses):
            m = p.frf.modes[r]
            fn = [x.frequency_hz for x in m.modes]
            frfs = {"H1": est.h1[i][band], "H2": est.h2[i][band], "Hv": est.hv[i][band]}
            fig = frf_figure(
                f,
                frfs,
                coherence={r.replace("_", " "): est.coherence[i][band]},
                kind=analysis.frf_kind,
                natural_frequencies_hz=fn or None,
                title=f"{stem} point {p.index}: {r.replace('_', ' ')} / force",
            )
            figs.append(
                NamedFigure(
                    f"point{p.index}-{r}-frf",
                    fig,
                    f"Point {p.index}: H1, H2 and Hv of {r} over the force as {analysis.frf_kind} "
                    f"(magnitude and phase), coherence below; {est.n_averages} averages, "
                    f"{est.resolution_hz:.3g} Hz resolution.",
                )
            )
            if m.chart is not None and len(m.chart.orders) and not any(m.chart is c for c in charts):
                charts.append(m.chart)
                shared = sum(p.frf.modes[x].chart is m.chart for x in p.frf.responses)
                of = f"the {shared} responses" if shared > 1 else r.replace("_", " ")
                fig = stabilisation_figure(
                    m.chart,
                    f,
                    np.abs(est.h1[i][band]),
                    natural_frequencies_hz=fn or None,
                    title=f"{stem} point {p.index}: stabilisation chart of {of}",
                    kind=analysis.frf_kind,
                )
                figs.append(
                    NamedFigure(
                        f"point{p.index}-{r}-stabilisation",
                        fig,
                        f"Point {p.index}: LSCF poles per model order of {of}, over |H1| of {r}; "
                        "filled: stable in frequency and damping; red: the poles of the reported "
                        "modes, judged over the shaded converged orders; dashed: the modes.",
                    )
                )
    return figs


def add_analysis(report, analysis: RecordingAnalysis, branches=()) -> None:
    """One section per recording: summary, tables, notes and figures; with ``branches``
    (:class:`rigtools.report.branches.BranchFile`), those continued in the recording's swept
    parameter drawn over its sweeps (:func:`rigtools.report.branches.add_recording_branches`)."""
    sec = report.section(f"{Path(analysis.path).name}: {analysis.procedure or 'recording'}")
    sec.text(
        f"Backend {analysis.backend} ({analysis.source.upper()}), status {analysis.status}, "
        f"{len(analysis.points)} point(s) analysed. Amplitudes are peak amplitudes; FRFs as "
        f"{analysis.frf_kind}."
    )
    for note in analysis.notes + analysis.skipped:
        sec.note(note)
    rows = analysis.point_rows()
    if rows:
        sec.table(rows, caption="Periodic points: force fundamental and shroud-acceleration harmonics (peak)")
        sec.note(
            "No modes from these points: a sine excites one frequency at a time "
            "(a broadband FRF test identifies modes)."
        )
    modes = analysis.mode_rows()
    if modes:
        sec.table(
            modes, caption="Identified modes per response (LSCF with stabilisation check, or peak picking)"
        )
    if analysis.frequency_table:
        cols = {
            "blade": "blade",
            "mode": "mode",
            "fem_hz": "FEM (Hz)",
            "am_hz": "AM (Hz)",
            "em_hz": "EM (Hz)",
            "fem_vs_em_pct": "FEM vs EM (%)",
            "am_vs_em_pct": "AM vs EM (%)",
            "article_hz": "simulated test article (Hz)",
            "em_vs_article_pct": "EM vs article (%)",
        }
        rows = [
            {
                t: shown(r[k], FREQUENCY_TABLE[k]) if k in FREQUENCY_TABLE else r[k]
                for k, t in cols.items()
                if k in r
            }
            for r in analysis.frequency_table
        ]
        sec.table(
            rows,
            caption="Flexural natural frequencies, FEM, AM and EM (identified), as the paper's "
            "Table 2; differences 100 (model - EM) / EM",
        )
    for p in analysis.broadband:
        for n in p.notes:
            sec.note(f"point {p.index}: {n}")
        if not any(p.frf.modes[r].modes for r in p.frf.responses):
            sec.note(f"point {p.index}: no mode identified from any response")
    for p in analysis.operational:
        _add_operational(sec, p)
    for nf in analysis_figures(analysis):
        sec.figure(nf.figure, nf.caption)
    if analysis.procedure in CONTROLLED_PROCEDURES:
        add_controlled_points(sec, analysis.path, list(branches))
    elif branches:
        add_recording_branches(sec, analysis, list(branches))


def _add_operational(sec, p) -> None:
    """A point without a force: its modes (operational modal analysis) and the harmonic tones
    flagged, each with its reason, then its notes."""
    oma = p.oma
    if oma is not None and oma.modes:
        rows = [
            {
                "mode": j + 1,
                "natural frequency (Hz)": m.frequency_hz,
                "spread (Hz)": m.frequency_spread_hz,
                "damping ratio (%)": 100 * m.damping_ratio,
                "spread (%)": 100 * m.damping_spread,
                "stable orders": f"{m.orders_stable}/{m.orders_judged}",
            }
            for j, m in enumerate(oma.modes)
        ]
        sec.table(
            rows,
            caption=f"Point {p.index}: modes without a force (SSI-cov, {oma.band[0]:.4g}-{oma.band[1]:.4g} Hz); "
            "spread: model orders and the record's statistical spread",
        )
    if oma is not None and oma.harmonics:
        sec.table(
            [{"harmonic (Hz)": h.frequency_hz, "why a tone, not a mode": h.reason} for h in oma.harmonics],
            caption=f"Point {p.index}: harmonic tones flagged (never modes)",
        )
    for n in p.notes:
        sec.note(f"point {p.index}: {n}")
