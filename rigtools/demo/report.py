"""The demo's one HTML report (:mod:`rigtools.report.html`): findings first, then each step's
tables and figures (every axis labelled, with units)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rigtools.analysis.branches import explain_jumps, turning_points
from rigtools.analysis.plots import log_bar_axis
from rigtools.branches_figure import branch_curves
from rigtools.demo.findings import Finding, em_to_fem_ratios, mark
from rigtools.demo.steps import flexural
from rigtools.measured_sweeps import measured_sweeps
from rigtools.report import Report
from rigtools.report.branches import add_branches, fixed_text
from rigtools.sim.channel_names import FORCE, SHROUD_ACCELS

CH = (
    ("force", "force sensor (N)"),
    ("active_shroud_accel", "active shroud accel. (m/s²)"),
    ("passive_shroud_accel", "passive shroud accel. (m/s²)"),
)


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def check_labels(fig):
    """The figure, after checking every visible axes has an x and a y label (a twin axes shares its
    partner's x label)."""
    for ax in fig.axes:
        if not ax.get_visible():
            continue
        shared_x = any(o is not ax and o.bbox.bounds == ax.bbox.bounds for o in fig.axes)
        below = any(o is not ax and o.get_shared_x_axes().joined(o, ax) for o in fig.axes)
        if not ax.get_ylabel() or not (ax.get_xlabel() or shared_x or below):
            raise ValueError(f"figure {ax.get_title() or fig.axes[0].get_title()!r}: an axis has no label")
    return fig


UPDATE_UNITS = {"root.rotational_stiffness": "N·m/rad", "root.translational_stiffness": "N/m"}


def _f1(run: dict) -> float | None:
    """The force fundamental (harmonic 1, peak) of a dwell run: what the force control holds."""
    h = run.get("harmonics", {}).get(FORCE)
    return float(h[0]) if h else run.get("force_amplitude_measured")


def _legend(ax) -> None:
    """A legend beside the axes (right), never over the data."""
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)


def frf_figure(modal: dict):
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 3.6))
    f = np.asarray(modal["frf"]["frequency_hz"])
    lo, hi = modal["frf"].get("band", (f[1], f[-1]))
    shown = (f >= lo) & (f <= hi)  # the excited band: outside it H1 is noise over noise
    ax.semilogy(
        f[shown], np.asarray(modal["frf"]["h"])[shown], label="simulated rig (EM), H1 active shroud / force"
    )
    for e in modal["fem"]["active"]:
        if e["kind"] == "flexural" and lo <= e["frequency_hz"] <= hi:
            ax.axvline(e["frequency_hz"], color="C1", ls="--", lw=0.8)
    ax.plot([], [], "--", color="C1", label="FEM flexural frequencies")
    ax.set_xlim(lo, hi)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("|accelerance| (m/s²/N)")
    ax.set_title(
        f"Modal check: FRF of the simulated rig, excited band {lo:g}-{hi:g} Hz (paper Fig. 6)", fontsize=10
    )
    _legend(ax)
    fig.tight_layout()
    return fig


def harmonic_figure(h: dict):
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 3.6))
    for i, loc in enumerate(("active_shroud", "passive_shroud")):
        ax.semilogy(h["frequency_hz"], h["fem"][loc], color=f"C{i}", label=f"FEM {loc.replace('_', ' ')}")
        ax.semilogy(
            h["frequency_hz"], h["am"][loc], "--", color=f"C{i + 2}", label=f"AM {loc.replace('_', ' ')}"
        )
    ax.set_xlabel("excitation frequency (Hz)")
    ax.set_ylabel("acceleration amplitude (m/s²)")
    ax.set_title("Linear harmonic response at 15 N, FEM vs AM (paper Fig. 7)")
    _legend(ax)
    fig.tight_layout()
    return fig


def waveform_figure(d: dict, title: str):
    plt = _plt()
    fig, axes = plt.subplots(3, 1, figsize=(9, 6.4), sharex=True)
    for ax, (ch, label) in zip(axes, CH, strict=True):
        for key, style, name in (
            ("em_wave", "-", "EM (simulated rig)"),
            ("fem_wave", "--", "FEM"),
            ("am_wave", ":", "AM"),
        ):
            w = d[key]
            ax.plot(w["time_s"] * 1e3, w[ch], style, lw=1, label=name)
        ax.set_ylabel(label, fontsize=8)
    _legend(axes[0])
    axes[-1].set_xlabel("time (ms), last three periods")
    axes[0].set_title(title)
    fig.tight_layout()
    return fig


def spectrum_figure(d: dict, title: str):
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))

    for ax, ch in zip(axes, SHROUD_ACCELS, strict=True):
        bars = []
        for j, (key, name) in enumerate((("em", "EM"), ("fem", "FEM"), ("am", "AM"))):
            a = np.asarray(d[key]["harmonics"][ch])
            k = np.arange(1, a.size + 1)
            ax.bar(k + (j - 1) * 0.27, a, width=0.27, label=name)
            bars.append(a)
        log_bar_axis(ax, bars)
        ax.set_xlabel("harmonic k (frequency k·fe)")
        ax.set_ylabel(f"{ch.replace('_accel', '').replace('_', ' ')} accel. (m/s²)", fontsize=9)
    _legend(axes[-1])
    axes[0].set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def study_figure(study: dict, kind: str, label: str):
    plt = _plt()
    unit, scale = {"gap": ("mm", 1e3), "force": ("N", 1.0), "frequency": ("Hz", 1.0)}[kind]
    rig = sorted(study["rig"]["points"], key=lambda p: p["value"])
    fem = sorted(study["fem"]["points"], key=lambda p: p["value"])
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 3.4))
    ax.plot(
        [p["value"] * scale for p in rig], [p["impulse_level"] for p in rig], "o-", label="EM (simulated rig)"
    )
    ax.plot([p["value"] * scale for p in fem], [p["impulse_level"] for p in fem], "s--", label="FEM")
    ax.set_xlabel(f"{kind} ({unit})")
    ax.set_ylabel("impact level (m/s²)", fontsize=9)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.28), ncol=2)
    ax2.plot(
        [p["value"] * scale for p in fem],
        [p["peak_contact_force_n"] for p in fem],
        "s--",
        color="C1",
        label="FEM peak contact force",
    )
    ax2.set_xlabel(f"{kind} ({unit})")
    ax2.set_ylabel("peak contact force (N)", fontsize=9)
    ax3 = ax2.twinx()
    ax3.plot(
        [p["value"] * scale for p in rig],
        [p["impacts_per_period"] for p in rig],
        "o:",
        color="C2",
        label="EM impacts per period (right axis)",
    )
    ax3.set_ylabel("impacts per period (EM)", fontsize=9)
    # one legend for both y axes, below the axes (never over the data)
    h2, l2 = ax2.get_legend_handles_labels()
    h3, l3 = ax3.get_legend_handles_labels()
    ax2.legend(h2 + h3, l2 + l3, fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.28), ncol=2)
    ax.set_title(f"{kind} study, {label}", fontsize=10)
    fig.tight_layout()
    return fig


def gap_trend_figure(data: dict):
    """The README's figure: impact strength against the gap at both points, rig and FEM."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    for ax, key in zip(axes, ("paper", "equivalent"), strict=True):
        st = data["studies"][("gap", key)]
        for src, style, name in (("rig", "o-", "EM (simulated rig)"), ("fem", "s--", "FEM")):
            pts = sorted(st[src]["points"], key=lambda p: p["value"])
            ax.plot([p["value"] * 1e3 for p in pts], [p["impulse_level"] for p in pts], style, label=name)
        pt = data["points"][key]
        ax.set_title(f"{pt.label}, F0 = {pt.force:.3g} N", fontsize=10)
        ax.set_xlabel("shroud gap (mm)")
        ax.set_ylabel("impact level (m/s²)", fontsize=9)
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2)
    fig.tight_layout()
    return fig


def _frequency_lead(curves) -> str:
    """What the frequency branch explains of C6 at the paper's point: where the impacts end."""
    turns = [t for t in turning_points(curves[0])] if curves else []
    upper = [t for t in turns if t.upper]
    lower = [t for t in turns if not t.upper]
    if not upper:
        return ""
    text = (
        "C6 at the paper's point: the impacts grow with fe and then vanish at once. The FEM's "
        f"impacting orbit grows up to its fold (LP) at {upper[0].value:.4g} Hz and ends there; above "
        "it only the orbit without impacts is left"
    )
    if lower:
        text += (
            f", which, coming down in fe, lasts to the grazing corner at {lower[-1].value:.4g} Hz "
            "where impacts begin again"
        )
    return text + "."


def _gap_lead(branches, gaps) -> str:
    """What the gap branch explains of C4 at the paper's point: the trend along a stable branch."""
    p1 = next((b for b in branches if b.periods == 1 and b.value.size > 1), None)
    if p1 is None or not np.all(np.diff(p1.value) > 0):
        return ""
    lo, hi = min(gaps), max(gaps)
    inside = (p1.value >= lo) & (p1.value <= hi)
    force = p1.measures["peak_contact_force"]
    a, b = np.interp([lo, hi], p1.value, force)
    trend = "grows" if b > a else "falls"
    stable = "stable" if p1.stable[inside].all() else "not stable everywhere"
    return (
        f"C4 at the paper's point: over the studied gaps ({lo * 1e3:g} to {hi * 1e3:g} mm) the FEM's "
        f"period-1 orbit is {stable} and its peak contact force {trend} along it from {a:.3g} to "
        f"{b:.3g} N: the trend is the branch's own slope, with no jump between the studied gaps."
    )


def _shift_sentence(explanations, modal: dict) -> str:
    """The rig's jumps against the FEM's turning points lowered by the rig's own offset from the
    FEM in natural frequency (C1): a softer rig moves its resonance and, to first order, its
    turning points down by the same ratio."""
    em = [e for e in explanations if e.sweep.startswith("EM") and e.turning is not None and not e.inside]
    ratios = em_to_fem_ratios(
        flexural(modal["fem"]["active"]), [m["frequency_hz"] for m in modal["em"]["active"]]
    )
    if not em or not ratios:
        return ""
    lo, hi = min(ratios), max(ratios)
    parts, overlap = [], []
    for e in em:
        a, b = e.turning.value * lo, e.turning.value * hi
        parts.append(f"the {LABEL_NAMES[e.turning.label]} at {a:.4g}-{b:.4g} Hz")
        overlap.append(a <= e.stop and b >= e.start)
    jumps = ", ".join(f"{e.start:g}-{e.stop:g} Hz" for e in em)
    verdict = "overlapping" if all(overlap) else "some still off" if any(overlap) else "still off"
    return (
        f"The rig's identified natural frequencies lie {abs(hi - 1) * 100:.1f} to {abs(lo - 1) * 100:.1f} % "
        f"{'below' if hi < 1 else 'around'} the FEM's (C1); lowered by as much, the FEM's turning points "
        f"fall at {' and '.join(parts)}, {verdict} the rig's jumps ({jumps})."
    )


LABEL_NAMES = {"fold": "fold", "grazing": "grazing corner"}


def study_branches(
    section, kind: str, study: dict, branch: dict, sweep: dict | None, modal: dict | None = None
) -> None:
    """The FEM's branch of ``kind`` (:func:`rigtools.demo.steps.branches_step`) where the report
    shows that study at the paper's point (:func:`rigtools.report.branches.add_branches`): in
    frequency with the simulated rig's stepped sine up and down (``sweep``,
    :func:`rigtools.demo.steps.sweep_step`) and the FEM study's points, in the active shroud's
    fundamental acceleration (what the rig measures); in gap with the FEM study's points in peak
    contact force (the rig has no contact force sensor; its impact level is in the figure
    above)."""
    from dataclasses import replace

    stored = branch["branches"]
    if kind == "frequency":
        measure = "accel1"
        sources = [("FEM frequency study", study["fem"]["file"])]
        if sweep is not None:
            sources.insert(0, ("EM stepped sine", sweep["file"]))
        lead = _frequency_lead(branch_curves(stored, measure))
    else:
        measure = "contact"
        sources = [("FEM gap study", study["fem"]["file"])]
        lead = _gap_lead(stored, [p["value"] for p in study["fem"]["points"]])
    param = branch["experiment"]["param"]
    measured = [
        replace(m, name=f"{name} ({m.direction})")
        for name, path in sources
        for m in measured_sweeps([path], param, measure)
    ]
    tail = ""
    if kind == "frequency" and modal is not None:
        tail = _shift_sentence(explain_jumps(branch_curves(stored, measure), measured), modal)
    add_branches(
        section,
        stored,
        measured,
        measure=measure,
        what=f"FEM branches in {param} ({fixed_text(branch['experiment'])})",
        lead=lead,
        tail=tail,
    )


def build_report(data: dict, findings: list[Finding], out_dir: Path):
    """The :class:`rigtools.report.Report` of a demo run."""
    pts = data["points"]
    rep = Report(
        "rig demo: the paper's study on the simulated rig",
        f"settings {data['settings']}; f1 = {data['info']['f1_hz']:.2f} Hz; free amplitude "
        f"{data['info']['free_amplitude_m'] * 1e3:.2f} mm",
    )
    s = rep.section("Findings C1-C7, judged from the data")
    s.text(
        "Each finding is judged at the paper's point and at the equivalent impact-oscillator point "
        f"({pts['equivalent'].label}, F0 = {pts['equivalent'].force:.1f} N keeps the paper's free amplitude) "
        "on what a lab measures: the force sensor, the shroud accelerations and impacts per period found "
        "from them; the model's contact force is quoted beside. Impact level: the impulsive (high-passed) "
        "part of the passive shroud acceleration at the impacts, which follows the contact force's "
        "jump at each impact."
    )
    s.table(
        [
            {
                "finding": f.id,
                "claim": f.claim,
                **{f"{pts[k].label}": f"{mark(v.holds)} {v.why}" for k, v in f.verdicts.items()},
            }
            for f in findings
        ]
    )
    if "equivalent" in pts and data["safety_note"]:
        s.note(data["safety_note"])
    m = data["modal"]
    s = rep.section("Modal check (paper Tables 2-3, Fig. 6)")
    rows = []
    for blade in ("active", "passive"):
        fem = [e for e in m["fem"][blade] if e["kind"] == "flexural"]
        for i, e in enumerate(fem[:3]):
            em = (
                m["em"]["active"][i]["frequency_hz"]
                if blade == "active" and i < len(m["em"]["active"])
                else None
            )
            rows.append(
                {
                    "blade": blade,
                    "mode": f"flexural {i + 1}",
                    "FEM (Hz)": e["frequency_hz"],
                    "AM (Hz)": m["am"][blade][i]["frequency_hz"],
                    "EM identified (Hz)": em,
                }
            )
    s.table(
        rows,
        caption="natural frequencies (EM: FRF test on the simulated rig, gap open; the passive "
        "blade is not driven with the gap open)",
    )
    s.figure(
        check_labels(frf_figure(m)),
        "FRF of the simulated rig's active shroud over the force, with the FEM frequencies",
    )
    s = rep.section("Harmonic response (paper Fig. 7)")
    s.figure(
        check_labels(harmonic_figure(data["harmonic"])),
        "linear amplitude-frequency curves of the shroud accelerations",
    )
    for key, d in data["dwell"].items():
        s = rep.section(
            f"Dwell at {pts[key].label}, F0 = {d['force']:.1f} N, gap {d['gap'] * 1e3:g} mm (Figs. 8-9)"
        )
        s.table(
            [
                {
                    "run": name,
                    "F1, controlled force fundamental (N)": _f1(d[k]),
                    "force peak (N)": d[k]["force_peak_n"],
                    "active accel. peak (m/s²)": d[k]["active_accel_peak"],
                    "passive accel. peak (m/s²)": d[k]["passive_accel_peak"],
                    "impacts/period": d[k]["impacts_per_period"],
                    "peak contact force (N)": d[k].get("peak_contact_force_n"),
                }
                for k, name in (("em", "EM (simulated rig)"), ("fem", "FEM"), ("am", "AM"))
            ]
        )
        s.figure(
            check_labels(waveform_figure(d, f"waveforms at {pts[key].label}")),
            "force and shroud accelerations, EM vs FEM vs AM",
        )
        s.figure(
            check_labels(spectrum_figure(d, f"harmonics at {pts[key].label}")),
            "shroud acceleration harmonics k·fe",
        )
    s = rep.section("Gap, force and frequency studies (Figs. 10-16)")
    s.figure(
        check_labels(gap_trend_figure(data)),
        "impact strength against the gap: reversed at the paper's "
        "point, as the paper reports at the equivalent point",
    )
    branches = data.get("branches") or {}
    for (kind, key), st in data["studies"].items():
        s.figure(
            check_labels(study_figure(st, kind, pts[key].label)),
            f"{kind} study at {pts[key].label}: measured on the simulated rig and simulated by the FEM",
        )
        if key == "paper" and kind in branches:
            study_branches(s, kind, st, branches[kind], data.get("sweep"), data["modal"])
    u = data["update"]
    s = rep.section("Model updating on the identified modes")

    def values(kind: str) -> str:
        return ", ".join(
            f"{n} = {v:.4g} {UPDATE_UNITS.get(n, '')}".rstrip() for n, v in u.get(kind, {}).items()
        )

    s.text(f"fitted {values('fitted')} (start {values('initial')})")
    s.table(
        [
            {
                "mode (blade, flexural order)": m["mode"],
                "identified on the rig (Hz)": m["measured_hz"],
                "model before (Hz)": m["before_hz"],
                "model after (Hz)": m["after_hz"],
                "after vs identified (%)": 100.0 * (m["after_hz"] - m["measured_hz"]) / m["measured_hz"],
            }
            for m in u["modes"]
        ],
        caption="natural frequencies before and after the update",
    )
    s = rep.section("Files")
    s.table(
        [{"file": Path(f).name} for f in data["files"]]
        + [{"file": Path(b["file"]).name} for b in branches.values()]
    )
    return rep
