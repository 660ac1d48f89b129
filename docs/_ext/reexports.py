"""Cross-references to a name re-exported elsewhere resolve to the page that documents the object.

An object has one page: a front-door name (``rigtools.dwell``) is documented on the front door's
page, anything else in the module that defines it (``rigtools.recording.reader.open_recording``).
Docstrings name objects the way a script imports them (``rigtools.recording.open_recording``,
``rigtools.procedures.DwellParameters``, ``rigtools.experiments.dwell``): when such a reference
finds no target, this resolves it by importing the name and looking for the documented name of the
same object. A reference to something that is not documented anywhere still fails (nitpicky).
"""

from __future__ import annotations

import importlib
import inspect
from typing import Any

from docutils import nodes
from sphinx.addnodes import pending_xref
from sphinx.application import Sphinx
from sphinx.environment import BuildEnvironment

_MISSING = object()
_DOCUMENTED: dict[str, str] = {}  # filled once per build, after every page is read


def import_name(name: str) -> Any:
    """The object a dotted name imports as, or ``_MISSING``."""
    parts = name.split(".")
    for split in range(len(parts), 0, -1):
        obj: Any = _module(".".join(parts[:split]))
        if obj is _MISSING:
            continue  # not a module: try a shorter prefix
        for attribute in parts[split:]:
            obj = getattr(obj, attribute, _MISSING)
            if obj is _MISSING:
                return _MISSING
        return obj
    return _MISSING


def _module(name: str) -> Any:
    try:
        return importlib.import_module(name)
    except (ImportError, TypeError, ValueError):  # not a module, or not a name at all
        return _MISSING


def canonical(obj: Any) -> str | None:
    """``module.qualname`` of a class or function (``None`` for anything else)."""
    module, qualname = getattr(obj, "__module__", None), getattr(obj, "__qualname__", None)
    if not isinstance(module, str) or not isinstance(qualname, str) or "<" in qualname:
        return None
    return f"{module}.{qualname}"


def _documented(env: BuildEnvironment) -> dict[str, str]:
    """canonical name -> documented name, for every documented class, function and method."""
    cached = _DOCUMENTED
    if not cached:
        domain = env.domains["py"]
        for name, entry in domain.objects.items():
            if entry.objtype not in ("class", "exception", "function", "method", "property"):
                continue
            key = canonical(import_name(name))
            if key is not None and (
                key not in cached or name.startswith("rigtools.") and name.count(".") == 1
            ):
                cached[key] = name  # the front door's name wins over any other
    return cached


def _candidates(node: pending_xref) -> list[str]:
    """The dotted names a reference may mean, most specific first (Python's own lookup order)."""
    target = node["reftarget"].lstrip("~.")
    modules = [node.get("py:module")]
    # a page of the reference documents an object under its public name (rigtools.analyze_recording):
    # its docstring's short names are those of the module that defines it
    page_object = import_name(node["refdoc"].rsplit("/", 1)[-1])
    modules.append(getattr(page_object, "__module__", None))
    names = [target]
    if inspect.isclass(page_object):  # a class's page: its methods and attributes by their short names
        names.append(f"{page_object.__module__}.{page_object.__qualname__}.{target}")
    for module in filter(None, modules):
        if node.get("py:class"):
            names.append(f"{module}.{node['py:class']}.{target}")
        names.append(f"{module}.{target}")
    return names


def _instance_attribute(name: str) -> bool:
    """Whether ``module.Class.attr`` names an attribute the class's code sets on its instances."""
    owner, _, attribute = name.rpartition(".")
    cls = import_name(owner)
    if not inspect.isclass(cls):
        return False
    try:
        source = inspect.getsource(cls)
    except (OSError, TypeError):
        return False
    return f"self.{attribute} " in source or f"self.{attribute}:" in source


def resolve(app: Sphinx, env: BuildEnvironment, node: pending_xref, contnode: nodes.Element) -> Any:
    """A re-exported name links to its object's page; a constant or attribute without an entry of its
    own links to the entry of the class or module that holds it (the name must import)."""
    if node.get("refdomain") != "py":
        return None
    domain = env.domains["py"]
    for name in _candidates(node):
        obj = import_name(name)
        if obj is _MISSING and _instance_attribute(name):
            obj = import_name(name.rsplit(".", 1)[0])  # link to the class that sets it
            name = name.rsplit(".", 1)[0]
        if obj is _MISSING:
            continue
        key = canonical(obj)
        documented = _documented(env).get(key) if key else None
        while documented is None and "." in name:
            name = name.rsplit(".", 1)[0]
            if name in domain.objects:
                documented = name
            else:
                key = canonical(import_name(name))
                documented = _documented(env).get(key) if key else None
        if documented is None:
            continue
        found = domain.resolve_any_xref(env, node["refdoc"], app.builder, documented, node, contnode)
        if found:
            return found[0][1]
    return None


def _forget(app: Sphinx, env: BuildEnvironment) -> None:
    _DOCUMENTED.clear()


def setup(app: Sphinx) -> dict[str, Any]:
    app.connect("env-updated", _forget)
    app.connect("missing-reference", resolve)
    return {"parallel_read_safe": True}
