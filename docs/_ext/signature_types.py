"""Parameter types from the signature, written into numpydoc's parameter lists.

The house style gives each parameter's unit and meaning in the docstring and leaves its type to the
annotation (``fe`` then its description, not ``fe : float | str``). Sphinx's
``autodoc_typehints = "description"`` adds ``:param:`` fields, which numpydoc's sections never are
(the page would get a second, type-only "Parameters" list), so this extension does it numpydoc's
way: before numpydoc reads a docstring, each entry of its Parameters, Other Parameters (from the
signature) and Attributes (from the class annotations) sections that names no type gets the
annotation's text, ``name : type``. An entry that states a type keeps it.
"""

from __future__ import annotations

import inspect
import re
from typing import Any

from sphinx.application import Sphinx
from sphinx.util.typing import stringify_annotation

_SECTIONS = {"Parameters": "signature", "Other Parameters": "signature", "Attributes": "annotations"}
_HEAD = re.compile(r"^(\*{0,2}[A-Za-z_][\w]*)\s*$")  # an entry naming one parameter and no type


def _text(annotation: Any) -> str | None:
    if annotation is inspect.Parameter.empty:
        return None
    if isinstance(annotation, str):  # `from __future__ import annotations`: the source's own text
        return annotation
    return stringify_annotation(annotation, "smart").replace("~", "")


def _signature_types(obj: Any) -> dict[str, str]:
    target = obj.__init__ if inspect.isclass(obj) else obj
    try:
        signature = inspect.signature(target)
    except (TypeError, ValueError):
        return {}
    types = {}
    for name, parameter in signature.parameters.items():
        text = _text(parameter.annotation)
        if text is None:
            continue
        star = {inspect.Parameter.VAR_POSITIONAL: "*", inspect.Parameter.VAR_KEYWORD: "**"}
        types[star.get(parameter.kind, "") + name] = text
    return types


def _annotation_types(obj: Any) -> dict[str, str]:
    if not inspect.isclass(obj):
        return {}
    types: dict[str, str] = {}
    for cls in reversed(obj.__mro__):
        for name, annotation in getattr(cls, "__annotations__", {}).items():
            text = _text(annotation)
            if text is not None and not text.startswith("ClassVar"):
                types[name] = text
    return types


def add_types(app: Sphinx, what: str, name: str, obj: Any, options: Any, lines: list[str]) -> None:
    """Give every untyped entry of the docstring's parameter sections its annotation."""
    if what not in ("function", "method", "class", "exception"):
        return
    lookups = {"signature": None, "annotations": None}
    section = None
    for i, line in enumerate(lines):
        if i + 1 < len(lines) and re.fullmatch(r"-{3,}", lines[i + 1].strip()) and not line.startswith(" "):
            section = _SECTIONS.get(line.strip())
            continue
        if section is None or not line or line.startswith(" "):
            continue
        match = _HEAD.match(line)
        if match is None:
            continue
        if lookups[section] is None:
            lookups[section] = _signature_types(obj) if section == "signature" else _annotation_types(obj)
        text = lookups[section].get(match.group(1))
        if text is not None:
            lines[i] = f"{match.group(1)} : {text}"


def setup(app: Sphinx) -> dict[str, Any]:
    # before numpydoc's own handler (priority 500) turns the sections into reST
    app.connect("autodoc-process-docstring", add_types, priority=400)
    return {"parallel_read_safe": True}
