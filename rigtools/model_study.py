"""A model study from options to a finished recording (``rig study``): the plan of the values or
the gap x F0 x fe map, the recording's life cycle (created, streamed point by point, ended with
status ``aborted`` and the reason on a stop or an error, closed) and the study figure.

The points run through :func:`rigtools.simulation.write_study` (each written as soon as it
settles; in-process or on a Dask cluster by :class:`rigtools.study_runner.StudyRunner`).
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path
from typing import Any

from rigtools.errors import Interrupted, UserError, exit_status_help, one_line
from rigtools.options import MAX_POINTS, gap, quantity, swept_not_fixed, value_list

EPILOG = (
    """\
The paper's studies (Figures 10-16): each value is run to a steady state and recorded as one
point of a single HDF5 file (backend "fem", the channels and point parameters of
`rig simulate`, plus direction and study_value). Fixed parameters default to the paper's: gap
study at F0 = 15 N, fe = 60 Hz; force study at gap 0.7 mm, fe = 60 Hz; frequency study at
gap 0.7 mm, F0 = 15 N.

--values is a comma list ("0.3 mm,0.5 mm,0.7 mm") or start:stop:step ("0.3 mm:0.9 mm:0.1 mm",
stop included), at most 10000 points, with units; a plain number is SI (m, N, Hz), so write
gaps with "mm" (a gap above 50 mm is refused).
Points run in sweep order and each starts from the previous point's state (as a slow sweep on
the rig does), so --direction both shows jumps and hysteresis; --from-rest starts each from rest.

Each point is written to FILE as soon as it has settled, so nothing finished is lost: on Ctrl-C,
SIGTERM or SIGHUP the file keeps every finished point and ends with status "aborted" and the
reason; after a crash or SIGKILL it keeps every point finished before (readable while the study
runs, e.g. by rig info). Memory does not grow with the number of points.

--json prints {"kind", "fixed", "points": [{"value", "direction", "fe", "force_amplitude",
"force_amplitude_measured", "gap", "steady_state", "peak_contact_force_n", "impacts_per_period",
"harmonics": {channel: [{"k", "frequency_hz", "amplitude"}, ...]}}, ...], "plot": PNG path or
null}.

Plot: FILE.png beside FILE.h5 (--no-plot skips it): peak contact force (N) versus the swept
value, up and down sweeps marked apart, and heat maps of the harmonics k = 1..30 (m/s^2, log
colour) of both shroud accelerations per point in run order.

Work that may take over a minute is announced on stderr with its estimate, as rig simulate
does; an --fe more than 10 x the model's highest mode is refused.

"""
    + exit_status_help(0, 2, notes={0: "written", 2: "bad input (options, rig file, --out)"})
    + """
A signal: the file keeps every finished point, status "aborted".

Maps and clusters: `rig study map --gap "0.3 mm:0.7 mm:0.2 mm" --force "10 N,15 N,20 N" --fe
"58 Hz:62 Hz:2 Hz"` runs every (gap, F0) pair as a frequency sweep (no plot; rig report). Points
run in chains (a carried-state sweep is one chain; from rest, each point is one): in-process by
default, on --workers N local processes (a Dask LocalCluster) or on an existing Dask cluster
(--scheduler tcp://host:port). Results are written in point order and are bit-identical
whatever the number of workers; a point whose worker dies is rerun once and reported.

examples:
  rig study gap --values "0.3 mm:0.9 mm:0.1 mm" --out gap.h5
  rig study map --gap "0.3 mm,0.5 mm" --force "10 N,15 N" --fe "58 Hz,60 Hz" --from-rest --workers 2 --out map.h5
  rig study force --values "5 N,10 N,15 N,20 N,25 N" --out force.h5
  rig study frequency --values "60 Hz:80 Hz:1 Hz" --direction both --out frequency.h5
"""
)

KINDS = ("gap", "force", "frequency", "map")
UNIT = {"gap": ("mm", 1e3), "force": ("N", 1.0), "frequency": ("Hz", 1.0)}
MAP_EXAMPLE = '--gap "0.3 mm:0.7 mm:0.2 mm" --force "10 N,15 N,20 N" --fe "58 Hz:62 Hz:2 Hz"'


class StudyStopped(Exception):
    """A stop request (Ctrl-C, SIGTERM, SIGHUP) ended a study whose recording was created: the
    recording keeps its ``done`` finished points and ends with status ``aborted``."""

    def __init__(self, stop: Interrupted, done: int, planned: int) -> None:
        super().__init__(f"{stop.reason} after {done} of {planned} points")
        self.stop, self.done, self.planned = stop, done, planned


def study_plan(
    kind: str,
    values: str | None = None,
    *,
    fe: str | float | None = None,
    force: str | float | None = None,
    gap_value: str | float | None = None,
    direction: str = "up",
    from_rest: bool = False,
) -> tuple[Any, list[float] | None]:
    """``(plan, values)`` of a study: a :class:`rigtools.sim.studies.StudyPlan` of ``values``
    (``"a,b,c"`` or ``"start:stop:step"`` with units) at the fixed ``fe``, ``force`` and
    ``gap_value`` (defaults: the paper's), or for ``kind="map"`` a
    :class:`rigtools.sim.studies.MapPlan` of the three grids (``values`` then ``None``)."""
    from rigtools.sim.studies import MapPlan, StudyPlan
    from rigtools.sim.vibro_impact import SimulationInputError

    carry = not from_rest
    try:
        if kind == "map":
            grids = {"--gap": gap_value, "--force": force, "--fe": fe}
            missing = [o for o, v in grids.items() if v is None]
            if missing:
                raise UserError(f"rig study map needs grids for {', '.join(missing)}, e.g. {MAP_EXAMPLE}")
            if values is not None:
                raise UserError(
                    "--values is for gap, force and frequency studies; a map takes --gap, --force, --fe grids"
                )
            g = value_list(str(gap_value), "gap", "--gap")
            f0 = value_list(str(force), "force", "--force")
            f = value_list(str(fe), "frequency", "--fe")
            n = len(g) * len(f0) * len(f)
            if n > MAX_POINTS:
                raise UserError(f"the map has {n} points; at most {MAX_POINTS}")
            return MapPlan(tuple(g), tuple(f0), tuple(f), direction=direction, carry_state=carry), None
        if values is None:
            raise UserError(f'rig study {kind} needs --values, e.g. --values "0.3 mm:0.9 mm:0.1 mm"')
        swept = value_list(values, kind, "--values")
        swept_not_fixed(kind, {"--fe": fe, "--force": force, "--gap": gap_value})
        fixed: dict[str, float] = {}
        if fe is not None:
            fixed["fe"] = quantity(fe, "frequency", "--fe")
            if not fixed["fe"] > 0:
                raise UserError(f"--fe = {fe!r}: the excitation frequency must be > 0 Hz")
        if force is not None:
            fixed["force"] = quantity(force, "force", "--force")
            if fixed["force"] < 0:
                raise UserError(f"--force = {force!r}: the force amplitude must be >= 0 N")
        if gap_value is not None:
            fixed["gap"] = gap(gap_value)
        return StudyPlan(kind, tuple(swept), direction, carry_state=carry, **fixed), swept
    except SimulationInputError as exc:
        raise UserError(str(exc)) from None


def point_label(kind: str) -> Callable[[Any], str]:
    """``label(planned_point)`` for progress lines."""
    if kind == "map":
        return lambda p: f"gap {p.gap * 1e3:g} mm, F0 {p.force:g} N, fe {p.fe:g} Hz"
    unit, scale = UNIT[kind]
    return lambda p: f"{kind} {p.value * scale:g} {unit} ({p.direction})"


def record_study(
    out: Path,
    plan: Any,
    cfg: Any,
    system: Any,
    settings: Any,
    *,
    experiment: dict,
    model: str = "fem",
    overwrite: bool = False,
    runner: Any = None,
    guard: Callable[[], AbstractContextManager[Any]] = nullcontext,
    on_point: Callable[[Any, dict], None] | None = None,
    progress: Callable[[float, float], None] | None = None,
) -> list[dict]:
    """Run ``plan`` and write it into a new recording ``out``, each point as soon as it settles.

    The recording's life cycle: created (inside ``guard()``, e.g.
    :meth:`rigtools.runtime.StopRequests.protected`), every point written, closed with status
    ``complete``. On a stop request it ends with status ``aborted`` and the reason
    (:class:`StudyStopped` is raised, naming the points kept); on any other error with status
    ``aborted`` and the error's one line (the error propagates). Returns the points' summaries
    (:func:`rigtools.simulation.write_study`).
    """
    from rigtools.recording import RecordingWriter
    from rigtools.simulation import write_study

    with guard():
        rec = RecordingWriter(
            out, backend="fem", rig=cfg.to_json(), experiment=experiment, overwrite=overwrite
        )
    try:
        points = write_study(
            rec,
            system,
            plan,
            settings,
            model,
            on_point=on_point,
            guard=guard,
            runner=runner,
            progress=progress,
        )
    except Interrupted as exc:
        done, planned = rec.n_points, len(plan.points())  # every point begun was ended: writes are guarded
        with guard():
            rec.abort(f"{exc.reason} after {done} of {planned} points")
        raise StudyStopped(exc, done, planned) from None
    except BaseException as exc:
        with guard():
            rec.abort(one_line(exc, typed=True))
        raise
    with guard():
        rec.close()
    return points


def study_plot(kind: str, fixed: dict, points: list[dict], title: str) -> Any:
    """:func:`rigtools.analysis.plots.study_figure` of the points' summaries (shroud acceleration harmonics)."""
    import numpy as np

    from rigtools.analysis.plots import study_figure

    harmonics = {
        label: np.array([[r["amplitude"] for r in p["harmonics"][channel]] for p in points])
        for label, channel in (
            ("active shroud", "active_shroud_accel"),
            ("passive shroud", "passive_shroud_accel"),
        )
    }
    return study_figure(
        kind,
        [p["value"] for p in points],
        [p["direction"] for p in points],
        [p["peak_contact_force_n"] for p in points],
        harmonics,
        fixed=fixed,
        title=title,
    )


def summary_table(kind: str, points: list[dict]) -> Any:
    """The rich table ``rig study`` prints of the points' summaries: the swept values (a map: gap,
    F0 and fe of every point), steady state, contact and the super-harmonics of interest."""
    from rich.table import Table

    if kind == "map":  # every point's gap, F0 and fe: a map sweeps fe for each (gap, F0)
        title = f"map study: gap x F0 x fe, {len(points)} points"
        swept = [
            ("gap (mm)", lambda p: f"{p['gap'] * 1e3:g}"),
            ("F0 (N)", lambda p: f"{p['force_amplitude']:g}"),
        ]
        swept.append(("fe (Hz)", lambda p: f"{p['fe']:g}"))
    else:
        unit, scale = UNIT[kind]
        title = f"{kind} study"
        swept = [(f"{kind} ({unit})", lambda p: f"{p['value'] * scale:g}")]
    table = Table(title=title)
    columns = (
        "dir",
        "steady",
        "peak contact force (N)",
        "impacts/period",
        "active a(6fe) m/s²",
        "passive a(8fe) m/s²",
    )
    for col in [c for c, _ in swept] + list(columns):
        table.add_column(col, justify="right")
    for p in points:
        h = p["harmonics"]
        table.add_row(
            *(cell(p) for _, cell in swept),
            p["direction"],
            "yes" if p["steady_state"] else "NO",
            f"{p['peak_contact_force_n']:.4g}",
            f"{p['impacts_per_period']:g}",
            f"{h['active_shroud_accel'][5]['amplitude']:.4g}",
            f"{h['passive_shroud_accel'][7]['amplitude']:.4g}",
        )
    return table
