"""What the monitor shows of a controlled test (phase-locked loop, control-based continuation).

A PLL is watched by its phase and lock: the phase of the response's fundamental to the force's,
measured live from the last whole periods (:func:`live_phase_deg`), and where the loop is
(locking, locked and recording, a point locked or not). A CBC by its control effort and
iterations per point. Both by their points growing: A against fe (PLL, the backbone or the
response curve it traces), F1 against A (CBC, its S-curve). The numbers of an ended point are the
ones its procedure wrote (the :class:`rigtools.controlled_point.ControlledPoint`
fields, ``control_effort``, ``phase_error_rms``), so the page shows what ``rig report`` tables.
"""

from __future__ import annotations

import html
import json
import math
from typing import Any

import numpy as np

from rigtools.readable import number

#: The recordings' procedure kinds shown as controlled tests.
KINDS = ("pll", "cbc")
#: Point attributes copied into a point's row (SI, as written).
ROW_FIELDS = (
    "fe_hz",
    "amplitude_m",
    "force_fundamental_n",
    "phase_deg",
    "phase_target",
    "converged",
    "iterations",
    "drive_harmonics_ratio",
    "control_effort",
    "phase_error_rms",
)
#: Live event kinds of the PLL (:mod:`rigtools.procedures.pll_run`) in words.
PLL_STATES = {"control": "locking", "recording": "locked, recording", "point": "starting the point"}


def procedure_kind(rec: Any) -> str:
    """``"pll"``, ``"cbc"`` or ``""`` from a recording's experiment (its ``parameters.kind``)."""
    try:
        params = json.loads(str(rec.attrs.get("experiment") or "{}")).get("parameters") or {}
    except (TypeError, ValueError):
        return ""
    kind = str(params.get("kind") or "")
    return kind if kind in KINDS else ""


def row_fields(params: Any) -> dict[str, Any]:
    """The controlled fields a point carries, as plain values (absent ones left out)."""
    out: dict[str, Any] = {}
    for name in ROW_FIELDS:
        value = _plain(name, params.get(name))
        if value is not None:
            out[name] = value
    return out


def _plain(name: str, value: Any) -> bool | int | float | None:
    """One field as a plain value; ``None`` when absent or not what the procedure writes (a
    script's edit, "sixty" for fe_hz: the row leaves it out rather than the page failing)."""
    if value is None or isinstance(value, (str, bytes)):
        return None
    try:
        if name == "converged":
            return bool(value) if int(value) in (0, 1) else None
        return int(value) if name == "iterations" else float(value)
    except (TypeError, ValueError, OverflowError):
        return None


def live_phase_deg(
    force: np.ndarray, accel: np.ndarray, rate: float, fe: float, harmonic_amplitudes
) -> float:
    """Phase of the displacement's fundamental to the force's, deg in (-360, 0]: the acceleration's
    fundamental phase less the force's, less 180 deg (displacement = -acceleration / w^2), over
    whole periods (both channels sampled together, so no converter delay enters)."""
    pf = float(harmonic_amplitudes(force, rate, fe, 1).phase[0])
    pa = float(harmonic_amplitudes(accel, rate, fe, 1).phase[0])
    deg = math.degrees(pa - pf) - 180.0
    return -((-deg) % 360.0)


def state_text(kind: str, control: dict, event: dict | None, rows: list[dict], point: int | None) -> str:
    """Where the procedure is: a PLL's lock state, a CBC's iteration state."""
    row = next((r for r in rows if r.get("point") == point), None)
    if row is not None and "converged" in row:
        done = "locked" if kind == "pll" else "converged"
        return done if row["converged"] else f"NOT {done}"
    ev = event or {}
    if kind == "pll":
        return PLL_STATES.get(str(ev.get("kind") or control.get("phase") or ""), str(ev.get("kind") or "–"))
    return str(ev.get("text") or ev.get("kind") or "–")


def control_rows(kind: str, s: Any) -> list[tuple[str, str, str]]:
    """The control panel's rows of a controlled test: ``(label, value html, element id)``."""
    rows = [r for r in s.points if "amplitude_m" in r]
    last = rows[-1] if rows else {}
    phase = s.phase_deg if s.phase_deg is not None else last.get("phase_deg")
    out = [
        ("phase of A to F1", number(phase, ".2f", "deg"), "mon-phase-deg"),
        ("lock" if kind == "pll" else "state", html.escape(s.controlled_state or "–"), "mon-lock"),
    ]
    if kind == "pll":
        target = last.get("phase_target")
        out.append(("phase target", number(target, ".1f", "deg"), "mon-phase-target"))
        out.append(
            (
                "phase error RMS (last point)",
                number(last.get("phase_error_rms"), ".3g", "deg"),
                "mon-phase-rms",
            )
        )
        out.append(("periods to lock (last point)", number(last.get("iterations")), "mon-iterations"))
    else:
        out.append(
            ("control effort (last point)", number(last.get("control_effort"), ".3g", "V"), "mon-effort")
        )
        out.append(("iterations (last point)", number(last.get("iterations")), "mon-iterations"))
        out.append(
            (
                "drive harmonics 2-10 (last point)",
                number(last.get("drive_harmonics_ratio"), ".2g"),
                "mon-drive-harm",
            )
        )
    return out


def points_table(kind: str, s: Any) -> str:
    """The points table of a controlled test (the numbers each point was written with)."""
    last = "phase RMS (deg)" if kind == "pll" else "effort (V)"
    head = "".join(
        f"<th>{h}</th>"
        for h in (
            "point",
            "fe (Hz)",
            "A (mm)",
            "F1 (N)",
            "phase (deg)",
            "converged",
            "iterations",
            last,
            "state",
        )
    )
    body = []
    for r in s.points:
        a = r.get("amplitude_m")
        cells = (
            str(r["point"] + 1),
            number(r.get("fe_hz", r.get("fe")), ".4f"),
            number(None if a is None else a * 1e3, ".4f"),
            number(r.get("force_fundamental_n", r.get("f1")), ".4g"),
            number(r.get("phase_deg"), ".2f"),
            "–" if "converged" not in r else ("yes" if r["converged"] else "NO"),
            number(r.get("iterations")),
            number(r.get("phase_error_rms" if kind == "pll" else "control_effort"), ".3g"),
            html.escape(r.get("state", "")),
        )
        current = " style='background:#fff8c5'" if r["point"] == s.point else ""
        body.append(f"<tr{current}>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return f"<table id='mon-points' style='font-size:13px'><tr>{head}</tr>{''.join(body)}</table>"


#: The trend of a controlled test: (title, x label, y label), the x and y of each point.
TRENDS = {
    "pll": ("the points: A against fe", "fe (Hz)", "A: active shroud displacement, 1×fe (mm)"),
    "cbc": ("the S-curve: F1 against A", "A: active shroud displacement, 1×fe (mm)", "F1: force 1×fe (N)"),
}


def trend(kind: str, rows: list[dict]) -> dict[str, dict[str, list]]:
    """The trend's points: ``converged`` and ``not converged`` series of x and y (units as
    :data:`TRENDS` labels them)."""
    out: dict[str, dict[str, list]] = {"converged": {"x": [], "y": []}, "not converged": {"x": [], "y": []}}
    for r in rows:
        if "amplitude_m" not in r:
            continue
        a = r["amplitude_m"] * 1e3
        x, y = (r["fe_hz"], a) if kind == "pll" else (a, r["force_fundamental_n"])
        series = out["converged" if r.get("converged") else "not converged"]
        series["x"].append(x)
        series["y"].append(y)
    return out
