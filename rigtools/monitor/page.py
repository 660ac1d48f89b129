"""The monitor's page: one Bokeh document per viewer, drawn from the shared :class:`.follow.Snapshot`.

Bokeh draws everything (Dask's dashboard does the same: column data sources refreshed from a
server-side callback); no JavaScript is written here. Each document is refreshed when the
server makes a new snapshot (and looks every :data:`REFRESH_MS` itself) and sends only when it
changed. Values a script reads off the page
(F1, impacts per period, the newest sample's time) carry element ids: ``mon-f1``, ``mon-ipp``,
``mon-latest-epoch``, ``mon-status``.
"""

from __future__ import annotations

import html
from collections.abc import Callable
from typing import Any

import numpy as np

from rigtools.monitor import controlled
from rigtools.monitor.follow import Snapshot
from rigtools.readable import number

REFRESH_MS = 1000  # a fallback: new snapshots are pushed
#: The traces' axis labels (the channel's name is the plot's title).
SHORT = {"force": "force", "active_shroud_accel": "active", "passive_shroud_accel": "passive"}
COLOURS = {"force": "#1f77b4", "active_shroud_accel": "#d62728", "passive_shroud_accel": "#2ca02c"}
STATUS_COLOURS = {"recording": "#1a7f37", "finished": "#0550ae", "aborted": "#cf222e", "failed": "#cf222e"}


def _num(value: Any, fmt: str | None = None, unit: str = "") -> str:
    """A number as every table of rig shows it (:func:`rigtools.readable.number`)."""
    return number(value, None if fmt in (None, ".4g") else fmt, unit)


def _unit(units: dict[str, str], channel: str) -> str:
    u = units.get(channel) or ""
    return u.replace("m/s^2", "m/s²")


def settled_text(c: dict) -> str:
    """The settled line, consistent with the phase: "no"/"yes" once the point has ended; while it
    records, the steadiness is judged at its end; before that, "not yet"."""
    if c.get("settled") is not None:
        return _num(c.get("settled"))
    if c.get("phase") == "recording":
        return "judged at the end of the record"
    if c.get("phase") == "stopped":
        return "– (stopped before its record)"
    return "not yet"


def header_html(s: Snapshot) -> str:
    colour = STATUS_COLOURS.get(s.status, "#9a6700")
    point = "" if s.point is None else f" · point {s.point + 1} of {max(s.n_points, s.point + 1)}"
    fe = "" if s.fe is None else f" · fe {s.fe:g} Hz"
    epoch = "" if s.latest_epoch is None else f"{s.latest_epoch:.3f}"
    end = f"<div>{html.escape(s.end)}</div>" if s.end else ""
    return (
        f"<div style='font-size:15px'><b>{html.escape(s.path)}</b> · "
        f"<span id='mon-status' style='color:{colour};font-weight:bold'>{html.escape(s.status_text)}</span>"
        f"{point}{fe} · newest sample t = <span id='mon-latest-t'>{s.latest_t:.3f}</span> s"
        f"<span id='mon-latest-epoch' style='display:none'>{epoch}</span>"
        f" · {html.escape(s.window)}</div>{end}"
    )


def control_html(s: Snapshot) -> str:
    c = s.control
    err = c.get("error")
    rows = [
        ("target F0", _num(c.get("target"), unit="N"), "mon-target"),
        ("measured F1", _num(c.get("f1"), unit="N"), "mon-f1"),
        ("drive", _num(c.get("drive"), unit="V"), "mon-drive"),
        ("error", "–" if err is None else _num(err * 100, "+.2f", "%"), "mon-error"),
        ("updates", _num(c.get("updates")), "mon-updates"),
        ("settled", settled_text(c), "mon-settled"),
        ("phase", html.escape(str(c.get("phase") or "–")), "mon-phase"),
        ("impacts per period", _num(s.impacts_per_period), "mon-ipp"),
    ]
    body = "".join(
        f"<tr><td>{k}</td><td id='{i}' style='text-align:right'><b>{v}</b></td></tr>" for k, v, i in rows
    )
    peaks = "".join(_peak_row(p) for p in s.peaks)
    if s.kind:
        title = "phase-locked loop" if s.kind == "pll" else "control-based continuation"
        more = "".join(
            f"<tr><td>{k}</td><td id='{i}' style='text-align:right'><b>{v}</b></td></tr>"
            for k, v, i in controlled.control_rows(s.kind, s)
        )
        body += f"<tr><th colspan=2>{title}</th></tr>{more}"
    return (
        f"<table style='font-size:14px'><tr><th colspan=2>force control</th></tr>{body}</table>"
        f"<table style='font-size:13px;margin-top:8px'><tr><th>channel</th><th>peak</th><th>warning</th>"
        f"<th>abort</th><th></th></tr>{peaks}</table>"
    )


def _peak_row(p: dict) -> str:
    warning, abort, peak = p.get("warning"), p.get("abort"), p["peak"]
    share = "" if not abort else f"{_num(peak / abort * 100, '.0f')} % of abort"
    colour = "#cf222e" if warning and peak >= warning else "inherit"
    u = html.escape(p["units"].replace("m/s^2", "m/s²"))
    return (
        f"<tr style='color:{colour}'><td>{html.escape(p['channel'])}</td><td>{_num(peak, unit=u)}</td>"
        f"<td>{_num(warning, unit=u)}</td><td>{_num(abort, unit=u)}</td><td>{share}</td></tr>"
    )


def points_html(s: Snapshot) -> str:
    if not s.points:
        return "<i>no point yet</i>"
    if s.kind:
        return controlled.points_table(s.kind, s)
    head = "".join(
        f"<th>{h}</th>"
        for h in (
            "point",
            "fe (Hz)",
            "gap (mm)",
            "F0 (N)",
            "F1 (N)",
            "drive (V)",
            "response (m/s²)",
            "dir",
            "impacts/period",
            "settled",
            "state",
        )
    )
    rows = []
    for r in s.points:
        gap = None if r.get("gap") is None else r["gap"] * 1e3
        cells = (
            str(r["point"] + 1),
            _num(r.get("fe")),
            _num(gap),
            _num(r.get("target")),
            _num(r.get("f1")),
            _num(r.get("drive")),
            _num(r.get("response")),
            html.escape(r.get("direction") or ""),
            _num(r.get("impacts_per_period")),
            _num(r.get("settled")),
            html.escape(r.get("state", "")),
        )
        current = " style='background:#fff8c5'" if r["point"] == s.point else ""
        rows.append(f"<tr{current}>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return f"<table id='mon-points' style='font-size:13px'><tr>{head}</tr>{''.join(rows)}</table>"


#: What a study or stepped sine varies, in the order looked for: key, axis label, SI factor.
SWEPT = (("fe", "fe (Hz)", 1.0), ("target", "F0 (N)", 1.0), ("gap", "gap (mm)", 1e3))


def trend_axis(rows: list[dict]) -> tuple[str, str, float]:
    """The parameter the points vary (frequency, force, gap), else the point number."""
    for key, label, factor in SWEPT:
        values = {r.get(key) for r in rows}
        if len(values) > 1 and None not in values:
            return key, label, factor
    return "point", "point", 1.0


#: The trend's series: a stepped sine's up and down sweeps (a study's points: "points").
TREND_SERIES = {
    "up": ("#1f77b4", "circle", "solid"),
    "down": ("#d62728", "triangle", "dashed"),
    "points": ("#555555", "square", "solid"),
}
#: A controlled test's trend (:func:`rigtools.monitor.controlled.trend`): its points by convergence.
CONTROLLED_SERIES = {
    "converged": ("#2ca02c", "diamond", "solid"),
    "not converged": ("#9a6700", "x", "dotted"),
}


def trend_series(rows: list[dict], key: str, factor: float) -> dict[str, dict[str, list]]:
    """The response fundamental of each ended point against ``key`` (in run order), split by the
    sweep's direction: the up and down curves where a jump shows."""
    out: dict[str, dict[str, list]] = {d: {"x": [], "y": []} for d in TREND_SERIES}
    for r in rows:
        d = str(r["direction"]) if r.get("direction") in ("up", "down") else "points"
        out[d]["x"].append(r[key] * factor if key != "point" else r["point"] + 1)
        out[d]["y"].append(r["response"])
    return out


def build(doc, get_snapshot: Callable[[], Snapshot], stop: Callable[[], str] | None) -> Callable[[], None]:
    """Lay out the page on ``doc``; returns its ``refresh()``, which redraws it from
    ``get_snapshot()`` when that changed (the server calls it on every new snapshot; the page
    also looks every :data:`REFRESH_MS` by itself).

    ``stop`` (None: no stop control) sends a stop request and returns the text to show.
    """
    from bokeh.layouts import column, row
    from bokeh.models import ColumnDataSource, DataRange1d, Range1d
    from bokeh.models.annotations import LabelSet
    from bokeh.models.widgets import Button, Div
    from bokeh.plotting import figure

    names = ("force", "active_shroud_accel", "passive_shroud_accel")
    header = Div(text="", sizing_mode="stretch_width")
    control = Div(text="", width=380)
    points = Div(text="", width=720)
    trace_src = {c: ColumnDataSource(data={"t": [], "y": []}) for c in names}
    spec_src = {c: ColumnDataSource(data={"f": [], "a": []}) for c in names}
    harm_src = ColumnDataSource(data={"f": [], "top": [], "bottom": []})
    named_src = ColumnDataSource(data={"f": [], "a": [], "text": []})
    trend_src = {d: ColumnDataSource(data={"x": [], "y": []}) for d in {**TREND_SERIES, **CONTROLLED_SERIES}}

    traces = []
    x_range = DataRange1d()  # shared: the three traces scroll together
    for c in names:
        p = figure(height=170, width=820, title=c, x_range=x_range, tools="pan,wheel_zoom,box_zoom,reset")
        p.line("t", "y", source=trace_src[c], color=COLOURS[c], line_width=1)
        p.yaxis.axis_label = SHORT.get(c, c)
        p.xaxis.axis_label = "time in point (s)"
        traces.append(p)
    spectrum = figure(
        height=300,
        width=820,
        y_axis_type="log",
        title="amplitude spectrum (peak)",
        tools="pan,wheel_zoom,box_zoom,reset",
    )
    spectrum.segment("f", "bottom", "f", "top", source=harm_src, color="#888888", line_dash="dashed")
    for c in names:
        spectrum.line("f", "a", source=spec_src[c], color=COLOURS[c], legend_label=c)
    legend_items = dict(zip(names, spectrum.legend.items, strict=True))
    spectrum.add_layout(
        LabelSet(x="f", y="a", text="text", source=named_src, text_font_size="11px", y_offset=4)
    )
    spectrum.xaxis.axis_label = "frequency (Hz)"
    spectrum.legend.location = "top_right"
    freq_range = Range1d(start=0, end=1000)
    spectrum.x_range = freq_range
    spectrum.yaxis.axis_label = "peak amplitude"
    trend = figure(
        height=260,
        width=720,
        title="response: active shroud acceleration 1×fe (peak) at each point",
        tools="",
    )
    trend_renderers: dict[str, list] = {}
    for d, (colour, marker, dash) in {**TREND_SERIES, **CONTROLLED_SERIES}.items():
        trend_renderers[d] = [
            trend.line("x", "y", source=trend_src[d], color=colour, line_dash=dash, legend_label=d),
            trend.scatter("x", "y", source=trend_src[d], color=colour, size=8, marker=marker, legend_label=d),
        ]
    # bokeh types legend items as LegendItem | tuple; these are LegendItems, labels value specs
    trend_legend: list[Any] = list(trend.legend.items)
    trend_items = {item.label["value"]: item for item in trend_legend}
    trend.legend.location = "top_left"
    trend.legend.orientation = "horizontal"
    trend.xaxis.axis_label = "point"
    trend.yaxis.axis_label = "active shroud 1×fe, peak (m/s²)"

    widgets: list[Any] = [control]
    if stop is not None:
        button = Button(label="stop the run (drive ramps to zero)", button_type="danger", width=300)
        said = Div(text="")

        def on_stop() -> None:
            said.text = html.escape(stop())
            button.disabled = True

        button.on_click(on_stop)
        widgets += [button, said]
    doc.add_root(
        column(
            header,
            row(column(*traces, spectrum), column(*widgets, trend, points)),
            sizing_mode="stretch_width",
        )
    )
    doc.title = "rig monitor"
    seen = {"version": -1}

    def refresh() -> None:
        s = get_snapshot()
        if s.version == seen["version"]:
            return
        seen["version"] = s.version
        header.text = header_html(s)
        control.text = control_html(s)
        points.text = points_html(s)
        for c, p in zip(names, traces, strict=True):
            p.yaxis.axis_label = f"{SHORT.get(c, c)} ({_unit(s.units, c)})" if s.units.get(c) else c
        shown_units = list(dict.fromkeys(_unit(s.units, c) for c in names if s.units.get(c)))
        spectrum.yaxis.axis_label = "peak amplitude" + (f" ({'; '.join(shown_units)})" if shown_units else "")
        for c, item in legend_items.items():
            item.label = {"value": f"{c} ({_unit(s.units, c)})" if s.units.get(c) else c}  # type: ignore[attr-defined]  # a bokeh LegendItem
        for c in names:
            t, y = s.traces.get(c, (np.empty(0), np.empty(0)))
            trace_src[c].data = {"t": t, "y": y}
            f, a = s.spectrum.get(c, (np.empty(0), np.empty(0)))
            keep = a > 0
            spec_src[c].data = {"f": f[keep], "a": a[keep]}
        top = max((float(np.max(a)) for _, a in s.spectrum.values() if len(a)), default=1.0)
        bottom = max(top * 1e-6, 1e-12)
        harm_src.data = {
            "f": [f for _, f in s.harmonics],
            "top": [top] * len(s.harmonics),
            "bottom": [bottom] * len(s.harmonics),
        }
        named_src.data = {
            "f": [f for _, f, _, _ in s.named],
            "a": [a for _, _, a, _ in s.named],
            "text": [f"{k}·fe {a:.3g}" for k, _, a, _ in s.named],
        }
        if s.fe:
            freq_range.end = min(s.fe * (len(s.harmonics) + 1.5), 25_000)
        shown = CONTROLLED_SERIES if s.kind else TREND_SERIES
        for d, renderers in trend_renderers.items():
            for r in renderers:
                r.visible = d in shown
            trend_items[d].visible = d in shown
        if s.kind:
            title, xlabel, ylabel = controlled.TRENDS[s.kind]
            trend.title.text = title  # type: ignore[union-attr]  # a bokeh Title
            trend.xaxis.axis_label, trend.yaxis.axis_label = xlabel, ylabel
            for d, series in controlled.trend(s.kind, s.points).items():
                trend_src[d].data = series  # type: ignore[assignment]  # bokeh takes a dict of columns
            return
        rows = [r for r in s.points if r.get("response") is not None]
        key, label, factor = trend_axis(rows)
        trend.xaxis.axis_label = label
        for d, series in trend_series(rows, key, factor).items():
            trend_src[d].data = series  # type: ignore[assignment]  # bokeh takes a dict of columns

    refresh()
    doc.add_periodic_callback(refresh, REFRESH_MS)
    return refresh
