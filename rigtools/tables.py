"""The tables the commands print, for a person to read: lines and rich tables built from an
analysis (``rig analyze``, :mod:`rigtools.recording_analysis`), a comparison (``rig compare``,
:mod:`rigtools.recording_comparison`), a model update (``rig update``, :mod:`rigtools.model_update`)
a simulated run (``rig simulate``), and ``rig info`` of recordings, FRF sets and branches files.
The commands print them in order. Every number goes through :mod:`rigtools.readable` (the one rule:
significant digits, round-off of a zero harmonic, no ``-0``)."""

from __future__ import annotations

import math
from typing import Any

from rigtools import readable
from rigtools.branches_file import X_LABELS, X_UNITS
from rigtools.recording.summary import format_value
from rigtools.vocabulary import parameter_units


def _fmt(x, digits: int = readable.DIGITS) -> str:
    return readable.number(x, None if digits == readable.DIGITS else f".{digits}g")


def analysis_tables(analysis: Any, verbose: bool = False) -> list[Any]:
    """What ``rig analyze`` prints of a :class:`rigtools.recording_analysis.results.RecordingAnalysis`: lines and rich
    tables, in order; ``verbose`` adds one line per candidate mode not reported and why."""
    from rich.table import Table

    out: list[Any] = []

    out.append(
        f"{analysis.path}: {analysis.procedure or 'recording'} ({analysis.backend}, "
        f"status {analysis.status}); amplitudes are peak"
    )
    for note in analysis.notes + analysis.skipped:
        out.append(f"note: {note}")
    rows = analysis.point_rows()
    if rows:
        short = {
            "point": "pt",
            "fe (Hz)": "fe Hz",
            "F0 target, peak (N)": "F0 N",
            "F1 measured, peak (N)": "F1 N",
            "gap (mm)": "gap mm",
            "impacts/period": "imp/T",
            "settled": "settled",
        }
        cols = list(rows[0])
        harm = [c for c in cols if "·fe" in c]
        for title, group, caption in (
            (
                "periodic points",
                ["point"] + [c for c in cols if c not in harm and c != "point"],
                "F0 target and F1 measured force fundamental, peak; imp/T: impacts per period",
            ),
            (
                "shroud-acceleration harmonics, peak (m/s²)",
                ["point"] + harm,
                "A6, P22...: active/passive shroud at 6·fe, 22·fe...",
            ),
        ):
            if len(group) < 2:
                continue
            table = Table(title=title, caption=caption)
            for c in group:
                table.add_column(
                    short.get(c) or c.replace("active ", "A").replace("passive ", "P").split("·")[0],
                    justify="right",
                    no_wrap=True,
                )
            for r in rows:
                table.add_row(*(_fmt(r.get(c), 3) for c in group))
            out.append(table)
        out.append(
            "modes: none from sine points (a sine excites one frequency at a time; use rig acquire frf)"
        )
    for p in analysis.operational:
        table = Table(
            title=f"point {p.index}: spectra (no force channel)",
            caption="peaks of the averaged PSD; m: a mode's, h: a harmonic tone's",
        )
        for col in ("channel", "RMS", "PSD peaks, Hz", "harmonics k·fe"):
            table.add_column(col, justify="right")
        for c, sp in p.spectra.items():
            peaks = ", ".join(
                f"{q['frequency_hz']:.4g}{_peak_mark(p.oma, q['frequency_hz'])}" for q in sp.peaks[:4]
            )
            harmonics = ", ".join(f"{h['k']}: {h['amplitude']:.3g}" for h in sp.harmonics[:4]) or "–"
            table.add_row(f"{c} ({p.units.get(c, '')})", f"{sp.rms:.3g}", peaks or "–", harmonics)
        out.append(table)
        out.extend(_oma_tables(p, verbose))
        for n in p.notes:
            out.append(f"note: {n}")
    for p in analysis.broadband:
        est = p.frf.estimate
        table = Table(
            title=f"point {p.index}: modes ({p.frf.kind}, {est.n_averages} averages, "
            f"{est.resolution_hz:.3g} Hz resolution, {p.excitation})"
        )
        for col in ("response", "mode", "f (Hz)", "ζ (%)", "coherence", "method"):
            table.add_column(col, justify="right")
        for i, r in enumerate(p.frf.responses):
            m = p.frf.modes[r]
            if not m.modes:
                table.add_row(r, "–", "–", "–", _fmt(float(est.coherence[i][p._band()].mean())), m.method)
            for j, mode in enumerate(m.modes):
                table.add_row(
                    r,
                    str(j + 1),
                    f"{mode.frequency_hz:.2f}",
                    f"{100 * mode.damping_ratio:.3f}",
                    _fmt(p.coherence_at(i, mode.frequency_hz)),
                    m.method,
                )
        out.append(table)
        for n in p.notes:
            out.append(f"note: {n}")
        if verbose:
            for r, m in p.frf.modes.items():
                for d in m.dropped:
                    out.append(
                        f"  not reported ({r}): {d['frequency_hz']:.5g} Hz, ζ {100 * d['damping_ratio']:.3g} %: "
                        f"{d['reason']}"
                    )
    if analysis.frequency_table:
        cols = [
            ("blade", "blade"),
            ("mode", "k"),
            ("fem_hz", "FEM"),
            ("am_hz", "AM"),
            ("em_hz", "EM"),
            ("fem_vs_em_pct", "FEM %"),
            ("am_vs_em_pct", "AM %"),
        ]
        if "article_hz" in analysis.frequency_table[0]:
            cols += [("article_hz", "article"), ("em_vs_article_pct", "EM-art %")]
        table = Table(
            title="flexural natural frequencies, Hz (paper's Table 2)",
            caption="EM: identified here; FEM/AM %: (model - EM) / EM; article: the simulated "
            "rig's own test article, EM-art %: (EM - article) / article",
        )
        for _, h in cols:
            table.add_column(h, justify="right", no_wrap=True)
        for r in analysis.frequency_table:
            table.add_row(*(readable.number(r[k], readable.FREQUENCY_TABLE.get(k)) for k, _ in cols))
        out.append(table)
    return out


def _fmt_spec(x: Any, spec: str = ".4g") -> str:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return "" if x is None else str(x)
    return "–" if not math.isfinite(x) else format(x, spec)


def comparison_tables(cmp: Any, k_show: int) -> list[Any]:
    """What ``rig compare`` prints of a :class:`rigtools.recording_comparison.Comparison`: lines and
    rich tables, in order; per point the harmonics k = 1..``k_show`` and 22."""
    from rich.table import Table

    out: list[Any] = []
    ml = cmp.model_label
    how = (
        f"model recording {cmp.model_source}"
        if cmp.excitation is None
        else f"{ml} simulated at every EM point, {cmp.excitation} excitation"
    )
    out.append(f"[bold]EM[/bold] {cmp.em_path}  vs  {how}")
    if cmp.natural is not None and len(cmp.natural):
        t = Table(title="natural frequencies, Hz (diff % = 100 (model - EM) / EM; AM vs FEM)")
        for col in ("blade", "mode", "FEM", "AM", "EM", "FEM vs EM %", "AM vs EM %", "AM vs FEM %"):
            t.add_column(col, justify="left" if col == "blade" else "right")
        for r in cmp.natural.to_dict("records"):
            t.add_row(
                r["blade"],
                str(r["mode"]),
                *(
                    readable.number(r[k], readable.FREQUENCY_TABLE[k])
                    for k in ("fem_hz", "am_hz", "em_hz", "fem_vs_em_pct", "am_vs_em_pct", "am_vs_fem_pct")
                ),
            )
        out.append(t)
    for p in cmp.points:
        t = Table(title=f"{p.label()}: harmonics (peak), score {p.score:.3f}")
        for col in ("channel", "k", "f Hz", "EM", ml, "diff %"):
            t.add_column(col, justify="left" if col == "channel" else "right")
        for ch in dict.fromkeys(p.table["channel"]):
            whole = p.table[p.table["channel"] == ch]
            top_em, top_model = readable.largest(whole["em"]), readable.largest(whole["fem"])
            sub = whole[(whole["k"] <= k_show) | (whole["k"] == 22)]
            for i, r in enumerate(sub.itertuples(index=False)):
                t.add_row(
                    ch if i == 0 else "",
                    str(r.k),
                    readable.number(r.frequency_hz, ".0f"),
                    readable.harmonic(r.em, top_em),
                    readable.harmonic(r.fem, top_model),
                    readable.number(r.diff_pct, readable.HARMONIC_PCT),
                )
            t.add_section()
        out.append(t)
        for line in p.explanation_lines(ml):
            out.append(f"  [yellow]explained[/yellow]: {line}")
    t = Table(title=f"agreement (10^-E over the shroud accelerations' harmonics), mean {cmp.mean_score:.3f}")
    for col in (
        "EM point",
        "fe Hz",
        "gap mm",
        "F0 N",
        "F1 EM N",
        f"F1 {ml} N",
        "active E",
        "passive E",
        "score",
    ):
        t.add_column(col, justify="right")
    for p in cmp.points:
        t.add_row(
            str(p.em_index),
            _fmt_spec(p.params["fe"]),
            _fmt_spec(p.params.get("gap", math.nan) * 1e3),
            _fmt_spec(p.params.get("force_amplitude")),
            _fmt_spec(p.em.force_amplitude),
            _fmt_spec(p.model.force_amplitude),
            _fmt_spec(p.agreement.per_channel.get("active_shroud_accel"), ".3f"),
            _fmt_spec(p.agreement.per_channel.get("passive_shroud_accel"), ".3f"),
            _fmt_spec(p.score, ".3f"),
        )
    out.append(t)
    for n in cmp.notes:
        out.append(f"note: {n}")
    how = f"{cmp.excitation} excitation, {ml}" if cmp.excitation is not None else f"{ml} recording"
    out.append(f"mean agreement score ({how}): {cmp.mean_score:.4f}")
    return out


def update_tables(o: Any) -> list[Any]:
    """What ``rig update`` prints of a :class:`rigtools.model_update.UpdateOutcome`: tables, the
    fit reports and notes, in order (lines starting with ``[`` carry rich markup)."""
    from rich.table import Table
    from rich.text import Text

    out: list[Any] = []
    t = Table(title="identified modes used")
    for col in (
        "blade",
        "flexural mode",
        "identified f (Hz)",
        "damping ratio ζ",
        "nominal model f (Hz)",
        "recordings",
    ):
        t.add_column(col, justify="left" if col in ("blade", "recordings") else "right")
    for p in o.paired:
        zeta = "-" if p.damping_ratio is None else f"{p.damping_ratio:.4f}"
        t.add_row(
            p.blade, str(p.order), f"{p.frequency_hz:.3f}", zeta, f"{p.model_hz:.3f}", ", ".join(p.sources)
        )
    out.append(t)
    for n in o.notes:
        out.append(f"[yellow]note:[/] {n}")
    out.append(Text(o.fit.report()))
    if o.fit.identifiability.unresolved:
        out.append(
            "[yellow]the values of the parameters named above are kept in the rig file but the data do "
            "not determine them: add modes (another blade, higher orders) or fit fewer parameters[/]"
        )
    if o.dwells:
        c = o.contact_fit
        out.append(Text(c.report()))
        for r in o.other_laws:
            out.append(
                f"other law: {r.law}: rms harmonic error {100 * r.rms_log_error_after:.2f} % "
                f"(kept: {c.law}, {100 * c.rms_log_error_after:.2f} %)"
            )
        s = Table(title="EM-versus-FEM agreement (1 = identical harmonics)")
        s.add_column("dwell")
        for step in o.scores:
            s.add_column(step, justify="right")
        for i, d in enumerate(o.dwells):
            s.add_row(
                f"{d.name} ({d.fe:g} Hz, {d.force_amplitude:.3g} N, gap {1e3 * d.gap:g} mm)",
                *[f"{o.scores[k][i]:.4f}" for k in o.scores],
            )
        out.append(s)
    if getattr(o, "unmeasured", None):
        u = Table(title="modes moved by the fit, not measured (the data did not determine them)")
        for col in ("blade", "mode", "before (Hz)", "after (Hz)", "change %", "why not measured"):
            u.add_column(col, justify="right" if "(" in col or "%" in col else "left")
        for m in o.unmeasured:
            u.add_row(
                m.blade,
                f"{m.kind} {m.order}",
                f"{m.before_hz:.2f}",
                f"{m.after_hz:.2f}",
                f"{100 * m.change:+.2f}",
                m.why,
            )
        out.append(u)
    out.append(f"wrote {o.out} (check: rig modal --rig {o.out})")
    if o.warnings and o.warnings[0].startswith("the fitted"):
        out.append(f"[yellow]warning:[/] {o.warnings[0]}")
    return out


def run_tables(doc: dict, result: Any, out: Any) -> list[Any]:
    """What ``rig simulate`` prints of a run: the harmonics k = 1..10 of the shroud accelerations,
    the force and the contact force, then the contact and steady-state line."""
    from rich.table import Table

    out_items: list[Any] = []
    table = Table(title=f"harmonics k*fe (fe = {result.fe:g} Hz), peak amplitudes")
    table.add_column("k", justify="right")
    table.add_column("Hz", justify="right")
    names = ("active_shroud_accel", "passive_shroud_accel", "force", "contact_force")
    for name in names:
        table.add_column(name + (" (m/s²)" if "accel" in name else " (N)"), justify="right")
    h = doc["harmonics"]
    tops = {name: readable.largest(x["amplitude"] for x in h[name]) for name in names}
    for i in range(10):
        table.add_row(
            str(i + 1),
            f"{h['force'][i]['frequency_hz']:g}",
            *(readable.harmonic(h[name][i]["amplitude"], tops[name]) for name in names),
        )
    out_items.append(table)
    c = doc["contact"]
    out_items.append(
        f"peak contact force {c['peak_force_n']:.4g} N, {c['impacts_per_period']:g} impacts per period, "
        f"steady state: {'yes' if doc['steady_state'] else 'NO'} "
        f"(after {result.settle_time:.3g} s simulated); wrote {out}"
        + (f" and {doc['plot']}" if doc.get("plot") else "")
    )
    return out_items


def frf_set_tables(info: dict) -> list[Any]:
    """``rig info`` of an FRF set (:func:`rigtools.frf_set.summary`): two lines and the FRFs."""
    from rich.table import Table

    f, src = info["frequency"], info["source"]
    head = [
        f"[bold]{info['path']}[/bold]  FRF set: {info['n_frfs']} {info['frf_kind']} FRF(s), {info['frf_units']}",
        (
            f"{f['lines']} lines {f['min_hz']:g}-{f['max_hz']:g} Hz, {f['resolution_hz']:g} Hz resolution; "
            f"from {src.get('file', '?')} ({src.get('format', '?')}), created {info['created']}, "
            f"schema v{info['schema_version']}"
        ),
    ]
    table = Table(title="FRFs (UFF node and direction)")
    for column in ("response", "at", "units", "reference", "at", "coherence"):
        table.add_column(column)
    at = lambda node, code: "" if node is None else f"{node} {code}".strip()
    for r in info["responses"]:  # the reference's direction is the response's own (one name, two ways)
        ref = at(r["reference_node"], r["reference_direction"])
        row = (r["name"], at(r["node"], r["direction"]), f"{r['units']} per N", r["reference"], ref)
        table.add_row(*row, "yes" if r["coherence"] else "no")
    return [*head, table]


def branches_tables(info: dict) -> list[Any]:
    """``rig info`` of a branches file (:func:`rigtools.branches_file.branches_info`): what was
    continued, at which fixed quantities, and a row per branch."""
    from rich.table import Table

    e, param = info["experiment"], info["param"]
    unit = "V" if e.get("drive") and param == "force" else X_UNITS.get(param, "")
    scale = X_LABELS.get(param, ("", 1.0))[1]
    show = lambda v: "–" if v is None else f"{v * scale:.6g}"
    fixed = {"fe": ("fe", "Hz", 1.0), "force": ("force", "V" if e.get("drive") else "N", 1.0),
             "gap": ("gap", "mm", 1e3)}  # fmt: skip
    held = ", ".join(
        f"{name} {e[k] * f:g} {u}" for k, (name, u, f) in fixed.items() if k != param and e.get(k) is not None
    )
    head = [
        (
            f"[bold]{info['path']}[/bold]  branches of rig continuation ({(e.get('model') or '?').upper()} "
            f"model{', rig ' + info['rig'] if info['rig'] else ''})"
        ),
        (
            f"{param} from {show(e.get('from'))} to {show(e.get('to'))} {unit}; {held}; "
            f"rigtools {info['software_version']}, schema v{info['schema_version']}"
        ),
    ]
    table = Table(title=f"branches ({param} in {unit})")
    for column in ("branch", "period", "status", "points", "stable", "from", "to", "bifurcations"):
        table.add_column(column, justify="right" if column in ("points", "stable", "from", "to") else "left")
    for i, b in enumerate(info["branches"]):
        marks = ", ".join(f"{x['label']} {show(x['value'])}" for x in b["bifurcations"]) or "none"
        status = b["status"] + (f" ({b['message']})" if b["message"] else "")
        table.add_row(
            f"{i:02d}", str(b["periods"]), status, str(b["points"]), str(b["stable_points"]),
            show(b["from"]), show(b["to"]), marks,
        )  # fmt: skip
    return [*head, table]


def _peak_mark(oma: Any, frequency_hz: float) -> str:
    """`` m`` / `` h`` after a PSD peak a mode / a harmonic tone of ``oma`` explains."""
    if oma is None:
        return ""
    df = float(oma.frequency_hz[1])
    if any(abs(frequency_hz - h.frequency_hz) <= 2 * df for h in oma.harmonics):
        return " h"
    if any(
        abs(frequency_hz - m.frequency_hz) <= max(m.damping_ratio * m.frequency_hz, df) for m in oma.modes
    ):
        return " m"
    return ""


def _oma_tables(p: Any, verbose: bool) -> list[Any]:
    """The modes of a point without a force (operational modal analysis) and its harmonic
    tones, each with the reason it is a tone."""
    from rich.table import Table

    oma = p.oma
    if oma is None:
        return []
    lo, hi = oma.band
    table = Table(
        title=f"point {p.index}: modes without a force (SSI-cov, {lo:.4g}-{hi:.4g} Hz)",
        caption="±: spread (model orders and the record's statistical spread); harmonics are not modes",
    )
    for col in ("mode", "f (Hz)", "± (Hz)", "ζ (%)", "± (%)", "orders"):
        table.add_column(col, justify="right")
    for j, m in enumerate(oma.modes):
        table.add_row(
            str(j + 1),
            f"{m.frequency_hz:.4f}",
            f"{m.frequency_spread_hz:.2g}",
            f"{100 * m.damping_ratio:.2f}",
            f"{100 * m.damping_spread:.2g}",
            f"{m.orders_stable}/{m.orders_judged}",
        )
    if not oma.modes:
        table.add_row("–", "–", "–", "–", "–", "–")
    out: list[Any] = [table]
    for h in oma.harmonics:
        out.append(f"harmonic {h.frequency_hz:.4f} Hz (not a mode): {h.reason}")
    if verbose:
        for d in oma.dropped:
            out.append(
                f"  not reported: {d['frequency_hz']:.5g} Hz, ζ {100 * d['damping_ratio']:.3g} %: {d['reason']}"
            )
    return out


# ``rig info`` of a recording: point parameters shown in columns with their units.
#: parameter -> (column heading with units, SI factor, format spec or None: significant digits)
INFO_COLUMNS: dict[str, tuple[str, float, str | None]] = {
    "fe": ("fe (Hz)", 1.0, None),
    "direction": ("dir", 1.0, None),
    "force_amplitude": ("F0 (N)", 1.0, None),
    "force_amplitude_measured": ("F1 (N)", 1.0, None),
    "gap": ("gap (mm)", 1e3, None),
    "drive_amplitude": ("drive (V)", 1.0, None),
    "control_updates": ("updates", 1.0, None),
    "settled": ("settled", 1.0, None),
    "control_limited_by": ("limited by", 1.0, None),
    "safety_warnings": ("warnings", 1.0, None),
    "record_start": ("record from (s)", 1.0, None),
    "record_samples": ("record samples", 1.0, None),
    "response_per_newton": ("response/F1", 1.0, None),
    "model": ("model", 1.0, None),
    "steps_per_period": ("steps/T", 1.0, None),
    "time_step": ("Δt (µs)", 1e6, None),
    "settle_time": ("settle (s)", 1.0, None),
    "period_multiple": ("period ×", 1.0, None),
    "peak_contact_force": ("contact peak (N)", 1.0, None),
    "impacts_per_period": ("imp/T", 1.0, None),
}
#: The legend of the short headings (those of the columns shown).
INFO_LEGEND = {
    "force_amplitude": "F0: force target (peak)",
    "force_amplitude_measured": "F1: measured force fundamental (peak)",
    "safety_warnings": "warnings: safety warnings",
    "response_per_newton": "response/F1: response fundamental per N",
    "steps_per_period": "T: a period",
    "impacts_per_period": "imp/T: impacts per period",
}
#: Parameters ``rig info`` does not show in a column: the state column says it, or the harmonics
#: table shows them.
_INFO_HIDDEN = ("point_complete", "study_value")
_HARMONIC_SUFFIX = "_harmonic_amplitude"
# harmonics of a point that are no channel: the CBC's target and controlled response, the active
# shroud's displacement (rigtools.procedures.cbc, CBCPoint.attrs)
_HARMONIC_UNITS = {"target": "m", "response": "m"}


def _info_cell(value: Any, factor: float, spec: str | None) -> str:
    if isinstance(value, (int, float)) and not isinstance(value, bool) and factor != 1.0:
        value = value * factor
    if value is None or value == "":
        return "–"
    return readable.number(value, spec)


def recording_tables(info: dict) -> list[Any]:
    """``rig info`` of a recording (:func:`rigtools.recording.summary.summary`): the status lines,
    the channels, the points with their parameters in columns with units, and each point's
    harmonic amplitudes (fundamental and largest k >= 2, round-off shown as such)."""
    from rich.table import Table

    colour = {"complete": "green", "aborted": "red"}.get(info["status"], "yellow")
    status = f"[{colour}]{info['status']}[/{colour}]"
    if info["status"] == "aborted":
        status += f" ({info['abort_reason']})"
    elif info["status"] == "recording" and info["writer"]:
        status += f" (being written now: {info['writer']}; showing what is there)"
    elif info["status"] == "recording":
        status += " (incomplete: the writer stopped without closing the file)"
    if info["end_status"]:
        status += f"; procedure {info['end_status']}" + (
            f" ({info['end_reason']})" if info["end_reason"] and info["status"] != "aborted" else ""
        )
    out: list[Any] = [
        f"[bold]{info['path']}[/bold]  status {status}",
        f"backend {info['backend']}, created {info['created']}, "
        f"rigtools {info['software_version']}, schema v{info['schema_version']}"
        + (f", opened as {info['opened_as']}" if info["opened_as"] != "clean" else ""),
        f"{len(info['points'])} point(s), {readable.number(info['total_duration_s'])} s recorded",
        *(f"note: {n}" for n in info.get("notes", [])),
    ]
    table = Table(title="channels")
    for column in ("name", "quantity", "units", "rate (Hz)", "sensitivity", "physical", "location"):
        table.add_column(column)
    units: dict[str, str] = {}
    for ch in info["channels"]:
        units[ch["name"]] = ch["units"] or ""
        sens = (
            ""
            if ch["sensitivity"] is None
            else readable.number(ch["sensitivity"], unit=ch["sensitivity_units"] or "")
        )
        table.add_row(
            ch["name"],
            ch["quantity"],
            ch["units"],
            readable.number(ch["sample_rate"]),
            sens,
            ch["physical_channel"] or "",
            ch["location"] or "",
        )
    out.append(table)
    out.append(_points_table(info, format_value))
    harmonics = _harmonics_table(info, units)
    if harmonics is not None:
        out.append(harmonics)
    return out


def _points_table(info: dict, format_value) -> Any:
    from rich.table import Table

    points = info["points"]
    present = [k for k in INFO_COLUMNS if any(p["params"].get(k) not in (None, "") for p in points)]
    other = lambda params: ", ".join(
        f"{k}={_with_units(k, v, format_value)}"
        for k, v in params.items()
        if k not in INFO_COLUMNS and k not in _INFO_HIDDEN and "_harmonic_" not in k and v not in (None, "")
    )
    others = [other(p["params"]) for p in points]
    legend = "; ".join(INFO_LEGEND[k] for k in present if k in INFO_LEGEND)
    table = Table(title="points", caption=legend or None)
    table.add_column("point")
    for k in present:
        table.add_column(INFO_COLUMNS[k][0], justify="right")
    if any(others):
        table.add_column("other parameters")
    for column in ("samples", "duration (s)", "state"):
        table.add_column(column, justify="left" if column == "state" else "right")
    for p, more in zip(points, others, strict=True):
        cells = [_info_cell(p["params"].get(k), *INFO_COLUMNS[k][1:]) for k in present]
        state = p["state"] if p["complete"] else f"[yellow]{p['state']}[/yellow]"
        table.add_row(
            f"{p['index']:04d}",
            *cells,
            *([more] if any(others) else []),
            str(p["n_samples"]),
            readable.number(p["duration_s"]),
            state,
        )
    return table


def _with_units(name: str, value: Any, format_value) -> str:
    """A parameter's value with its SI units where the vocabulary defines them (a number or a
    list of numbers: ``amplitude_target=0.00032 m``)."""
    text = format_value(value)
    plain = value.tolist() if hasattr(value, "tolist") else value  # numpy arrays and scalars
    items = plain if isinstance(plain, (list, tuple)) else [plain]
    numeric = bool(items) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in items)
    unit = parameter_units(name) if numeric else ""
    return f"{text} {unit}" if unit else text


def _harmonics_table(info: dict, units: dict[str, str]) -> Any:
    """Each point's harmonic amplitudes (peak), a row per channel: the fundamental and the largest
    k >= 2 (its k), a round-off shown as such (:func:`rigtools.readable.harmonic`)."""
    from rich.table import Table

    rows = []
    for p in info["points"]:
        for key, amps in p["params"].items():
            if key.endswith(_HARMONIC_SUFFIX) and amps is not None and len(amps):
                rows.append((p["index"], key[: -len(_HARMONIC_SUFFIX)], [float(a) for a in amps]))
    if not rows:
        return None
    table = Table(
        title="harmonic amplitudes k·fe, peak",
        caption=f"{readable.ROUND_OFF_TEXT}: below 1e-9 of the channel's largest harmonic",
    )
    for column in ("point", "channel", "units", "1×fe", "largest k ≥ 2"):
        table.add_column(column, justify="right" if column[0] in "1l" else "left")
    last = None
    for index, channel, amps in rows:
        if last is not None and index != last:
            table.add_section()
        top = readable.largest(amps)
        largest_k = "–"
        if len(amps) > 1:
            k = 2 + max(range(len(amps) - 1), key=lambda i: abs(amps[i + 1]))
            text = readable.harmonic(amps[k - 1], top)
            largest_k = text if text == readable.ROUND_OFF_TEXT else f"{text} (k = {k})"
        table.add_row(
            f"{index:04d}" if index != last else "",
            channel,
            units.get(channel) or _HARMONIC_UNITS.get(channel, ""),
            readable.harmonic(amps[0], top),
            largest_k,
        )
        last = index
    return table
