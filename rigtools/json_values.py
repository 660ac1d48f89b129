"""Numbers, arrays and paths as JSON: the one ``default=`` of every ``json.dumps`` that may meet
numpy values (a recording's rig and experiment text, ``--json`` output)."""

from __future__ import annotations

from pathlib import Path
from typing import Any


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
