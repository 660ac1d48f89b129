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

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rigtools.errors import UserError, option
from rigtools.readable import FREQUENCY_TABLE, HARMONIC_PCT, SCORE, Shown, harmonic, largest, shown
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL as ACTIVE
from rigtools.sim.channel_names import FORCE, VELOCITY_OF
from rigtools.sim.channel_names import PASSIVE_SHROUD_ACCEL as PASSIVE
from rigtools.sim.studies import PlannedPoint
from rigtools.vocabulary import CHANNELS, MODEL_BACKENDS, current_parameters, excitation_frequency

COMPARED = (FORCE, ACTIVE, PASSIVE)
SCORED = (ACTIVE, PASSIVE)
K_MAX = 30
LARGE_DIFF_PCT = 30.0
MODEL_RECORD_PERIODS = 10
MAX_MODE_DAMPING = 0.1  # identified "modes" more damped than this are fit artefacts
MODE_MATCH = 0.15  # an EM mode pairs with the nearest model mode within 15 %
Progress = Callable[[int, int, str], None]


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
        """:func:`explanation_text` of every large harmonic difference."""
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
        (:func:`em_modes_from_frf`), or None.
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
        from rigtools.analysis.correlation import trend_series

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
        from rigtools.figures import save_figures

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


def _open(path: str, what: str):
    from rigtools.recording import open_recording
    from rigtools.recording.schema import RecordingError

    try:
        return open_recording(path)
    except RecordingError as exc:
        raise UserError(f"{what}: {exc}") from None
    except OSError as exc:
        raise UserError(f"{what} {path}: {exc.strerror or exc}") from None


def _window(point) -> tuple[int, int]:
    """Settled window of a point, samples: ``record_start`` / ``record_samples`` if recorded."""
    n = point.n_samples
    fs = point.sample_rate
    start = point.params.get("record_start")
    count = point.params.get("record_samples")
    if start is None or count is None or fs is None:
        return 0, n
    a = round(float(start) * fs)
    b = min(n, a + int(count))
    if b - a <= 0:
        return 0, n
    return a, b


def too_short(point, k_max: int, who: str) -> str | None:
    """The note that leaves ``point`` out when a compared channel's record window holds fewer
    samples than a fit of ``k_max`` harmonics needs (``2 k_max + 1``), or ``None``."""
    total = {len(point.channels[c]) for c in COMPARED if c in point.channels}
    if len(total) > 1:
        return f"{who} point {point.index}: its channels differ in length ({min(total)} to {max(total)} samples), left out"
    a, b = _window(point)
    lengths = {c: min(b, len(point.channels[c])) - a for c in COMPARED if c in point.channels}
    short = {c: n for c, n in lengths.items() if n < 2 * k_max + 1}
    if not short:
        return None
    what = ", ".join(f"{c} {max(n, 0)}" for c, n in short.items())
    return f"{who} point {point.index}: too few samples to fit {k_max} harmonics ({what}; need {2 * k_max + 1}), left out"


def _is_frf_point(point) -> bool:
    return "frame_samples" in point.params and "signal" in point.params


def em_point_analysis(point, k_max: int = K_MAX):
    """``(DwellAnalysis, {channel: samples}, rate)`` of an EM point over its settled window."""
    from rigtools.analysis.point import analyze_dwell

    fs = point.sample_rate
    if fs is None:
        raise UserError(f"EM point {point.index}: its channels have different sample rates")
    a, b = _window(point)
    waves = {c: np.asarray(point.channels[c][a:b], dtype=float) for c in COMPARED if c in point.channels}
    fe = float(point.params["fe"])
    return analyze_dwell(waves, fs, fe, k_max=k_max), waves, fs


def _with_velocity_harmonics(analysis, velocities: dict, rate: float):
    """Replace the acceleration harmonics by ``derivative_harmonics`` of the velocity ones."""
    from rigtools.analysis.harmonics import derivative_harmonics, harmonic_amplitudes

    fits = dict(analysis.harmonics)
    for ch, v in velocities.items():
        if ch in fits:
            k = int(fits[ch].k[-1])
            fits[ch] = derivative_harmonics(harmonic_amplitudes(v, rate, analysis.fe, k), 1)
    return dataclasses.replace(analysis, harmonics=fits)


def model_run_analysis(run, k_max: int = K_MAX):
    """``(DwellAnalysis, {channel: samples}, rate)`` of a :class:`rigtools.sim.vibro_impact.VibroImpactRun`."""
    from rigtools.analysis.point import analyze_dwell

    o = run.outputs
    waves = {
        FORCE: o["excitation_force"],
        ACTIVE: o["active_tip_acceleration"],
        PASSIVE: o["passive_tip_acceleration"],
    }
    res = analyze_dwell(waves, run.sample_rate, run.fe, k_max=k_max)
    res = _with_velocity_harmonics(
        res, {ACTIVE: o["active_tip_velocity"], PASSIVE: o["passive_tip_velocity"]}, run.sample_rate
    )
    return res, waves, run.sample_rate


def model_point_analysis(point, k_max: int = K_MAX):
    """Same for a point of a model recording (its record window, the whole point where none is set,
    as a model run's; velocities used when present)."""
    from rigtools.analysis.point import analyze_dwell

    fs = point.sample_rate
    waves = {c: point.settled(c) for c in COMPARED if c in point.channels}
    res = analyze_dwell(waves, fs, float(point.params["fe"]), k_max=k_max)
    vel = {c: point.settled(v) for c, v in VELOCITY_OF.items() if v in point.channels and c in waves}
    return _with_velocity_harmonics(res, vel, fs), waves, fs


def em_force_harmonics(analysis) -> list[tuple[int, float, float]]:
    """``(k, A_k, phi_k)`` of the EM force, phases shifted so the fundamental is ``-pi/2`` (a sine
    from t = 0, as the nominal force): ``phi_k - k (phi_1 + pi/2)``."""
    fit = analysis.harmonics[FORCE]
    shift = fit.phase[0] + math.pi / 2
    return [
        (int(k), float(a), float(np.angle(np.exp(1j * (p - k * shift)))))
        for k, a, p in zip(fit.k, fit.amplitude, fit.phase, strict=True)
    ]


# ------------------------------------------------------------------------------ model runs


@dataclass(frozen=True)
class DrivenPoint(PlannedPoint):
    """A planned point with the periodic force that drives it (``None``: ``F0 sin``)."""

    force_harmonics: tuple | None = None


def run_driven_point(system, point: DrivenPoint, options, previous=None):
    """:func:`rigtools.study_runner.run_point` with the point's ``force_harmonics``."""
    from rigtools.sim.vibro_impact import run_harmonic

    return run_harmonic(
        system.with_contact(gap=point.gap),
        point.fe,
        point.force,
        record_periods=max(1, round(options.record_duration * point.fe)),
        steps_per_period=options.steps_per_period,
        max_settle_time=options.max_settle_time,
        initial=None if previous is None else previous.final_state,
        force_harmonics=point.force_harmonics,
    )


def simulate_em_points(
    system,
    em_points: Sequence[tuple[dict, Any]],
    excitation: str,
    *,
    carry_state: bool = True,
    workers: int | None = None,
    max_settle_time: float = 30.0,
    progress: Progress | None = None,
) -> list:
    """Model runs at the EM points: ``em_points`` is ``[(params, DwellAnalysis)]``; returns the runs."""
    from rigtools.sim.vibro_impact import SimulationInputError
    from rigtools.simulation import check_finite
    from rigtools.study_runner import RunOptions, StudyRunner

    planned = []
    for i, (params, ana) in enumerate(em_points):
        f1 = float(ana.force_amplitude)
        harm = tuple(em_force_harmonics(ana)) if excitation == "measured" else None
        gap = params.get("gap")
        if gap is None:
            raise UserError(f"EM point {i} has no gap parameter: cannot simulate it")
        planned.append(
            DrivenPoint(
                index=i,
                value=float(params.get("study_value", i)),
                direction=str(params.get("direction", "up")),
                fe=float(params["fe"]),
                force=f1,
                gap=float(gap),
                force_harmonics=harm,
            )
        )
    chains = [planned] if carry_state else [[p] for p in planned]
    fe_min = min(p.fe for p in planned)
    options = RunOptions(record_duration=MODEL_RECORD_PERIODS / fe_min, max_settle_time=max_settle_time)
    runs = []
    try:
        with StudyRunner(workers=workers) as runner:
            for _, run in runner.run(system, chains, options, progress=progress, point_fn=run_driven_point):
                check_finite(run)
                runs.append(run)
    except SimulationInputError as exc:
        raise UserError(str(exc)) from None
    return runs


# ------------------------------------------------------------------------------ natural frequencies


def em_modes_from_frf(recording) -> tuple[dict, dict, list[str], dict | None]:
    """``({"active": fn}, {"active": zeta}, notes, frf)`` from the first FRF point of a recording
    with modes: the very analysis ``rig analyze`` reports of it
    (:func:`rigtools.analyze.analyze_broadband`: the recording's one FRF estimate, LSCF with a
    stabilisation check); ``frf`` is that point's ``"frf"`` summary
    (:meth:`rigtools.analyze.PointAnalysis.frf_dict`, with ``file`` and ``point``), None without
    one. The passive blade is not excited by the shaker, so only the active blade's modes are
    measured."""
    from rigtools.analyze import analyze_broadband

    notes = []
    fns: list[float] = []
    zetas: list[float] = []
    summary = None
    procedure = str((recording.experiment or {}).get("procedure", ""))
    for point in recording.points:
        if not _is_frf_point(point) or not point.complete or ACTIVE not in point.channels:
            continue
        analysed = analyze_broadband(point, procedure, responses=[ACTIVE])
        ident = analysed.frf.modes[ACTIVE]
        notes.extend(ident.notes)
        for m in ident.modes:
            if m.damping_ratio <= MAX_MODE_DAMPING:
                fns.append(m.frequency_hz)
                zetas.append(m.damping_ratio)
            else:
                notes.append(
                    f"FRF point {point.index}: a fitted pole at {m.frequency_hz:.1f} Hz with damping "
                    f"ratio {m.damping_ratio:.3f} is not taken as a mode (band edge or fit artefact)"
                )
        if fns:
            summary = {"file": str(recording.path), "point": point.index, **analysed.frf_dict()}
            break
    order = np.argsort(fns)
    return (
        {"active": np.asarray(fns)[order]} if fns else {},
        {"active": np.asarray(zetas)[order]} if fns else {},
        notes,
        summary,
    )


def _align(em: np.ndarray, model: np.ndarray) -> np.ndarray:
    """EM frequencies placed at the index of the nearest model mode (within MODE_MATCH), NaN else."""
    out = np.full(model.size, np.nan)
    for f in em:
        j = int(np.argmin(np.abs(model - f)))
        if abs(model[j] - f) <= MODE_MATCH * model[j] and not np.isfinite(out[j]):
            out[j] = f
    return out


def _matched_modes(em: dict, zeta: dict, model: dict) -> tuple[dict, dict, dict]:
    """Per blade, the EM modes that pair with a model mode (nearest within MODE_MATCH) with their
    damping ratios and the paired model frequencies, ascending."""
    fn_e, z, fn_m = {}, {}, {}
    for blade, fs in em.items():
        m = np.sort(np.asarray(model.get(blade, []), dtype=float))
        if m.size == 0:
            continue
        pairs = {}
        for f, zz in zip(np.asarray(fs, dtype=float), np.asarray(zeta[blade], dtype=float), strict=True):
            j = int(np.argmin(np.abs(m - f)))
            if abs(m[j] - f) <= MODE_MATCH * m[j] and j not in pairs:
                pairs[j] = (f, zz)
        js = sorted(pairs)
        fn_e[blade] = np.array([pairs[j][0] for j in js])
        z[blade] = np.array([pairs[j][1] for j in js])
        fn_m[blade] = m[js]
    return fn_e, z, fn_m


def _model_mode(fn_em: float, fn_e: dict, fn_m: dict, fn_model: dict) -> tuple[str, int, float] | None:
    """(blade, mode number, model frequency) paired with an EM natural frequency."""
    for blade, fs in fn_e.items():
        hit = np.flatnonzero(np.isclose(fs, fn_em, rtol=0, atol=1e-9))
        if hit.size:
            fm = float(fn_m[blade][hit[0]])
            n = int(np.argmin(np.abs(np.sort(fn_model[blade]) - fm))) + 1
            return blade, n, fm
    return None


def explanation_text(channel: str, e, mode: tuple[str, int, float] | None, model_label: str) -> str:
    """One line: the harmonic's model/EM ratio and the natural-frequency offset that explains it."""
    short = channel.replace("_accel", "").replace("_", " ")
    text = f"{short} {e.k}·fe = {e.frequency_hz:.1f} Hz: {model_label}/EM = x{e.observed_ratio:.2f}. "
    if mode is not None:
        blade, n, fm = mode
        text += (
            f"It lies {100 * (e.frequency_hz / e.natural_hz - 1):+.1f} % from the EM {blade} mode {n} at "
            f"{e.natural_hz:.1f} Hz, which the {model_label} puts at {fm:.1f} Hz "
            f"({100 * (fm / e.natural_hz - 1):+.2f} %): that offset alone changes this harmonic by "
            f"x{e.ratio_from_model_frequency:.2f}"
        )
    else:
        text += (
            f"It lies {100 * (e.frequency_hz / e.natural_hz - 1):+.1f} % from the model's mode at "
            f"{e.natural_hz:.1f} Hz (no EM modes measured)"
        )
    text += f"; a 1 % higher/lower natural frequency changes it by x{e.ratio_per_percent[0]:.2f}/x{e.ratio_per_percent[1]:.2f}"
    if np.isfinite(e.offset_pct_needed):
        text += f"; x{e.observed_ratio:.2f} needs a {e.offset_pct_needed:+.2f} % offset"
    else:
        text += (
            "; no single-mode offset gives the whole ratio: the rest comes from the forcing at this "
            "harmonic (compare the force rows) and the impacts"
        )
    return text


def natural_table(fem: dict, am: dict | None, em: dict, n_modes: int = 3):
    """Natural-frequency table: FEM, AM and EM per blade and mode with differences in % (EM the
    reference where measured, as the paper's Tables 2 and 3; else AM vs FEM)."""
    import pandas as pd

    rows = []
    for blade in ("active", "passive"):
        f = np.sort(np.asarray(fem.get(blade, []), dtype=float))
        a = np.sort(np.asarray((am or {}).get(blade, []), dtype=float))
        e = _align(np.asarray(em.get(blade, []), dtype=float), f) if blade in em else np.full(f.size, np.nan)
        for i in range(min(n_modes, f.size)):
            fa = float(a[i]) if i < a.size else float("nan")
            row = {
                "blade": blade,
                "mode": i + 1,
                "fem_hz": float(f[i]),
                "am_hz": fa,
                "em_hz": float(e[i]),
                "fem_vs_em_pct": 100 * (f[i] - e[i]) / e[i],
                "am_vs_em_pct": 100 * (fa - e[i]) / e[i],
                "am_vs_fem_pct": 100 * (fa - f[i]) / f[i],
            }
            rows.append(row)
    return pd.DataFrame(rows)


# ------------------------------------------------------------------------------ the comparison


def _pair_key(params: dict) -> dict:
    out = {}
    for key, name in (("fe", "fe"), ("gap", "gap"), ("force_amplitude_target", "force_amplitude")):
        if params.get(name) is not None:
            out[key] = float(params[name])
    return out


def _study_kind(recording) -> str | None:
    exp = recording.experiment or {}
    par = exp.get("parameters") or {}
    kind = (par.get("plan") or {}).get("kind") or par.get("kind")
    if kind in ("gap", "force", "frequency"):
        return kind
    # a model study or any multi-point file: the parameter that varies
    pts = [current_parameters(p.params) for p in recording.points if p.complete and not _is_frf_point(p)]
    for key, k in (("gap", "gap"), ("force_amplitude", "force"), ("fe", "frequency")):
        vals = {round(float(p[key]), 12) for p in pts if p.get(key) is not None}
        if len(vals) > 1:
            return k
    return None


def _carry_state(recording) -> bool:
    par = (recording.experiment or {}).get("parameters") or {}
    return bool((par.get("plan") or {}).get("carry_state", True))


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
    from rigtools.analysis.correlation import (
        explain_large_differences,
        harmonic_table,
        pair_points,
        point_agreement,
    )
    from rigtools.sim.natural_frequencies import reduced_natural_frequencies as natural_frequencies
    from rigtools.simulation import load_system

    notes: list[str] = []
    with _open(em_path, "EM recording") as rec:
        if rec.backend in MODEL_BACKENDS:
            raise UserError(
                f"{em_path} is a model recording (backend {rec.backend}): give the EM (rig) recording first"
            )
        kind = _study_kind(rec)
        carry = _carry_state(rec)
        dwell_points = [p for p in rec.points if not _is_frf_point(p)]
        skipped = [p.index for p in dwell_points if not p.complete]
        notes.extend(f"EM: {n}" for n in rec.notes)  # what a damaged file read with --skip-damaged left out
        if skipped:
            notes.append(f"EM points {skipped} were cut off (not complete) and are left out")
        em_items = []
        for p in dwell_points:
            if not p.complete:
                continue
            params = current_parameters(p.params)
            if not excitation_frequency(params):
                notes.append(
                    f"EM point {p.index}: "
                    + ("fe = 0 (no single excitation frequency)" if "fe" in params else "no fe")
                    + ", left out"
                )
                continue
            if (short := too_short(p, k_max, "EM")) is not None:
                notes.append(short)
                continue
            ana, waves, fs = em_point_analysis(p, k_max)
            if FORCE not in ana.harmonics:
                raise UserError(f"EM point {p.index} has no force channel")
            if params.get("settled") is False:
                notes.append(f"EM point {p.index} was not settled when recorded")
            em_items.append((p.index, params, ana, waves, fs))
        if not em_items:
            raise UserError(f"{em_path} holds no complete periodic (dwell, sweep, study) point to compare")
        em_modes, em_zeta, mode_notes, em_frf = em_modes_from_frf(rec)
        if not em_modes and frf is None:
            notes.append(
                f"{Path(em_path).name} holds no FRF data: no measured (EM) natural frequencies; "
                f"give {option('frf', 'FRF.h5')} (an FRF test: rig acquire frf, rigtools.frf_test) "
                "for the EM column"
            )
        try:
            rig_cfg_text = rig if rig is not None else rec.rig_config()
        except Exception as exc:  # noqa: BLE001 - a damaged rig attribute
            raise UserError(
                f"{em_path}: its rig description cannot be read ({exc}); give {option('rig', 'FILE')}"
            ) from None
    if frf is not None:
        with _open(frf, "FRF recording") as frec:
            em_modes, em_zeta, mode_notes, em_frf = em_modes_from_frf(frec)
        if not em_modes:
            notes.append(f"{Path(frf).name}: no modes identified from its FRF points")
    notes.extend(mode_notes)

    # the model: rig from --rig or the EM file
    if isinstance(rig_cfg_text, str):
        cfg, system = load_system(rig_cfg_text, model)
        _, other = load_system(rig_cfg_text, "am" if model == "fem" else "fem")
    else:
        from rigtools.sim.reduction import reduced_system

        cfg = rig_cfg_text
        system = reduced_system(cfg.to_params(), model)
        other = reduced_system(cfg.to_params(), "am" if model == "fem" else "fem")
    fn_model = natural_frequencies(system)
    fn_other = natural_frequencies(other)
    fem_fn, am_fn = (fn_model, fn_other) if model == "fem" else (fn_other, fn_model)
    natural = natural_table(fem_fn, am_fn, em_modes)

    model_items = []  # (index, params, analysis, waves, rate)
    run_excitation: str | None = excitation  # None: the model side is a recording
    if fem_path is None:  # --simulate (checked above)
        runs = simulate_em_points(
            system,
            [(it[1], it[2]) for it in em_items],
            excitation,
            carry_state=carry,
            workers=workers,
            max_settle_time=max_settle_time,
            progress=progress,
        )
        from rigtools.simulation import force_fundamental

        for i, run in enumerate(runs):
            ana, waves, fs = model_run_analysis(run, k_max)
            mp = {
                "fe": run.fe,
                "gap": run.gap,
                "force_amplitude": run.force_amplitude,
                "force_amplitude_measured": force_fundamental(run),
                "settled": bool(run.steady_state),
            }
            if not run.steady_state:
                notes.append(
                    f"the model run at EM point {em_items[i][0]} did not settle within "
                    f"{max_settle_time:g} s simulated"
                )
            model_items.append((i, mp, ana, waves, fs))
        pairs = [(i, i) for i in range(len(em_items))]
        source = "simulated"
    else:
        with _open(fem_path, "model recording") as mrec:
            notes.extend(f"model: {n}" for n in mrec.notes)
            if mrec.backend not in MODEL_BACKENDS:
                notes.append(
                    f"{Path(fem_path).name} was written by backend {mrec.backend!r}, not a model run"
                )
            for p in mrec.points:
                if not p.complete or _is_frf_point(p):
                    continue
                params = current_parameters(p.params)
                if not excitation_frequency(params):
                    if "fe" in params:
                        notes.append(
                            f"model point {p.index}: fe = 0 (no single excitation frequency), left out"
                        )
                    continue
                if (short := too_short(p, k_max, "model")) is not None:
                    notes.append(short)
                    continue
                ana, waves, fs = model_point_analysis(p, k_max)
                model_items.append((p.index, params, ana, waves, fs))
        pairs = pair_points([_pair_key(it[1]) for it in em_items], [_pair_key(it[1]) for it in model_items])
        source = str(fem_path)
        run_excitation = None

    if not pairs:
        have = sorted(
            {
                (
                    round(it[1].get("fe", np.nan), 6),
                    round(it[1].get("gap", np.nan) * 1e3, 6),
                    round(it[1].get("force_amplitude", np.nan), 6),
                )
                for it in model_items
            }
        )
        raise UserError(
            f"no EM point of {Path(em_path).name} has a model point with the same fe, gap and "
            f"force target (within 2 %); the model file holds (fe Hz, gap mm, F0 N) = "
            f"{', '.join(str(h) for h in have[:5]) or 'no periodic point'}"
        )
    paired_em = {i for i, _ in pairs}
    unpaired = [em_items[i][0] for i in range(len(em_items)) if i not in paired_em]
    if unpaired:
        notes.append(f"EM points {unpaired} have no model point with the same fe, gap and force target (2 %)")
    fn_em_for_explain = em_modes if em_modes else {b: v for b, v in fn_model.items()}
    zeta = (
        {"active": em_zeta["active"]}
        if em_modes
        else {b: np.full(v.size, float(np.median(system.zeta))) for b, v in fn_model.items()}
    )
    if not em_modes:
        notes.append(
            "large harmonic differences are set against the model's own natural frequencies (no EM "
            "modes): the offset needed is stated, not the measured one"
        )
    points = []
    for i, j in pairs:
        idx, params, ana, waves, fs = em_items[i]
        midx, mparams, mana, mwaves, mfs = model_items[j]
        chans = [c for c in COMPARED if c in ana.harmonics and c in mana.harmonics]
        table = harmonic_table(
            {c: ana.harmonics[c].amplitude for c in chans},
            {c: mana.harmonics[c].amplitude for c in chans},
            params["fe"],
            k_max=k_max,
        )
        agreement = point_agreement(ana, mana, channels=[c for c in SCORED if c in chans], k_max=k_max)
        if em_modes:
            fn_e, z, fn_m = _matched_modes(em_modes, em_zeta, fn_model)
            large = explain_large_differences(
                table, params["fe"], fn_e, z, fn_m, threshold_pct=LARGE_DIFF_PCT
            )
            expl = [(ch, e, _model_mode(e.natural_hz, fn_e, fn_m, fn_model)) for ch, e in large]
        else:
            large = explain_large_differences(
                table, params["fe"], fn_em_for_explain, zeta, None, threshold_pct=LARGE_DIFF_PCT
            )
            expl = [(ch, e, None) for ch, e in large]
        mparams["model_label"] = model.upper()
        points.append(
            PointComparison(
                idx,
                midx,
                _plain(params),
                _plain(mparams),
                ana,
                mana,
                table,
                agreement,
                expl,
                waves,
                mwaves,
                fs,
                mfs,
            )
        )
    return Comparison(
        str(em_path), source, model, run_excitation, kind, points, natural, notes, unpaired, em_frf
    )
