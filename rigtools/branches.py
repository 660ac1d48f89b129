"""Continued branches of the model as files: compute (:func:`continue_model`), store
(:func:`write_branches`, HDF5 of kind "branches", see docs/recording-format.md), read
(:func:`read_branches`), read recorded sweeps and studies to overlay (:func:`measured_sweeps`) and
draw (:func:`branches_figure`)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rigtools.errors import UserError
from rigtools.options import switch as yes_no
from rigtools.recording.reader import open_checked

if TYPE_CHECKING:
    from rigtools.sim.continuation import Branch

BRANCHES_SCHEMA = "rigtools-branches"
BRANCHES_VERSION = 1
MEASURES = {  # response measure -> (OrbitMeasures field, harmonic index or None, axis label)
    "contact": ("peak_contact_force", None, "peak contact force (N)"),
    "accel1": ("accel_harmonics_active", 0, "active shroud acceleration, k = 1 (m/s^2)"),
    "tip": ("tip_amplitude_active", None, "active shroud amplitude (m)"),
    "impacts": ("impacts_per_period", None, "impacts per period"),
}
POINT_PARAM = {"fe": "fe", "force": "force_amplitude", "gap": "gap"}  # recording point parameter
JUMP_THRESHOLD = 0.3  # as rig acquire sweep's default --jump-threshold
X_LABELS = {
    "fe": ("excitation frequency (Hz)", 1.0),
    "force": ("force amplitude (N)", 1.0),
    "gap": ("gap (mm)", 1e3),
}
X_UNITS = {"fe": "Hz", "force": "N", "gap": "mm"}  # as the figure shows the parameter (X_LABELS)


@dataclass
class StoredBranch:
    """A branch as read back: arrays per point, its periods and how it ended."""

    param: str
    periods: int
    status: str
    message: str
    value: np.ndarray
    stable: np.ndarray
    multipliers: np.ndarray  # (n, m) complex
    labels: list[tuple[str, ...]]
    measures: dict[str, np.ndarray]
    # one dict per labelled bifurcation or event (rigtools.sim.bifurcations.Bifurcation.as_dict:
    # critical multiplier, contact structures, location at a converged time step); empty in a
    # file written before they were stored
    bifurcations: list[dict] = field(default_factory=list)


DIMENSION = {"fe": "frequency", "force": "force", "gap": "length"}
DEFAULT_FORCE = "15 N"  # the force held when none is given


def parse_inputs(
    param: str,
    start: str | float,
    stop: str | float,
    fe: str | float,
    force: str | float | None,
    gap: str | float,
    drive: str | float | None = None,
) -> tuple[float, float, dict[str, float]]:
    """``(start, stop, {"fe", "force", "gap"})`` in SI from quantity strings (``"0.7 mm"``; a
    plain number is SI); one-line :class:`UserError` naming the option otherwise. With
    ``drive`` (the simulated rig's model driven at a fixed drive amplitude) ``"force"`` is that
    amplitude in peak volts, and so is a ``"force"`` range; ``force`` None is 15 N, and a force
    given with ``drive`` is refused (it would not be held)."""
    from rigtools.errors import option
    from rigtools.options import drive_amplitude, positive_finite
    from rigtools.options import gap as gap_value

    # each named as the caller gives it: --from on the command line, start= in a script
    p_, f_, t_ = option("param"), option("start", flag="--from"), option("stop", flag="--to")
    fe_, force_, gap_, drive_ = option("fe"), option("force"), option("gap"), option("drive")

    if param not in DIMENSION:
        raise UserError(f"{p_} = {param!r}: one of {', '.join(DIMENSION)}")
    if param == "gap":
        lo, hi = gap_value(start, f_), gap_value(stop, t_)
    elif param == "force" and drive is not None:
        lo, hi = drive_amplitude(str(start), f_), drive_amplitude(str(stop), t_)
    else:
        lo = positive_finite(start, DIMENSION[param], f_)
        hi = positive_finite(stop, DIMENSION[param], t_)
    if lo == hi:
        raise UserError(f"{f_} and {t_} are both {start!r}: give a range")
    if drive is not None and force is not None:
        raise UserError(
            f"{force_} = {force!r} with {drive_} = {drive!r}: the model holds either the force or the "
            "drive amplitude; give one"
        )
    force = DEFAULT_FORCE if force is None else force
    fixed = {
        "fe": positive_finite(fe, "frequency", fe_),
        "force": (
            positive_finite(force, "force", force_) if drive is None else drive_amplitude(str(drive), drive_)
        ),
        "gap": gap_value(gap, gap_),
    }
    return lo, hi, fixed


def continuation(
    param: str,
    start: str | float,
    stop: str | float,
    *,
    fe: str | float = "60 Hz",
    force: str | float | None = None,
    gap: str | float = "0.7 mm",
    model: str = "fem",
    rig: str | None = None,
    switch: bool = True,
    drive: str | float | None = None,
    found: list | None = None,
) -> list[Branch]:
    """Branches of the rig model's periodic orbits continued in ``param`` (what ``rig
    continuation`` computes, without the file).

    Parameters
    ----------
    param
        ``"fe"``, ``"force"`` or ``"gap"``.
    start, stop
        The range of ``param`` (``"55 Hz"``, ``"0.5 mm"``; a plain number is SI).
    fe, force, gap
        The fixed quantities (the continued one is ignored); ``force`` None: 15 N (not with
        ``drive``).
    model
        ``"fem"`` or ``"am"`` reduction of the rig; ``"rig"``: the simulated rig's model (the
        FEM of its test article driven through the shaker and amplifier, as ``--backend sim``
        integrates it), under force control at ``force`` as the rig's procedures hold it.
    rig
        Rig file (TOML); default the calibrated default rig.
    switch
        Also the period-2 branch of each period doubling.
    drive
        With ``model="rig"``: hold this drive amplitude (``"1 V"``, peak) instead of the force;
        ``"force"`` then means the drive amplitude (a ``"force"`` range too).
    found
        A list the branches grow in as they are computed: after a Ctrl-C (KeyboardInterrupt)
        it holds what was computed so far, the branch being traced marked "interrupted".

    Returns
    -------
    list of rigtools.sim.continuation.Branch
        The period-1 branch first; its points carry stability, Floquet multipliers, labels
        (fold, period-doubling, neimark-sacker, grazing) and response measures.

    Examples
    --------
    Without contact (a 5 mm gap no orbit closes) every orbit is stable:

    >>> import rigtools
    >>> (b,) = rigtools.continuation("fe", "56 Hz", "57 Hz", gap="5 mm", switch=False)
    >>> b.status, b.points[0].value, b.points[-1].value, bool(b.stable().all())
    ('complete', 56.0, 57.0, True)
    >>> b.points[-1].max_multiplier < 1.0
    True

    A long continuation stopped with Ctrl-C keeps its points in ``found`` (minutes of work:
    not run here):

    >>> found = []
    >>> try:  # doctest: +SKIP
    ...     branches = rigtools.continuation("fe", "15 Hz", "80 Hz", found=found)
    ... except KeyboardInterrupt:
    ...     branches = found
    >>> branches[-1].status  # after a Ctrl-C  # doctest: +SKIP
    'interrupted'
    """
    if found is not None and not isinstance(found, list):
        raise UserError(
            f"found = {found!r}: give a list (found=[]) to hold the branches as they are computed"
        )
    lo, hi, fixed = parse_inputs(param, start, stop, fe, force, gap, drive)
    return continue_model(
        param,
        lo,
        hi,
        **fixed,
        model=model,
        rig=rig,
        switch=yes_no(switch, "switch"),
        drive=drive is not None,
        found=found,
    )[1]


def continue_model(
    param: str,
    start: float,
    stop: float,
    *,
    fe: float,
    force: float,
    gap: float,
    model: str = "fem",
    rig: str | None = None,
    switch: bool = True,
    progress=None,
    drive: bool = False,
    found: list | None = None,
    announce=None,
):
    """``(rig config, branches)``: the period-1 branch of the rig's reduced model over
    ``[start, stop]`` and the period-2 branches of its period doublings
    (:func:`rigtools.sim.continuation.trace`). ``model="rig"``: the simulated rig's model
    (:func:`simulated_rig_model`), ``force`` the force fundamental held or, with ``drive``, the
    drive amplitude (V). Bad input becomes a :class:`UserError`. ``found``: the branches grow
    there as they are computed (kept when interrupted, :func:`rigtools.sim.continuation.trace`).
    The range is held against the model and the memory first (:func:`check_continuation_resources`);
    ``announce(line)`` is told when the work will be long."""
    from rigtools.sim.continuation import trace
    from rigtools.sim.params import SimulationInputError
    from rigtools.simulation import load_system

    if model not in ("fem", "am", "rig"):
        raise UserError(f"--model = {model!r}: one of fem, am, rig")
    if drive and model != "rig":
        raise UserError("--drive holds the simulated rig's drive: use it with --model rig")
    shaker = None
    if model == "rig":
        cfg, system, shaker = simulated_rig_model(rig, force_control=not drive)
    else:
        cfg, system = load_system(rig, model)
    check_continuation_resources(system, param, start, stop, fe=fe, force=force, announce=announce)
    try:
        branches = trace(
            system,
            param,
            start,
            stop,
            fe=fe,
            force=force,
            gap=gap,
            shaker=shaker,
            switch=switch,
            progress=progress,
            found=found,
        )
    except SimulationInputError as exc:
        raise UserError(str(exc)) from None
    check_plausible_branches(branches, drive)
    return cfg, branches


def check_continuation_resources(
    system, param: str, start: float, stop: float, *, fe: float, force: float, announce=None
) -> None:
    """Refuse, before any orbit, a continuation the model cannot answer or the memory cannot
    hold: a frequency more than the model's range above its highest mode
    (:func:`rigtools.simulation.check_model_range`), or one orbit at the lowest frequency (the
    most steps per period) larger than the memory (:func:`rigtools.memory.check_memory`), each
    in one line with the estimate; ``announce`` gets one line when a point takes long."""
    from rigtools.memory import check_memory
    from rigtools.simulation import LONG_WORK_SECONDS, check_model_range, continuation_cost, human_seconds

    lo, hi = sorted((start, stop))
    fe_lo, fe_hi = (lo, hi) if param == "fe" else (fe, fe)
    check_model_range(system, fe_hi, "--to" if param == "fe" else "--fe")
    force_max = hi if param == "force" else force
    steps, need, seconds = continuation_cost(system, fe_lo, abs(force_max))
    check_memory(
        need,
        f"an orbit at {fe_lo:g} Hz ({steps} steps per period)",
        "start the range at a higher frequency (the steps per period grow as 1/fe)",
    )
    if announce is not None and seconds * 100 > LONG_WORK_SECONDS:
        announce(
            f"each point at {fe_lo:g} Hz takes about {human_seconds(seconds)} ({steps} steps per period); "
            "a branch holds up to 2000 points"
        )


def continue_to_file(
    out: Path,
    param: str,
    start: float,
    stop: float,
    fixed: dict[str, float],
    *,
    model: str,
    rig: str | None,
    switch: bool,
    drive: bool,
    measured: list[str],
    found: list,
    announce=None,
):
    """``(rig config, branches)`` of :func:`continue_model`, written to ``out``
    (:func:`write_branches`, ``experiment`` naming the inputs). Interrupted (Ctrl-C, SIGTERM), the
    branches computed so far (``found``, the one in progress ``"interrupted"``) are written before
    the interrupt goes on."""
    from rigtools.config import load_rig

    experiment = {
        "procedure": "continuation",
        "param": param,
        "from": start,
        "to": stop,
        **fixed,
        "model": model,
        "drive": drive,  # "force" is then the drive amplitude, V (--model rig)
        "measured": [str(m) for m in measured],
    }
    try:
        cfg, branches = continue_model(
            param,
            start,
            stop,
            **fixed,
            model=model,
            rig=rig,
            switch=switch,
            drive=drive,
            found=found,
            announce=announce,
        )
    except KeyboardInterrupt:
        if any(b.points for b in found):
            write_branches(out, [b for b in found if b.points], load_rig(rig).to_json(), experiment)
        raise
    write_branches(out, branches, cfg.to_json(), experiment)
    return cfg, branches


def check_plausible_branches(branches, drive: bool = False) -> None:
    """Refuse branches on which a shroud moves farther than any blade of the rig can (more than
    :data:`rigtools.units.MAX_GAP`), as :func:`rigtools.simulation.check_plausible` refuses such a
    run: the linear beam model is meaningless there (a typical cause: ``"1 MN"`` for ``"1 mN"``)."""
    from rigtools.units import MAX_GAP

    for b in branches:
        for name in ("active", "passive"):
            amplitude = b.measure(f"tip_amplitude_{name}")
            if amplitude.size and float(np.max(amplitude)) > MAX_GAP:
                p = b.points[int(np.argmax(amplitude))]
                what = "--drive and its unit (mV, V)" if drive else "--force and its unit (mN, N, kN)"
                unit = "V" if drive and b.param == "force" else X_UNITS[b.param]
                raise UserError(
                    f"at {b.param} = {p.value * X_LABELS[b.param][1]:.6g} {unit} the {name} shroud "
                    f"moves {float(np.max(amplitude)):.3g} m, more than any blade of the rig can "
                    f"({MAX_GAP * 1e3:g} mm): not a physical orbit; check {what}"
                )


def simulated_rig_model(rig: str | None, force_control: bool = True):
    """``(rig config, reduced system, shaker drive)`` of the simulated rig (``--backend sim``):
    the rig file's ``[test_article]`` applied to its nominal parameters, reduced as the
    simulated rig's vibro-impact physics reduces it, and its ``[shaker]`` with the amplifier
    gain (:class:`rigtools.sim.continuation.ShakerDrive`)."""
    from rigtools.config import load_rig
    from rigtools.sim.continuation import ShakerDrive
    from rigtools.sim.reduction import reduced_system

    cfg = load_rig(rig)
    article = cfg.test_article.to_params().apply(cfg.to_params())
    shaker = cfg.shaker.to_params()
    drive = ShakerDrive(shaker.coupling(), shaker.amplifier_gain, force_control)
    return cfg, reduced_system(article, "fem"), drive


def write_branches(path: str | Path, branches, rig_text: str, experiment: dict) -> Path:
    """Write branches to HDF5: root attrs ``schema`` = "rigtools-branches", ``schema_version``,
    ``kind`` = "branches", ``rig``, ``experiment`` (JSON); one group ``/branches/NN`` per branch.
    Whole or not at all (:func:`rigtools.derived_files.atomic_write_hdf5`): a full disk is a
    :class:`rigtools.errors.FaultError` (exit 4) with nothing left behind."""
    import rigtools
    from rigtools.derived_files import atomic_write_hdf5

    def fill(f) -> None:
        f.attrs.update(
            schema=BRANCHES_SCHEMA,
            schema_version=BRANCHES_VERSION,
            kind="branches",
            software_version=rigtools.__version__,
            rig=rig_text,
            experiment=json.dumps(experiment),
        )
        top = f.create_group("branches")
        for i, b in enumerate(branches):
            g = top.create_group(f"{i:02d}")
            g.attrs.update(param=b.param, periods=b.periods, status=b.status, message=b.message)
            pts = b.points
            g["value"] = np.array([p.value for p in pts], float)
            g["stable"] = np.array([p.stable for p in pts], bool)
            m = max((p.multipliers.size for p in pts), default=0)
            mult = np.full((len(pts), m), np.nan + 0j)
            for j, p in enumerate(pts):
                mult[j, : p.multipliers.size] = p.multipliers
            g["multipliers_real"], g["multipliers_imag"] = mult.real, mult.imag
            g.attrs["labels"] = json.dumps([list(p.labels) for p in pts])
            g.attrs["bifurcations"] = json.dumps([r.as_dict() for r in getattr(b, "bifurcations", [])])
            meas = g.create_group("measures")
            for name in pts[0].measures.as_dict() if pts else ():
                if name == "peak_contact_force_per_period":
                    meas[name] = np.array([p.measures.peak_contact_force_per_period for p in pts], float)
                else:
                    meas[name] = np.array([getattr(p.measures, name) for p in pts], float)

    return atomic_write_hdf5(path, fill)


def read_branches(path: str | Path) -> tuple[dict, list[StoredBranch]]:
    """``(experiment, branches)`` of a file written by :func:`write_branches`; a missing,
    unreadable, foreign or damaged file is a one-line :class:`UserError`: the reader relies on
    exactly what :func:`check_branches` verifies (``rig check``), so a file it rejects is
    refused here with its first problem, and one it passes reads whole."""
    from rigtools.errors import one_line
    from rigtools.recording.reader import open_h5

    f, _ = open_h5(path, wait=False)  # the file-level errors: missing, a folder, truncated
    with f:
        if f.attrs.get("schema") != BRANCHES_SCHEMA:
            raise UserError(f"{path}: not a branches file (schema {f.attrs.get('schema')!r})")
    errors = [p for p in check_branches(path).problems if p.severity == "error"]
    if errors:
        more = f" and {len(errors) - 1} more" if len(errors) > 1 else ""
        raise UserError(
            f"{path}: a damaged branches file: {errors[0].line()}{more} (rig check {path} lists them)"
        )
    f, _ = open_h5(path, wait=False)
    with f:
        try:
            return _read_branches(f)
        except (KeyError, ValueError, TypeError, OSError) as exc:  # a group, dataset or attr gone
            raise UserError(f"{path}: damaged branches file ({one_line(exc, 200)})") from None


def _read_branches(f) -> tuple[dict, list[StoredBranch]]:
    out = []
    for name in sorted(f["branches"]):
        g = f["branches"][name]
        out.append(
            StoredBranch(
                param=str(g.attrs["param"]),
                periods=int(g.attrs["periods"]),
                status=str(g.attrs["status"]),
                message=str(g.attrs["message"]),
                value=g["value"][()],
                stable=g["stable"][()],
                multipliers=g["multipliers_real"][()] + 1j * g["multipliers_imag"][()],
                labels=[tuple(lab) for lab in json.loads(g.attrs["labels"])],
                measures={k: g["measures"][k][()] for k in g["measures"]},
                bifurcations=json.loads(g.attrs.get("bifurcations", "[]")),
            )
        )
    return json.loads(f.attrs["experiment"]), out


def branches_info(path: str | Path) -> dict:
    """``rig info`` of a branches file: how it was computed and, per branch, its periods, status,
    points, parameter range and bifurcations. Values in SI (the parameter's unit: Hz, N, or m
    for a gap; volts for a force parameter under ``drive``); a damaged file is a
    :class:`UserError` (:func:`read_branches`)."""
    import h5py

    experiment, branches = read_branches(path)
    with h5py.File(path, "r") as f:
        root = {k: f.attrs.get(k) for k in ("schema_version", "software_version")}
        rig_text = str(f.attrs.get("rig", ""))
    try:
        rig_name = json.loads(rig_text).get("name")
    except (ValueError, AttributeError):
        rig_name = None
    rows = []
    for b in branches:
        value = np.asarray(b.value, float)
        rows.append(
            {
                "periods": b.periods,
                "status": b.status,
                "message": b.message,
                "points": int(value.size),
                "from": float(value[0]) if value.size else None,
                "to": float(value[-1]) if value.size else None,
                "stable_points": int(np.count_nonzero(b.stable)),
                "bifurcations": [
                    {"label": lab, "value": float(v)}
                    for v, labels in zip(value, b.labels, strict=True)
                    for lab in labels
                    if lab not in ("start", "end")
                ],
            }
        )
    return {
        "path": str(path),
        "kind": "branches",
        "schema_version": None if root["schema_version"] is None else int(root["schema_version"]),
        "software_version": None if root["software_version"] is None else str(root["software_version"]),
        "rig": rig_name,
        "experiment": experiment,
        "param": experiment.get("param"),
        "branches": rows,
    }


def is_branches_file(path: str | Path) -> bool:
    """True if ``path`` is an HDF5 file with the branches schema (:data:`BRANCHES_SCHEMA`)."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            return f.attrs.get("schema") == BRANCHES_SCHEMA
    except (OSError, ValueError):
        return False


@dataclass
class BranchesCheck:
    """Outcome of :func:`check_branches`; ``valid`` when no problem is an error."""

    path: str
    problems: list = field(default_factory=list)
    n_branches: int = 0
    n_points: int = 0

    @property
    def valid(self) -> bool:
        """True when no problem has severity error."""
        return not any(p.severity == "error" for p in self.problems)

    def to_dict(self) -> dict:
        """``rig check --json`` of a branches file."""
        from dataclasses import asdict

        return {
            "path": self.path,
            "kind": "branches",
            "valid": self.valid,
            "branches": self.n_branches,
            "points": self.n_points,
            "problems": [asdict(p) for p in self.problems],
        }


def check_branches(path: str | Path, read_data: bool = True) -> BranchesCheck:
    """Validate a branches file (:func:`write_branches`) against what :func:`read_branches` and
    ``rig report --branches`` rely on: root attributes (schema, version, kind, a rig description,
    the experiment as a JSON object naming its parameter), at least one branch, and per ``/branches/NN`` its
    attributes (param, periods >= 1, status, message, one label list per point), datasets of one
    point count (value, stable, multipliers, every measure; the measures the figure draws
    present) and (with ``read_data``) finite parameter values and no infinite multiplier or
    measure (NaN pads the multipliers of a smaller system).

    Raises
    ------
    RecordingError
        The file cannot be opened as HDF5, is not a branches file, or was written by a newer
        rigtools (``schema_version`` above :data:`BRANCHES_VERSION`): ``rig check`` exits 2.
    """
    import h5py

    from rigtools.recording.validate import Problem, rig_problems

    out = BranchesCheck(str(path))

    def error(where: str, message: str) -> None:
        out.problems.append(Problem(where, message))

    f, attrs = open_checked(
        path, BRANCHES_SCHEMA, ("a branches file", "branches"), BRANCHES_VERSION, out.problems
    )
    with f:
        if attrs.get("kind") != "branches":
            error("/", f"kind must be 'branches', got {attrs.get('kind')!r}")
        if isinstance(attrs.get("rig"), str):
            out.problems.extend(rig_problems(attrs["rig"]))
        else:
            error("/", "attribute rig (the rig description) is missing")
        try:
            experiment = json.loads(attrs.get("experiment", ""))
        except (TypeError, ValueError):
            experiment = None
        param = experiment.get("param") if isinstance(experiment, dict) else None
        if param not in POINT_PARAM:
            error(
                "/",
                f"attribute experiment must be a JSON object naming param (one of {', '.join(POINT_PARAM)})",
            )
        if "branches" not in f or not isinstance(f["branches"], h5py.Group):
            error("/branches", "missing")
            return out
        for name in sorted(f["branches"]):
            out.n_points += _branch_problems(
                f["branches"][name], f"/branches/{name}", param, read_data, error
            )
            out.n_branches += 1
        if not out.n_branches:
            error("/branches", "holds no branch (rig report --branches would draw nothing)")
    return out


def _branch_problems(g, where: str, param: str | None, read_data: bool, error) -> int:
    """Problems of one branch group (see :func:`check_branches`); returns its point count."""
    import h5py

    if not isinstance(g, h5py.Group):
        error(where, "is not a group")
        return 0
    a = dict(g.attrs)
    if a.get("param") != param and param is not None:
        error(where, f"param {a.get('param')!r} is not the experiment's {param!r}")
    periods = a.get("periods")
    if not isinstance(periods, (int, np.integer)) or periods < 1:
        error(where, f"periods must be a whole number >= 1, got {periods!r}")
    for key in ("status", "message"):
        if not isinstance(a.get(key), str):
            error(where, f"attribute {key} must be text, got {a.get(key)!r}")
    shapes = {}
    for key, kind in (("value", "f"), ("stable", "b"), ("multipliers_real", "f"), ("multipliers_imag", "f")):
        d = g.get(key)
        if not isinstance(d, h5py.Dataset):
            error(f"{where}/{key}", "missing")
        elif d.dtype.kind != kind:
            error(f"{where}/{key}", f"must hold {'floats' if kind == 'f' else 'booleans'}, holds {d.dtype}")
        else:
            shapes[key] = d.shape
    n = shapes["value"][0] if len(shapes.get("value", ())) == 1 else None
    if "value" in shapes and n is None:
        error(f"{where}/value", f"must be one-dimensional, shape {shapes['value']}")
    if n is None:
        return 0
    if "stable" in shapes and shapes["stable"] != (n,):
        error(f"{where}/stable", f"shape {shapes['stable']}, expected ({n},) (one per point)")
    for key in ("multipliers_real", "multipliers_imag"):
        if key in shapes and (len(shapes[key]) != 2 or shapes[key][0] != n):
            error(f"{where}/{key}", f"shape {shapes[key]}, expected ({n}, m) (points, multipliers)")
    real, imag = shapes.get("multipliers_real"), shapes.get("multipliers_imag")
    if real is not None and imag is not None and real != imag:
        error(
            f"{where}/multipliers_imag", f"shape differs from multipliers_real's {shapes['multipliers_real']}"
        )
    try:
        labels = json.loads(a.get("labels", ""))
    except (TypeError, ValueError):
        labels = None
    if not (
        isinstance(labels, list)
        and all(isinstance(x, list) and all(isinstance(t, str) for t in x) for x in labels)
    ):
        error(where, "attribute labels must be a JSON list of lists of names (one list per point)")
    elif len(labels) != n:
        error(where, f"labels holds {len(labels)} entries for {n} points")
    if "bifurcations" in a:  # written since the labels carry their converged location
        try:
            located = json.loads(a["bifurcations"])
        except (TypeError, ValueError):
            located = None
        if not (isinstance(located, list) and all(isinstance(x, dict) for x in located)):
            error(
                where, "attribute bifurcations must be a JSON list of objects (one per labelled bifurcation)"
            )
    measures = g.get("measures")
    if not isinstance(measures, h5py.Group):
        error(f"{where}/measures", "missing")
        measures = {}
    for key, d in measures.items():
        if not isinstance(d, h5py.Dataset) or d.dtype.kind != "f" or d.ndim not in (1, 2) or d.shape[0] != n:
            error(f"{where}/measures/{key}", f"must be floats of shape ({n},) or ({n}, k)")
    drawn = sorted({m[0] for m in MEASURES.values()} - set(measures)) if n else []
    if drawn and isinstance(g.get("measures"), h5py.Group):
        error(f"{where}/measures", f"{', '.join(drawn)} missing (rig report --branches draws them)")
    if read_data and n:
        _branch_values(g, where, measures, error)
    return n


def _branch_values(g, where: str, measures, error) -> None:
    """Values of one branch: finite parameter values, no infinite multiplier or measure."""
    import h5py

    if "value" in g and g["value"].dtype.kind == "f":
        bad = ~np.isfinite(g["value"][()])
        if bad.any():
            error(
                f"{where}/value",
                f"{int(bad.sum())} non-finite value(s), first at point {int(np.argmax(bad))}",
            )
    datasets = [(k, g[k]) for k in ("multipliers_real", "multipliers_imag") if k in g]
    datasets += [(f"measures/{k}", d) for k, d in measures.items() if isinstance(d, h5py.Dataset)]
    for key, d in datasets:
        if d.dtype.kind == "f" and np.isinf(d[()]).any():
            error(f"{where}/{key}", f"{int(np.isinf(d[()]).sum())} infinite value(s)")


def measured_sweeps(paths, param: str, measure: str = "contact") -> list:
    """The recorded sweeps of ``paths`` (stepped sines of ``rig acquire sweep``, studies of
    ``rig study`` / ``rig acquire study``) as :class:`rigtools.analysis.branches.MeasuredSweep`,
    one per file and direction, points in run order, with the contact of each point
    (:func:`point_contact`) and their jumps (a change above :data:`JUMP_THRESHOLD` between
    neighbouring steps that the contact or the other direction confirms,
    :func:`rigtools.procedures.detect_jumps`).

    ``measure`` is read as the branches have it: ``accel1`` the fundamental of the active shroud
    acceleration (fitted over each point's record window), ``contact`` and ``impacts`` the
    model's point parameters (a rig recording has no contact force: a one-line error says so),
    ``tip`` half the peak-to-peak active shroud displacement channel of a model recording.
    """
    if not paths:  # nothing to read: spare the procedures' import (scipy.signal, ~1.5 s)
        return []
    from rigtools.analysis.branches import MeasuredSweep
    from rigtools.procedures import detect_jumps
    from rigtools.recording import open_recording
    from rigtools.recording_analysis.periodic import analyze_periodic
    from rigtools.recording_analysis.samples import record_window
    from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL, ACTIVE_SHROUD_DISP, FORCE

    def value(path, point) -> float:
        if measure == "accel1":
            a = analyze_periodic(point, channels=[FORCE, ACTIVE_SHROUD_ACCEL], k_max=1)
            return float(a.dwell.harmonics[ACTIVE_SHROUD_ACCEL].amplitude[0])
        if measure == "tip" and ACTIVE_SHROUD_DISP in point.channels:
            start, n = record_window(point)
            return 0.5 * float(np.ptp(point.channels[ACTIVE_SHROUD_DISP][start : start + n]))
        name = {"contact": "peak_contact_force", "impacts": "impacts_per_period"}.get(measure, "")
        if name not in point.params:
            raise UserError(
                f"--measured {path}: point {point.index} has no {MEASURES[measure][2]} "
                f"(a rig recording measures accelerations: use --measure accel1)"
            )
        return float(point.params[name])

    out = []
    for path in paths:
        with open_recording(path) as rec:
            runs: dict[str, tuple[list[float], list[float], list[bool | None]]] = {}
            for point in rec.complete_points:
                if POINT_PARAM[param] not in point.params or "fe" not in point.params:
                    raise UserError(f"--measured {path}: point {point.index} has no {POINT_PARAM[param]}")
                x, y, touch = runs.setdefault(str(point.params.get("direction", "up")), ([], [], []))
                x.append(float(point.params[POINT_PARAM[param]]))
                y.append(value(path, point))
                touch.append(point_contact(point.params))
        if not runs:
            raise UserError(f"--measured {path}: no complete point to overlay")
        for direction, (x, y, touch) in runs.items():
            other = next(((ox, oy) for d, (ox, oy, _) in runs.items() if d != direction), None)
            jumps = [
                (j["from_hz"], j["to_hz"])
                for j in detect_jumps(x, y, JUMP_THRESHOLD, contact=touch, other=other)
            ]
            name = f"{Path(path).stem} ({direction})"
            out.append(MeasuredSweep(np.array(x), np.array(y), direction, name, jumps, touch))
    return out


def point_contact(params: dict) -> bool | None:
    """Whether the shrouds touch at a recorded point: a model point's impacts per period (or peak
    contact force), a rig point's shroud acceleration harmonics
    (:func:`rigtools.analysis.jumps.contact_seen`); ``None`` if the point says neither."""
    from rigtools.analysis.jumps import contact_seen
    from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL, PASSIVE_SHROUD_ACCEL

    for key in ("impacts_per_period", "peak_contact_force"):
        if key in params:
            return bool(float(params[key]) > 0)
    active = params.get(f"{ACTIVE_SHROUD_ACCEL}_harmonic_amplitude")
    if active is None:
        return None
    return contact_seen(active, params.get(f"{PASSIVE_SHROUD_ACCEL}_harmonic_amplitude"))


def branch_curves(branches: list[StoredBranch], measure: str = "contact") -> list:
    """The non-empty stored branches as :class:`rigtools.analysis.branches.BranchCurve` in
    ``measure`` (a key of :data:`MEASURES`), named "period 1", "period 2"."""
    from rigtools.analysis.branches import BranchCurve

    field_name, index, _ = MEASURES[measure]
    curves = []
    for b in branches:
        if not b.value.size:
            continue
        y = b.measures[field_name]
        curves.append(
            BranchCurve(
                b.value,
                y[:, index] if index is not None else y,
                b.stable,
                b.labels,
                f"period {b.periods}",
                b.measures.get("impacts_per_period"),
            )
        )
    return curves


def branches_figure(
    branches: list[StoredBranch], measure: str = "contact", title: str = "", measured=(), drive: bool = False
):
    """:func:`rigtools.analysis.branches.branch_figure` of stored branches, with the
    :func:`measured_sweeps` given on the same axes (``drive``: a ``"force"`` axis is the drive
    amplitude, V)."""
    from rigtools.analysis.branches import branch_figure

    xlabel, scale = X_LABELS[branches[0].param] if branches else ("", 1.0)
    if drive and branches and branches[0].param == "force":
        xlabel = "drive amplitude (V)"
    return branch_figure(
        branch_curves(branches, measure),
        xlabel,
        MEASURES[measure][2],
        measured=measured,
        x_scale=scale,
        title=title,
    )


def summary(branches) -> dict:
    """The ``--json`` document: per branch its periods, status, points, labels (``bifurcations``:
    every label of every point, start and end included) and the labelled bifurcations and events
    with their critical multiplier and converged location (``located``,
    :meth:`rigtools.sim.bifurcations.Bifurcation.as_dict`)."""
    return {
        "branches": [
            {
                "periods": b.periods,
                "status": b.status,
                "message": b.message,
                "points": len(b.points),
                "steps_per_period": b.steps_per_period,
                "bifurcations": [
                    {"label": lab, "value": p.value, "stable": p.stable, "max_multiplier": p.max_multiplier}
                    for p in b.points
                    for lab in p.labels
                ],
                "located": [r.as_dict() for r in b.bifurcations],
            }
            for b in branches
        ]
    }


def located_lines(branch, param: str) -> list[str]:
    """One line per labelled bifurcation or event of a branch (``Branch`` or
    :class:`StoredBranch`): label, value at the branch's time step, converged value and its last
    change, critical multiplier, contact structures of an event."""
    unit, scale = X_UNITS[param], X_LABELS[param][1]
    out = []
    for r in [x if isinstance(x, dict) else x.as_dict() for x in branch.bifurcations]:
        mu = r["multiplier_converged"] if r["converged"] is not None else r["multiplier"]
        mu_text = "" if mu[0] is None else f", multiplier {complex(mu[0], mu[1] or 0.0):.4f}"
        text = f"  {r['label']} at {r['value'] * scale:.6g} {unit}"
        if r["converged"] is not None:
            text += (
                f" -> {r['converged'] * scale:.6g} {unit} at {r['steps_per_period']} steps/period "
                f"(last change {r['change'] * scale:+.2g} {unit}{'' if r['converged_ok'] else ', not converged'})"
            )
        text += mu_text
        if not r["smooth"]:
            text += f"; contact {r['contact_before']} -> {r['contact_after']}"
        out.append(text)
    return out
