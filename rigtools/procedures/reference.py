"""The reference page of every procedure parameter, generated from the parameter models.

:func:`reference_table` renders, for each procedure, a table of its parameters with the SI
unit, the default and the allowed range, read from the pydantic models themselves (so the page
cannot drift from the code). The docs build includes its output.
"""

from __future__ import annotations

import typing

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from rigtools.procedures.dwell import DwellParameters
from rigtools.procedures.frf import FrfParameters
from rigtools.procedures.pll import PllParameters
from rigtools.procedures.rig_study import StudyParameters
from rigtools.procedures.sine import ControlParameters
from rigtools.procedures.sweep import SweepParameters
from rigtools.procedures.tap import TapParameters
from rigtools.quantity_fields import field_bounds, field_unit

# (title, model, function of the front door, CLI command)
PROCEDURES: tuple[tuple[str, type[BaseModel], str, str], ...] = (
    ("Sine dwell", DwellParameters, "rigtools.dwell", "rig acquire dwell"),
    ("Stepped sine", SweepParameters, "rigtools.stepped_sine", "rig acquire sweep"),
    (
        "Study on the rig (gap, force or frequency)",
        StudyParameters,
        "rigtools.acquire_study",
        "rig acquire study",
    ),
    ("FRF test", FrfParameters, "rigtools.frf_test", "rig acquire frf"),
    ("Tap test", TapParameters, "rigtools.tap_test", "rig acquire tap"),
    ("Phase-locked loop", PllParameters, "rigtools.phase_locked_loop", "rig acquire pll"),
    ("Force control (the `control` parameter of the sine procedures)", ControlParameters, "", ""),
)


def _default(field) -> str:
    if field.default is PydanticUndefined:
        return "required"
    if isinstance(field.default, BaseModel):
        return "see below"
    return "None" if field.default is None else f"{field.default!r}".replace("|", "\\|")


def _choices(annotation: object) -> str:
    """The allowed words of a ``Literal`` field (``"up, down, both"``), else ``""``."""
    if typing.get_origin(annotation) is typing.Literal:
        return ", ".join(str(a) for a in typing.get_args(annotation))
    return ""


def parameter_rows(model: type[BaseModel]) -> list[dict[str, str]]:
    """One row per parameter of ``model``: ``name``, ``unit`` (SI), ``default``, ``range`` (SI,
    ``"(0, 25000]"``, or the allowed words; empty if unbounded) and ``description``."""
    rows = []
    for name, field in model.model_fields.items():
        rows.append(
            {
                "name": name,
                "unit": field_unit(field),
                "default": _default(field),
                "range": field_bounds(field) or _choices(field.annotation),
                "description": (field.description or "").replace("|", "\\|"),
            }
        )
    return rows


def reference_table() -> str:
    """The parameter reference of every procedure as Markdown (MyST), one table per procedure.

    Quantities take a number in the SI unit shown or a string with a unit (``"60 Hz"``,
    ``"0.5 mm"``), in a script and on the command line alike.

    Returns
    -------
    str
        Markdown text: a heading and a table per procedure.

    Examples
    --------
    >>> from rigtools.procedures import reference_table
    >>> text = reference_table()
    >>> "| fe | Hz | required | (0, 25000] | excitation frequency, Hz |" in text
    True
    """
    out = [
        "# Procedure parameters",
        "",
        "Every parameter of every procedure, generated from the parameter models. A quantity is a",
        'number in the SI unit shown or a string with its unit (`"60 Hz"`, `"0.5 mm"`, `"1 V"`);',
        "ranges are in SI units, `(` and `)` exclusive, `[` and `]` inclusive.",
        "",
    ]
    for title, model, function, command in PROCEDURES:
        out.append(f"## {title}")
        out.append("")
        if function:
            out.append(f"`{function}(...)` in a script, `{command}` on the command line.")
            out.append("")
        out.append("| parameter | unit | default | range | description |")
        out.append("|---|---|---|---|---|")
        for r in parameter_rows(model):
            out.append(f"| {r['name']} | {r['unit']} | {r['default']} | {r['range']} | {r['description']} |")
        out.append("")
    return "\n".join(out)
