"""FRF sets: measured FRFs (an analyser's, imported from UFF 58) stored for ``rig analyze``.

An FRF set is one HDF5 file, text and numbers only:

==============================  ==================================================================
``/`` attributes                ``schema`` = ``"rigtools.frfset"``, ``schema_version`` = 1,
                                ``created`` (ISO UTC), ``kind`` (``accelerance``, ``mobility`` or
                                ``receptance``), ``reference`` (the excitation's name),
                                ``responses`` (JSON list of names), ``source`` (JSON object: file,
                                format, what the import assumed); optional ``points`` (JSON list,
                                one per response: ``{"response": {"entity", "node", "direction"},
                                "reference": {...}}``, UFF node numbers and direction codes)
``/frequency``                  (n_freq,) float64, Hz, uniform, increasing
``/frf_real``, ``/frf_imag``    (n_responses, n_freq) float64, SI (response units per N)
``/coherence``                  (n_responses, n_freq) float64, NaN where the source had none
==============================  ==================================================================

:func:`summary` describes a set (``rig info``); :func:`check_frf_set` validates one (``rig
check``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import ClassVar

import h5py
import numpy as np

from rigtools.derived_files import atomic_write_hdf5
from rigtools.errors import UserError, one_line, option
from rigtools.interop.directions import direction_text
from rigtools.recording.reader import has_schema, open_checked
from rigtools.recording.validate import FileCheck

SCHEMA = "rigtools.frfset"
SCHEMA_VERSION = 1
KINDS = ("accelerance", "mobility", "receptance")


@dataclass
class FRFSet:
    """FRFs of several responses over one reference on one frequency grid.

    Attributes
    ----------
    frequency_hz
        (n_freq,) uniform grid, Hz.
    frf
        (n_responses, n_freq) complex, SI units of ``kind``.
    coherence
        (n_responses, n_freq), NaN where unknown.
    responses, reference
        Names.
    kind
        ``"accelerance"``, ``"mobility"`` or ``"receptance"``.
    source
        Where the FRFs came from and what their import assumed.
    created
        When the set was written (ISO UTC).
    points
        Per response, where it and its reference were measured: ``{"response": {"entity",
        "node", "direction"}, "reference": {...}}`` (UFF node and direction code), or empty.
    schema_version
        The file's (as read; written as :data:`SCHEMA_VERSION`).
    """

    frequency_hz: np.ndarray
    frf: np.ndarray
    coherence: np.ndarray
    responses: list[str]
    reference: str
    kind: str
    source: dict = field(default_factory=dict)
    created: str = ""
    points: list[dict] = field(default_factory=list)
    schema_version: int = SCHEMA_VERSION


def write_frf_set(path: str | Path, frf_set: FRFSet, *, overwrite: bool = False) -> None:
    """Write ``frf_set`` to ``path`` whole or not at all (:func:`rigtools.derived_files.atomic_write`).

    Raises
    ------
    UserError
        ``path`` exists and ``overwrite`` is False, or is not a place rigtools writes.
    FaultError
        The write failed (disk full, ...), in one line; nothing is left behind.
    """
    path = Path(path)
    if path.exists() and not overwrite:
        raise UserError(f"{path} exists (give {option('overwrite', True)} to replace it)")
    if frf_set.kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {frf_set.kind!r}")

    def fill(f) -> None:
        f.attrs.update(
            {
                "schema": SCHEMA,
                "schema_version": SCHEMA_VERSION,
                "created": datetime.now(UTC).isoformat(),
                "kind": frf_set.kind,
                "reference": frf_set.reference,
                "responses": json.dumps(list(frf_set.responses)),
                "source": json.dumps(frf_set.source),
                **({"points": json.dumps(frf_set.points)} if frf_set.points else {}),
            }
        )
        h = np.atleast_2d(np.asarray(frf_set.frf, dtype=complex))
        f["frequency"] = np.asarray(frf_set.frequency_hz, dtype=float)
        f["frf_real"], f["frf_imag"] = h.real, h.imag
        f["coherence"] = np.atleast_2d(np.asarray(frf_set.coherence, dtype=float))

    atomic_write_hdf5(path, fill)
    errors = [p for p in check_frf_set(path).problems if p.severity == "error"]
    if errors:  # what rig check would reject is never left as an FRF set (an import's bad grid)
        path.unlink(missing_ok=True)
        raise UserError(f"{path} not written: the FRF set would be damaged: {errors[0].line()}")


def is_frf_set(path: str | Path) -> bool:
    """True if ``path`` is an HDF5 file with the FRF-set schema."""
    return has_schema(path, SCHEMA)


def read_frf_set(path: str | Path) -> FRFSet:
    """Read an FRF set: one line :class:`UserError` if it is not one, or if :func:`check_frf_set`
    finds an error in it (the reader relies on exactly what ``rig check`` verifies, so a file
    ``check`` rejects is refused here with its first problem, and one it passes reads whole)."""
    check_frf_set(path).refuse_damaged()
    try:
        with h5py.File(path, "r") as f:
            return FRFSet(
                frequency_hz=np.asarray(f["frequency"][:], dtype=float),
                frf=np.asarray(f["frf_real"][:]) + 1j * np.asarray(f["frf_imag"][:]),
                coherence=np.asarray(f["coherence"][:], dtype=float),
                responses=list(json.loads(f.attrs["responses"])),
                reference=str(f.attrs["reference"]),
                kind=str(f.attrs["kind"]),
                source=dict(json.loads(f.attrs.get("source", "{}"))),
                created=str(f.attrs.get("created", "")),
                points=list(json.loads(f.attrs.get("points", "[]"))),
                schema_version=int(f.attrs["schema_version"]),
            )
    except (OSError, KeyError, ValueError) as exc:
        raise UserError(f"{path}: cannot read the FRF set ({one_line(exc, 200)})") from None


#: SI units of the response of each FRF kind (the reference is a force, N)
RESPONSE_UNITS = {"accelerance": "m/s^2", "mobility": "m/s", "receptance": "m"}


def _where(point: dict | None, name: str, units: str) -> dict:
    point = point or {}
    node, code = point.get("node"), point.get("direction")
    return {
        "name": name,
        "entity": point.get("entity"),
        "node": node,
        "direction": direction_text(code) if code is not None else None,
        "units": units,
    }


def summary(path: str | Path) -> dict:
    """What ``rig info`` shows of an FRF set (plain Python, ``--json``).

    Returns
    -------
    dict
        ``kind`` (``"frf set"``), ``frf_kind`` and ``frf_units``, ``n_frfs``, ``references`` and
        ``responses`` (name, UFF entity, node, direction, units; a response also its
        reference's name, node and direction, and whether it has a coherence), ``frequency`` (``lines``, ``min_hz``, ``max_hz``,
        ``resolution_hz``), ``source`` (file and format), ``created``, ``schema_version``.
    """
    fs = read_frf_set(path)
    units = RESPONSE_UNITS.get(fs.kind, "?")
    points = fs.points if len(fs.points) == len(fs.responses) else [{} for _ in fs.responses]
    responses, references = [], []
    for row, (name, point) in enumerate(zip(fs.responses, points, strict=True)):
        ref = _where(
            point.get("reference"), (point.get("reference") or {}).get("entity") or fs.reference, "N"
        )
        if ref not in references:
            references.append(ref)
        responses.append(
            {
                **_where(point.get("response"), name, units),
                "reference": ref["name"],
                "reference_node": ref["node"],  # the name alone does not say which of its directions
                "reference_direction": ref["direction"],
                "coherence": bool(np.any(np.isfinite(fs.coherence[row]))),
            }
        )
    f = fs.frequency_hz
    return {
        "path": str(path),
        "kind": "frf set",
        "schema_version": fs.schema_version,
        "created": fs.created,
        "source": {k: v for k, v in fs.source.items() if k != "records"},
        "frf_kind": fs.kind,
        "frf_units": f"({units})/N",
        "n_frfs": len(fs.responses),
        "references": references,
        "responses": responses,
        "frequency": {
            "lines": int(f.size),
            "min_hz": float(f[0]) if f.size else None,
            "max_hz": float(f[-1]) if f.size else None,
            "resolution_hz": float(f[1] - f[0]) if f.size > 1 else None,
        },
    }


@dataclass
class FRFSetCheck(FileCheck):
    """Outcome of :func:`check_frf_set`; ``valid`` when no problem is an error."""

    KIND: ClassVar[str] = "frf set"
    WHAT: ClassVar[str] = "FRF set"
    COUNTS: ClassVar[dict[str, str]] = {"n_frfs": "frfs", "lines": "lines"}

    n_frfs: int = 0
    lines: int = 0


def check_frf_set(path: str | Path, read_data: bool = True) -> FRFSetCheck:
    """Validate an FRF set: schema and version, root attributes, dataset shapes and (with
    ``read_data``) finite frequencies, FRFs and coherence (NaN only for a whole row without
    one), coherence within [0, 1], and a uniform increasing frequency grid.

    Raises
    ------
    RecordingError
        The file cannot be opened as HDF5, is not an FRF set, or was written by a newer
        rigtools (``schema_version`` above :data:`SCHEMA_VERSION`): ``rig check`` exits 2.
    """
    out = FRFSetCheck(str(path))
    error = out.error
    f, attrs = open_checked(path, SCHEMA, ("an FRF set", "FRF set"), SCHEMA_VERSION, out.problems)
    with f:
        if attrs.get("kind") not in KINDS:
            error("/", f"kind must be one of {', '.join(KINDS)}, got {attrs.get('kind')!r}")
        if not isinstance(attrs.get("reference"), str) or not attrs["reference"]:
            error("/", f"reference must be a name, got {attrs.get('reference')!r}")
        responses = _json_attr(attrs, "responses", list, error)
        if responses is not None and (
            not responses
            or not all(isinstance(r, str) and r for r in responses)
            or len(set(responses)) < len(responses)
        ):
            error("/", f"responses must be distinct names, got {responses!r}")
        _json_attr(attrs, "source", dict, error)
        points = _json_attr(attrs, "points", list, error, required=False)
        n = len(responses) if responses else None
        if points is not None and n is not None and len(points) != n:
            error("/", f"points holds {len(points)} entries for {n} responses")
        for i, entry in enumerate(points or []):
            if problem := _place_problem(entry):
                error("/", f"points entry {i}: {problem}")
        shapes = {}
        for name in ("frequency", "frf_real", "frf_imag", "coherence"):
            if name not in f or not isinstance(f[name], h5py.Dataset):
                error(f"/{name}", "missing")
            elif f[name].dtype.kind != "f":
                error(f"/{name}", f"must hold floats, holds {f[name].dtype}")
            else:
                shapes[name] = f[name].shape
        lines = shapes.get("frequency", (0,))
        if "frequency" in shapes and (len(lines) != 1 or lines[0] < 2):
            error("/frequency", f"must be one-dimensional with at least 2 lines, shape {lines}")
        expected = (n, lines[0]) if n is not None and len(lines) == 1 else None
        for name in ("frf_real", "frf_imag", "coherence"):
            if name in shapes and expected is not None and shapes[name] != expected:
                error(f"/{name}", f"shape {shapes[name]}, expected {expected} (responses, lines)")
        out.n_frfs, out.lines = n or 0, lines[0] if len(lines) == 1 else 0
        if read_data and out.valid:
            _data_problems(f, error)
    return out


def _place_problem(entry: object) -> str | None:
    """What is wrong with a ``points`` entry (``{"response": PLACE, "reference": PLACE}``, each
    place ``{"entity", "node", "direction"}`` or null), or ``None``."""
    if not isinstance(entry, dict):
        return f"must be a JSON object, got {entry!r}"
    for side in ("response", "reference"):
        place = entry.get(side)
        if place is None:
            continue
        if not isinstance(place, dict):
            return f"{side} must be a JSON object, got {place!r}"
        node, code = place.get("node"), place.get("direction")
        if node is not None and (isinstance(node, bool) or not isinstance(node, int)):
            return f"{side} node must be a whole number, got {node!r}"
        if code is not None and (isinstance(code, bool) or not isinstance(code, int) or not -6 <= code <= 6):
            return f"{side} direction must be a UFF direction code -6..6, got {code!r}"
    return None


def _json_attr(attrs: dict, name: str, kind: type, error, *, required: bool = True):
    """The JSON value of a root attribute, of type ``kind``; an error (None) otherwise."""
    if name not in attrs:
        if required:
            error("/", f"attribute {name} is missing")
        return None
    try:
        value = json.loads(attrs[name])
    except (TypeError, ValueError):
        error("/", f"attribute {name} is not JSON")
        return None
    if not isinstance(value, kind):
        error("/", f"attribute {name} must be a JSON {'list' if kind is list else 'object'}")
        return None
    return value


def _data_problems(f, error) -> None:
    """Values of a well-formed FRF set: finite, coherence in [0, 1], a uniform increasing grid."""
    try:
        freq = np.asarray(f["frequency"][:], dtype=float)
        frf = {name: np.asarray(f[name][:], dtype=float) for name in ("frf_real", "frf_imag")}
        coherence = np.asarray(f["coherence"][:], dtype=float)
    except (OSError, ValueError) as exc:
        error("/", f"the values cannot be read ({one_line(exc, 200)})")
        return
    if not np.all(np.isfinite(freq)):
        error("/frequency", f"{int(np.sum(~np.isfinite(freq)))} non-finite value(s)")
        return
    if freq.size and freq[0] < 0:
        error("/frequency", f"starts at {freq[0]:g} Hz, below 0 Hz")
    step = np.diff(freq)
    if np.any(step <= 0):
        i = int(np.argmax(step <= 0))
        error("/frequency", f"not increasing: line {i + 1} ({freq[i + 1]:g} Hz) after {freq[i]:g} Hz")
    elif np.max(np.abs(step - step[0])) > 1e-6 * step[0]:
        error("/frequency", f"not uniform: spacing from {step.min():g} to {step.max():g} Hz")
    for name, values in frf.items():
        bad = ~np.isfinite(values)
        if bad.any():
            error(
                f"/{name}",
                f"{int(bad.sum())} non-finite value(s), first at line {int(np.argwhere(bad)[0][1])}",
            )
    for row, c in enumerate(coherence):
        nan = np.isnan(c)
        if np.any(np.isinf(c)) or (nan.any() and not nan.all()):
            error(
                "/coherence",
                f"row {row}: {int(np.sum(~np.isfinite(c)))} non-finite value(s) among finite ones",
            )
        elif not nan.any() and (c.min() < -1e-9 or c.max() > 1 + 1e-9):
            error("/coherence", f"row {row}: values {c.min():g} to {c.max():g}, outside [0, 1]")
