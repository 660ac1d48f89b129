"""The HDF5 file of continued branches (kind "branches", docs/recording-format.md): what ``rig
continuation`` writes (:func:`write_branches`), reads back (:func:`read_branches`), checks
(:func:`check_branches`, ``rig check``) and summarises (:func:`branches_info`, ``rig info``), and
how its continued parameter is shown (:data:`X_LABELS`, :data:`X_UNITS`).

Light on purpose (numpy, h5py and the recording package): ``rig info`` and ``rig check`` read these
files without loading the model (:mod:`rigtools.branches` computes the branches).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import h5py
import numpy as np

import rigtools
from rigtools.derived_files import atomic_write_hdf5
from rigtools.errors import UserError, one_line
from rigtools.recording.reader import has_schema, open_checked, open_h5
from rigtools.recording.validate import FileCheck, rig_problems

BRANCHES_SCHEMA = "rigtools-branches"
BRANCHES_VERSION = 1
MEASURES = {  # response measure -> (OrbitMeasures field, harmonic index or None, axis label)
    "contact": ("peak_contact_force", None, "peak contact force (N)"),
    "accel1": ("accel_harmonics_active", 0, "active shroud acceleration, k = 1 (m/s^2)"),
    "tip": ("tip_amplitude_active", None, "active shroud amplitude (m)"),
    "impacts": ("impacts_per_period", None, "impacts per period"),
}
POINT_PARAM = {"fe": "fe", "force": "force_amplitude", "gap": "gap"}  # recording point parameter
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


def write_branches(path: str | Path, branches, rig_text: str, experiment: dict) -> Path:
    """Write branches to HDF5: root attrs ``schema`` = "rigtools-branches", ``schema_version``,
    ``kind`` = "branches", ``rig``, ``experiment`` (JSON); one group ``/branches/NN`` per branch.
    Whole or not at all (:func:`rigtools.derived_files.atomic_write_hdf5`): a full disk is a
    :class:`rigtools.errors.FaultError` (exit 4) with nothing left behind."""

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
    check_branches(path).refuse_damaged()  # missing, foreign, newer or damaged: one line
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
    return has_schema(path, BRANCHES_SCHEMA)


@dataclass
class BranchesCheck(FileCheck):
    """Outcome of :func:`check_branches`; ``valid`` when no problem is an error."""

    KIND: ClassVar[str] = "branches"
    WHAT: ClassVar[str] = "branches file"
    COUNTS: ClassVar[dict[str, str]] = {"n_branches": "branches", "n_points": "points"}

    n_branches: int = 0
    n_points: int = 0


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
    out = BranchesCheck(str(path))
    error = out.error
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
