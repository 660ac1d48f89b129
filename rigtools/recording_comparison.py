"""Experiment (EM) versus model (FEM or AM) from recordings: what ``rig compare`` and the report show.

:func:`compare_recordings` reads an EM recording (``rig acquire``), pairs each of its points by
meaning (fe, gap, force target; :mod:`rigtools.vocabulary` names) with a point of a model
recording (``rig simulate`` / ``rig study``) or with a model run made at the EM point
(``simulate=True``), and returns a :class:`Comparison`: per point the harmonic tables of every
channel with differences in percent, one agreement score, the natural-frequency offset that
explains each large harmonic difference; natural-frequency tables (FEM, AM, EM); the study
trends and the waveform/spectrum overlays as figures.

EM points are analysed on their settled window ``[record_start, record_start + record_samples)``
(the rest of a point's stream is control and settling). Model points are settled records; the
model's shroud-acceleration harmonics are taken from its velocity (``k w |V_k|``, exact for a
periodic response, :data:`rigtools.simulation.HARMONIC_SOURCES`).

Simulating the EM points (``simulate=True``): the model runs at each EM point's fe and gap and at
the force the blade felt there:

* ``excitation="measured"``: the harmonics k = 1..K (amplitude and phase) of the EM force over
  its settled window drive the model (:func:`rigtools.sim.vibro_impact.run_harmonic`'s
  ``force_harmonics``), so every harmonic the blade felt is applied;
* ``excitation="nominal"``: ``F0 sin`` with ``F0`` the EM force fundamental.

Runs go through :class:`rigtools.study_runner.StudyRunner` (in-process by default; ``workers``
for a Dask LocalCluster), carrying the state from point to point when the EM study did.

Agreement score (one per point): :func:`rigtools.analysis.correlation.agreement_score` of the two shroud
accelerations' harmonics k = 1..K, ``score = 10 ** (-E)`` with ``E`` the energy-weighted mean
``|log10(model / EM)|`` over harmonics, averaged over the two channels; 1 is identical, ``1/q``
when every harmonic is off by a factor ``q``. The force is the input and is left out of the
score (its table is still shown): a model driven by the measured force reproduces it by
construction, which would flatter that excitation.

What the excitation changes, on the simulated rig (15 N, gaps 0.3/0.6/0.9 mm; tests/rigtools/
test_compare.py): at 65 Hz the measured force (5·fe harmonic about 5 N) lifts the mean score from
0.831 (nominal) to 0.951. At 60 Hz it does not (0.611 measured, 0.619 nominal): 6·fe = 360 Hz lies
0.5 % below the FEM's 2nd active mode (361.9 Hz) and 1.2 % above the rig's (355.6 Hz), so the
measured force's 1.2-1.6 N 6·fe harmonic drives the FEM near its resonance and its 6·fe grows to
x2.9-4.7 of EM's, while the 5·fe gets right (x0.94 instead of x0.16). The explanation lines say so.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rigtools.analysis.correlation import (
    explain_large_differences,
    harmonic_table,
    point_agreement,
    trend_series,
)
from rigtools.comparison_modes import explanation_text, matched_modes, model_mode
from rigtools.comparison_points import COMPARED, K_MAX, SCORED
from rigtools.comparison_runs import Progress
from rigtools.comparison_sides import (
    EmSide,
    Item,
    model_system,
    no_pairs_error,
    read_em_side,
    recorded_side,
    simulated_side,
)
from rigtools.errors import UserError, option
from rigtools.readable import FREQUENCY_TABLE, HARMONIC_PCT, SCORE, Shown, harmonic, largest, shown
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL as ACTIVE
from rigtools.sim.channel_names import PASSIVE_SHROUD_ACCEL as PASSIVE
from rigtools.vocabulary import CHANNELS

LARGE_DIFF_PCT = 30.0

# ------------------------------------------------------------------------------ results


@dataclass
class PointComparison:
    """One EM point beside its model point.

    Attributes
    ----------
    em_index, model_index
        Point indices in the EM recording and in the model recording (or the run order).
    params
        The EM point's parameters (vocabulary names, SI): fe, gap, force_amplitude (target),
        force_amplitude_measured, study_value, settled.
    model_params
        fe, gap, force_amplitude (nominal F0), force_amplitude_measured, settled of the model point.
    em, model
        :class:`rigtools.analysis.point.DwellAnalysis` of both sides.
    table
        :func:`rigtools.analysis.correlation.harmonic_table` of the compared channels (pandas DataFrame).
    agreement
        :class:`rigtools.analysis.correlation.Agreement` of the shroud accelerations.
    explanations
        ``[(channel, FrequencyOffsetExplanation, (blade, mode, model Hz) or None)]`` for the large
        harmonic differences (text: :meth:`explanation_lines`).
    em_wave, model_wave
        ``{channel: samples}`` of the analysed windows (for overlays); rates in
        ``em_rate``, ``model_rate``.
    """

    em_index: int
    model_index: int
    params: dict
    model_params: dict
    em: Any
    model: Any
    table: Any
    agreement: Any
    explanations: list
    em_wave: dict = field(repr=False, default_factory=dict)
    model_wave: dict = field(repr=False, default_factory=dict)
    em_rate: float = 0.0
    model_rate: float = 0.0

    @property
    def score(self) -> float:
        return self.agreement.score

    def label(self) -> str:
        p = self.params
        return (
            f"point {self.em_index}: fe {p['fe']:g} Hz, F0 {p.get('force_amplitude', float('nan')):g} N, "
            f"gap {p.get('gap', float('nan')) * 1e3:g} mm"
        )

    def to_dict(self) -> dict:
        return {
            "em_index": self.em_index,
            "model_index": self.model_index,
            "params": _plain(self.params),
            "model_params": _plain(self.model_params),
            "agreement": {
                "score": self.agreement.score,
                "error_decades": self.agreement.error_decades,
                "per_channel": self.agreement.per_channel,
                "channels": list(SCORED),
            },
            "harmonics": _records(self.table),
            "peaks": {"em": self.em.peak_levels, "model": self.model.peak_levels},
            "explanations": [
                {
                    "channel": ch,
                    "k": e.k,
                    "model_mode": None if m is None else {"blade": m[0], "mode": m[1], "model_hz": m[2]},
                    "frequency_hz": e.frequency_hz,
                    "natural_hz_em": e.natural_hz,
                    "observed_ratio": e.observed_ratio,
                    "ratio_for_plus_minus_1pct": list(e.ratio_per_percent),
                    "ratio_from_model_frequency": _f(e.ratio_from_model_frequency),
                    "offset_pct_needed": _f(e.offset_pct_needed),
                    "text": explanation_text(ch, e, m, self.model_params.get("model_label", "model")),
                }
                for ch, e, m in self.explanations
            ],
        }

    def explanation_lines(self, model_label: str) -> list[str]:
        """:func:`~rigtools.comparison_modes.explanation_text` of every large harmonic difference."""
        return [explanation_text(ch, e, m, model_label) for ch, e, m in self.explanations]


@dataclass
class Comparison:
    """Result of :func:`compare_recordings`.

    Attributes
    ----------
    em_path
        The EM recording.
    model_source
        The model recording's path, or ``"simulated"``.
    model, excitation
        ``"fem"``/``"am"``; ``"measured"``/``"nominal"`` (``None`` for a model recording).
    kind
        The swept parameter of the EM study (``"gap"``, ``"force"``, ``"frequency"``) or None.
    points
        :class:`PointComparison` in EM order.
    natural
        Natural-frequency table (:func:`rigtools.analysis.correlation.natural_frequency_table` layout with the EM
        column filled where measured), or None.
    notes
        Sentences on what could not be compared and why.
    unpaired
        EM point indices with no model point.
    em_frf
        The FRF point the EM natural frequencies come from, as ``rig analyze --json`` shows it
        (:func:`~rigtools.comparison_modes.em_modes_from_frf`), or None.
    """

    em_path: str
    model_source: str
    model: str
    excitation: str | None
    kind: str | None
    points: list[PointComparison]
    natural: Any
    notes: list[str]
    unpaired: list[int] = field(default_factory=list)
    em_frf: dict | None = None

    @property
    def mean_score(self) -> float:
        """Mean of the points' agreement scores (NaN without points)."""
        return float(np.mean([p.score for p in self.points])) if self.points else float("nan")

    @property
    def model_label(self) -> str:
        return self.model.upper()

    def to_dict(self) -> dict:
        """Plain-Python result for ``--json``."""
        return {
            "em": self.em_path,
            "model_source": self.model_source,
            "model": self.model,
            "excitation": self.excitation,
            "study_kind": self.kind,
            "amplitude": "peak",
            "score_definition": (
                "10**(-E), E = energy-weighted mean |log10(model/EM)| of the harmonics "
                "k = 1..K of active_shroud_accel and passive_shroud_accel, averaged "
                "over both channels"
            ),
            "mean_score": self.mean_score,
            "natural_frequencies": None if self.natural is None else _records(self.natural),
            "em_frf": self.em_frf,
            "notes": list(self.notes),
            "unpaired_em_points": list(self.unpaired),
            "points": [p.to_dict() for p in self.points],
        }

    # -------------------------------------------------------------- figures
    def trend_quantities(self) -> dict:
        """``{label: {"EM": (values, y), model: (values, y)}}`` of :func:`rigtools.analysis.correlation.trend_series`."""
        if self.kind is None or len(self.points) < 2:
            return {}
        values = np.array([_swept_value(p.params, self.kind) for p in self.points])
        em = trend_series([p.em for p in self.points])
        mo = trend_series([p.model for p in self.points])
        return {key: {"EM": (values, em[key]), self.model_label: (values, mo[key])} for key in em}

    def figures(self) -> list[tuple[str, Any, str]]:
        """``[(name, matplotlib Figure, caption)]``: the study trends (if a study) and, per point,
        the waveform/spectrum overlay and the harmonic bars."""
        from rigtools.analysis.plots import harmonic_bars_figure, overlay_figure, trend_figure

        out = []
        q = self.trend_quantities()
        if q and self.kind is not None:
            units = {key: ("N" if key.startswith("peak force") else "m/s²") for key in q}
            fig = trend_figure(self.kind, q, units, title=f"EM vs {self.model_label}: {self.kind} study")
            out.append(
                (
                    "trends",
                    fig,
                    (
                        f"EM and {self.model_label} against {self.kind}: peak force-sensor "
                        "signal, peak shroud accelerations and the 6·fe, 8·fe, 22·fe amplitudes (peak)"
                    ),
                )
            )
        units = {c: CHANNELS[c].units.replace("^2", "²") for c in COMPARED}
        for p in self.points:
            fig = overlay_figure(
                {c: p.em_wave[c] for c in COMPARED if c in p.em_wave},
                {c: p.model_wave[c] for c in COMPARED if c in p.model_wave},
                units,
                p.params["fe"],
                em_rate=p.em_rate,
                fem_rate=p.model_rate,
                model_label=self.model_label,
                title=f"{p.label()}: EM vs {self.model_label}",
            )
            out.append(
                (
                    f"point-{p.em_index}-overlay",
                    fig,
                    f"{p.label()}: waveforms (t = 0 at each side's force zero crossing) and peak spectra",
                )
            )
            em_h = {c: p.em.harmonics[c].amplitude for c in COMPARED if c in p.em.harmonics}
            mo_h = {c: p.model.harmonics[c].amplitude for c in COMPARED if c in p.model.harmonics}
            fig = harmonic_bars_figure(
                em_h,
                mo_h,
                units,
                p.params["fe"],
                model_label=self.model_label,
                title=f"{p.label()}: harmonic amplitudes (peak)",
            )
            out.append((f"point-{p.em_index}-harmonics", fig, f"{p.label()}: harmonic amplitudes k·fe, peak"))
        return out

    def save_figures(self, out_dir: str | Path) -> list[Path]:
        """Write :meth:`figures` as PNG into ``out_dir`` (created), named
        ``EMSTEM.compare-NAME.png``; never over a recording or a file rigtools did not make."""
        from rigtools.figures import save_figures  # matplotlib

        stem = Path(self.em_path).stem
        return save_figures(
            ((name, fig) for name, fig, _ in self.figures()),
            out_dir,
            lambda name: f"{stem}.compare-{name}.png",
            source=self.em_path,
        )

    # -------------------------------------------------------------- report
    def add_to_report(self, report) -> None:
        """Add a section (tables, explanations, figures) to a :class:`rigtools.report.Report`."""
        sec = report.section(f"EM vs {self.model_label}: {Path(self.em_path).name}")
        how = (
            "model recording " + Path(self.model_source).name
            if self.excitation is None
            else f"{self.model_label} simulated at every EM point, {self.excitation} excitation"
        )
        sec.text(
            f"EM {self.em_path} against {how}. Amplitudes are peak values; differences are "
            "100 (model - EM) / EM. Agreement score per point: 10^-E, E the energy-weighted mean "
            "|log10(model/EM)| of the shroud accelerations' harmonics (1 = identical)."
        )
        for n in self.notes:
            sec.note(n)
        if self.natural is not None:
            heading = {
                "fem_hz": "FEM (Hz)",
                "am_hz": "AM (Hz)",
                "em_hz": "EM (Hz)",
                "fem_vs_em_pct": "FEM vs EM (%)",
                "am_vs_em_pct": "AM vs EM (%)",
                "am_vs_fem_pct": "AM vs FEM (%)",
            }
            spec = FREQUENCY_TABLE
            sec.table(
                [
                    {heading.get(k, k): shown(v, spec[k]) if k in spec else v for k, v in r.items()}
                    for r in self.natural.to_dict("records")
                ],
                caption="Natural frequencies, Hz, and differences in % (as the paper's Tables 2 and 3)",
            )
        sec.table(
            [
                {
                    "EM point": p.em_index,
                    "fe Hz": p.params["fe"],
                    "gap mm": p.params.get("gap", np.nan) * 1e3,
                    "F0 target N": p.params.get("force_amplitude"),
                    "F1 EM N": p.em.force_amplitude,
                    f"F1 {self.model_label} N": p.model.force_amplitude,
                    "score": shown(p.score, SCORE),
                    "active error (decades)": shown(p.agreement.per_channel.get(ACTIVE), SCORE),
                    "passive error (decades)": shown(p.agreement.per_channel.get(PASSIVE), SCORE),
                }
                for p in self.points
            ],
            caption=f"Agreement per point (mean {self.mean_score:.3f})",
        )
        for p in self.points:
            sec.table(
                _wide_table(p.table, self.model_label, k_show=12),
                caption=f"{p.label()}: harmonic amplitudes (peak) and differences in %",
            )
            for line in p.explanation_lines(self.model_label):
                sec.note(line)
        import matplotlib.pyplot as plt

        for _, fig, caption in self.figures():
            sec.figure(fig, caption)
            plt.close(fig)


# ------------------------------------------------------------------------------ helpers


def _f(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _plain(d: dict) -> dict:
    out: dict[str, Any] = {}
    for k, v in d.items():
        if isinstance(v, (np.floating, float)):
            out[k] = _f(v)
        elif isinstance(v, (np.integer,)):
            out[k] = int(v)
        elif isinstance(v, (np.bool_,)):
            out[k] = bool(v)
        elif isinstance(v, (str, int, bool)) or v is None:
            out[k] = v
    return out


def _records(frame) -> list[dict]:
    return [_plain(r) for r in frame.to_dict("records")]


def _wide_table(table, model_label: str, k_show: int = 12, extra_k: Sequence[int] = (22,)) -> list[dict]:
    """Rows k with EM, model and diff % of every channel side by side, written as the terminal's
    table writes them (:mod:`rigtools.readable`: a zero harmonic's round-off shown as such)."""
    rows = []
    tops = {
        (ch, side): largest(table.loc[table["channel"] == ch, side])
        for ch in set(table["channel"])
        for side in ("em", "fem")
    }
    ks = sorted({k for k in table["k"] if k <= k_show or k in extra_k})
    for k in ks:
        sub = table[table["k"] == k]
        row: dict[str, Any] = {"k": int(k), "f Hz": shown(sub["frequency_hz"].iloc[0], ".0f")}
        for r in sub.itertuples(index=False):
            short = r.channel.replace("_shroud_accel", "").replace("_", " ")
            row[f"{short} EM"] = Shown(harmonic(r.em, tops[(r.channel, "em")]))
            row[f"{short} {model_label}"] = Shown(harmonic(r.fem, tops[(r.channel, "fem")]))
            row[f"{short} diff %"] = shown(r.diff_pct, HARMONIC_PCT)
        rows.append(row)
    return rows


def _swept_value(params: dict, kind: str) -> float:
    key = {"gap": "gap", "force": "force_amplitude", "frequency": "fe"}[kind]
    return float(params.get(key, params.get("study_value", np.nan)))


def compare_recordings(
    em_path: str,
    fem_path: str | None = None,
    *,
    simulate: bool = False,
    model: str = "fem",
    excitation: str = "measured",
    rig: str | None = None,
    frf: str | None = None,
    k_max: int = K_MAX,
    workers: int | None = None,
    max_settle_time: float = 30.0,
    progress: Progress | None = None,
) -> Comparison:
    """Compare an EM recording with a model recording or with model runs at its points.

    Parameters
    ----------
    em_path
        EM recording (``rig acquire dwell|sweep|study``; FRF points in it feed the natural-frequency
        table).
    fem_path
        Model recording (``rig simulate`` / ``rig study``); excludes ``simulate``.
    simulate
        Run the model at every EM point (fe, gap and the force felt there; see the module docstring).
    model
        ``"fem"`` or ``"am"``: the model simulated (and labelled).
    excitation
        ``"measured"`` (the EM force's harmonics drive the model) or ``"nominal"`` (``F0 sin``).
    rig
        Rig file for the model; default: the rig description stored in the EM recording.
    frf
        An FRF recording (``rig acquire frf``) whose modes give the EM natural frequencies.
    k_max
        Harmonics compared, k = 1..k_max.
    workers
        Model runs on a Dask LocalCluster of this many workers (default in-process).
    progress
        ``progress(done, total, text)`` as model runs finish.
    """
    if model not in ("fem", "am"):
        raise UserError(f"{option('model')} must be fem or am, got {model!r}")
    if excitation not in ("measured", "nominal"):
        raise UserError(f"{option('excitation')} must be measured or nominal, got {excitation!r}")
    if simulate and fem_path is not None:
        raise UserError("give a model recording FEM.h5 or --simulate, not both")
    if not simulate and fem_path is None:
        raise UserError("give a model recording FEM.h5 to compare with, or --simulate")
    notes: list[str] = []
    em = read_em_side(em_path, frf, rig, k_max, notes)
    system, fn_model, natural = model_system(em.rig, model, em.modes)
    run_excitation: str | None = excitation  # None: the model side is a recording
    if fem_path is None:  # --simulate (checked above)
        model_items, pairs = simulated_side(
            system,
            em,
            excitation,
            k_max=k_max,
            workers=workers,
            max_settle_time=max_settle_time,
            progress=progress,
            notes=notes,
        )
        source = "simulated"
    else:
        model_items, pairs = recorded_side(fem_path, em.items, k_max=k_max, notes=notes)
        source = str(fem_path)
        run_excitation = None
    if not pairs:
        raise no_pairs_error(em_path, model_items)
    paired_em = {i for i, _ in pairs}
    unpaired = [em.items[i][0] for i in range(len(em.items)) if i not in paired_em]
    if unpaired:
        notes.append(f"EM points {unpaired} have no model point with the same fe, gap and force target (2 %)")
    if not em.modes:
        notes.append(
            "large harmonic differences are set against the model's own natural frequencies (no EM "
            "modes): the offset needed is stated, not the measured one"
        )
    points = [
        _compare_pair(em.items[i], model_items[j], em, system, fn_model, model=model, k_max=k_max)
        for i, j in pairs
    ]
    return Comparison(
        str(em_path), source, model, run_excitation, em.kind, points, natural, notes, unpaired, em.frf
    )


def _compare_pair(
    em_item: Item, model_item: Item, em: EmSide, system, fn_model: dict, *, model: str, k_max: int
) -> PointComparison:
    """One EM point beside its model point: harmonic table, agreement score and the explanations
    of its large harmonic differences."""
    idx, params, ana, waves, fs = em_item
    midx, mparams, mana, mwaves, mfs = model_item
    chans = [c for c in COMPARED if c in ana.harmonics and c in mana.harmonics]
    table = harmonic_table(
        {c: ana.harmonics[c].amplitude for c in chans},
        {c: mana.harmonics[c].amplitude for c in chans},
        params["fe"],
        k_max=k_max,
    )
    agreement = point_agreement(ana, mana, channels=[c for c in SCORED if c in chans], k_max=k_max)
    if em.modes:
        fn_e, z, fn_m = matched_modes(em.modes, em.zeta, fn_model)
        large = explain_large_differences(table, params["fe"], fn_e, z, fn_m, threshold_pct=LARGE_DIFF_PCT)
        expl = [(ch, e, model_mode(e.natural_hz, fn_e, fn_m, fn_model)) for ch, e in large]
    else:
        # no EM modes: the model's own natural frequencies, at the model's median damping
        zeta = {b: np.full(v.size, float(np.median(system.zeta))) for b, v in fn_model.items()}
        large = explain_large_differences(
            table, params["fe"], dict(fn_model), zeta, None, threshold_pct=LARGE_DIFF_PCT
        )
        expl = [(ch, e, None) for ch, e in large]
    mparams["model_label"] = model.upper()
    return PointComparison(
        idx, midx, _plain(params), _plain(mparams), ana, mana, table, agreement, expl, waves, mwaves, fs, mfs
    )
