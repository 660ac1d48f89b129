"""What ``rig acquire`` shows of a procedure's result: its tables and summary lines (rich
renderables), built from the ``--json`` document (:mod:`rigtools.procedures.from_options`)."""

from __future__ import annotations

from typing import Any

from rigtools.readable import ROUND_OFF_TEXT, harmonic, largest, number


def _largest_k(top: dict | None, biggest: float) -> str:
    """The largest k >= 2 harmonic and its k; a round-off (every k >= 2 is then) without a k."""
    if top is None:
        return "–"
    text = harmonic(top["amplitude"], biggest)
    return text if text == ROUND_OFF_TEXT else f"{text} (k = {top['k']})"


def summary_tables(doc: dict) -> list[Any]:
    """What ``rig acquire`` prints of a :func:`rigtools.procedures.from_options.result_document`:
    rich tables and lines, in order."""
    from rich.table import Table

    out: list[Any] = []
    name = doc["procedure"]
    if name == "dwell" and "fe" in doc:
        table = Table(
            title=f"sine dwell {doc['fe']:g} Hz, F0 {doc['force_amplitude']:g} N ({doc['backend']})"
        )
        for col in ("channel", "units", "1×fe", "largest k×fe, k ≥ 2", "peak"):
            table.add_column(col)
        for channel, ch in doc["channels"].items():
            h = ch["harmonics"]
            top = max(h[1:], key=lambda r: r["amplitude"]) if len(h) > 1 else None
            biggest = largest(r["amplitude"] for r in h)
            table.add_row(
                channel,
                ch["units"],
                harmonic(h[0]["amplitude"], biggest),
                _largest_k(top, biggest),
                number(ch["peak"]),
            )
        out.append(table)
        out.append(
            f"force {number(doc['force_amplitude_measured'])} N (target {doc['force_amplitude']:g} N) at "
            f"{number(doc['drive_amplitude'])} V after {doc['control_updates']} updates; settled: "
            f"{'yes' if doc['settled'] else 'NO'}; wrote {doc['file']} ({doc['status']})"
        )
    elif name in ("sweep", "study"):
        table = Table(title=f"{name} ({doc['backend']}, {len(doc['points'])} points)")
        for col in ("fe Hz", "dir", "F0 N", "F1 N", "gap mm", "drive V", "updates", "settled"):
            table.add_column(col)
        for p in doc["points"]:
            table.add_row(
                f"{p['fe']:g}",
                p.get("direction", ""),
                f"{p['force_amplitude']:g}",
                number(p["force_amplitude_measured"]),
                number(p["gap"] * 1e3),
                number(p["drive_amplitude"]),
                str(p["control_updates"]),
                "yes" if p["settled"] else "NO",
            )
        out.append(table)
        for d, jumps in doc.get("jumps", {}).items():
            for j in jumps:
                why = f"; {j['evidence']}" if j.get("evidence") else ""
                out.append(
                    f"jump {d}: {j['from_hz']:g} -> {j['to_hz']:g} Hz ({j['kind']}, {j['change'] * 100:.0f} %{why})"
                )
        if "peak_hz" in doc:
            out.append(f"response peak per newton at {doc['peak_hz']:.4g} Hz")
        out.append(f"wrote {doc['file']} ({doc['status']})")
    elif name == "cbc":
        table = Table(
            title=f"control-based continuation ({doc['backend']}, {doc.get('inner_loop', '')} loop)"
        )
        for col in (
            "fe Hz",
            "A mm",
            "F1 N",
            "phase deg",
            "converged",
            "iterations",
            "drive 2-10 %",
            "effort V",
        ):
            table.add_column(col)
        for p in doc["points"]:
            table.add_row(
                f"{p['fe_hz']:g}",
                f"{p['amplitude_m'] * 1e3:.4f}",
                number(p["force_fundamental_n"]),
                f"{p['phase_deg']:.1f}",
                "yes" if p["converged"] else "NO",
                str(p["iterations"]),
                f"{p['drive_harmonics_ratio'] * 100:.2f}",
                number(p["control_effort"]),
            )
        out.append(table)
        if doc.get("release"):
            out.append(f"gains at zero: the response leaves at {doc['release']['growth_rate']:.3g} 1/s")
        out.append(f"wrote {doc['file']} ({doc['status']})")
    elif name == "tap":
        out.append(
            f"{doc.get('accepted', 0)} of {doc.get('hits', 0)} hits accepted on "
            f"{doc.get('response', '')} / {doc.get('hammer', '')}"
        )
        for h in doc.get("hits_detail", []):
            if not h["accepted"]:
                out.append(f"hit {h['hit']} rejected: {h['reject_reason']}")
        if doc.get("modes"):
            table = Table(title="modes from H1 (response / hammer force)")
            for col in ("frequency Hz", "damping %"):
                table.add_column(col)
            for m in doc["modes"]:
                table.add_row(f"{m['frequency_hz']:.2f}", f"{m['damping_ratio'] * 100:.2f}")
            out.append(table)
        out.append(f"wrote {doc['file']} ({doc['status']})")
    elif name == "pll":
        out.extend(pll_table(doc))
    elif name == "frf":
        chk = doc.get("check")
        if chk:
            table = Table(
                title=f"H1 {chk['response']}/{chk['force']}: {chk['averages']} averages, "
                f"{chk['resolution_hz']:g} Hz resolution"
            )
            for col in ("peak Hz", f"|H1| {chk.get('h1_units', '')}".rstrip(), "coherence"):
                table.add_column(col)
            for pk in chk["peaks"]:
                table.add_row(f"{pk['frequency_hz']:g}", f"{pk['h1']:.4g}", f"{pk['coherence']:.4f}")
            out.append(table)
        out.append(f"wrote {doc['file']} ({doc['status']})")
    return out


def pll_table(doc: dict) -> list[Any]:
    """The points of a phase-locked-loop run (:mod:`rigtools.procedures.pll`) and its end line."""
    from rich.table import Table

    table = Table(title=f"phase-locked loop ({doc['backend']}, {len(doc['points'])} points)")
    for col in ("fe Hz", "A mm", "F1 N", "phase deg", "locked", "periods", "drive harm."):
        table.add_column(col)
    for p in doc["points"]:
        table.add_row(
            f"{p['fe_hz']:.4f}",
            f"{p['amplitude_m'] * 1e3:.4f}",
            number(p["force_fundamental_n"]),
            f"{p['phase_deg']:.2f}",
            "yes" if p["converged"] else "NO",
            str(p["iterations"]),
            f"{p['drive_harmonics_ratio']:.2g}",
        )
    lines: list[Any] = [table]
    if doc.get("stopped"):
        lines.append(doc["stopped"])
    lines.append(f"wrote {doc['file']} ({doc['status']})")
    return lines
