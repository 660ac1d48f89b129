"""Numbers, arrays and paths as JSON: the one ``default=`` of every ``json.dumps`` that may meet
numpy values (a recording's rig and experiment text, ``--json`` output)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rigtools.runtime import silence_stdout


def json_default(value: Any) -> Any:
    """``json.dumps(..., default=json_default)``: a numpy scalar as its Python value, an array as a
    (nested) list, a path as text; anything else raises ``TypeError`` naming the value and type."""
    import numpy as np

    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"value {value!r} of type {type(value).__name__} is not JSON")


def finite_or_none(value: Any, notes: list[str] | None = None, where: str = "") -> Any:
    """``value`` with every non-finite float (NaN, ±inf; numpy values too) replaced by ``None``,
    recursively through dicts, lists and tuples; each replacement's place is appended to ``notes``."""
    import math

    import numpy as np

    if isinstance(value, np.ndarray):
        value = value.tolist()
    elif isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        if notes is not None:
            notes.append(f"{where or 'value'} = {value!r}")
        return None
    if isinstance(value, dict):
        return {k: finite_or_none(v, notes, f"{where}.{k}" if where else str(k)) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_or_none(v, notes, f"{where}[{i}]") for i, v in enumerate(value)]
    return value


def dumps(doc: Any, **kwargs: Any) -> str:
    """The one way rigtools writes JSON (``--json`` output, JSON files): always valid JSON.

    Non-finite numbers become ``null``; if any did, a dict ``doc`` gains ``"json_notes"`` naming
    where (at most 20 places) so a reader knows a ``null`` was a NaN or an infinity, not a gap.
    numpy values and paths go through :func:`json_default`; ``json.dumps(..., allow_nan=False)``
    guarantees no bare ``NaN`` or ``Infinity`` ever leaves.

    Examples
    --------
    >>> dumps({"a": float("inf"), "b": 1.0})
    '{"a": null, "b": 1.0, "json_notes": ["a = inf was not a finite number: written as null"]}'
    """
    import json

    notes: list[str] = []
    clean = finite_or_none(doc, notes)
    if notes and isinstance(clean, dict):
        more = f" (and {len(notes) - 20} more)" if len(notes) > 20 else ""
        clean["json_notes"] = [f"{n} was not a finite number: written as null" for n in notes[:20]]
        if more:
            clean["json_notes"].append(more.strip())
    return json.dumps(clean, default=json_default, allow_nan=False, **kwargs)


def print_document(doc: Any) -> None:
    """``doc`` as one line of JSON on stdout, flushed (a command's ``--json`` document); a reader
    that went away (``rig ... --json | head``) leaves stdout pointed at the null device
    (:func:`rigtools.runtime.silence_stdout`), so the command's own line and status still follow."""
    try:
        print(dumps(doc), flush=True)
    except BrokenPipeError:
        silence_stdout()
