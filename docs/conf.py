"""Sphinx configuration of the documentation site (build: ``sphinx-build -W -n -b html docs build/docs-html``).

The user guide is the repository's markdown pages (MyST), the API reference is generated from the
docstrings (autosummary + numpydoc), and the scripts of ``docs/examples/`` run as a sphinx-gallery.
"""

import importlib
import pkgutil
import shutil
import sys
from pathlib import Path
from typing import Any

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
# The repository's own rigtools/ first (its sibling folders drivers/, sim/, analysis/ then import as
# rigtools.drivers/.sim/.analysis through rigtools/_checkout.py), whatever is installed.
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(DOCS / "_ext"))

import rigtools

project = "shrouded-blade rig toolkit"
author = "the rigtools authors"
copyright = "the rigtools authors, MIT licence"
version = release = rigtools.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "signature_types",
    "reexports",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
templates_path = ["_templates"]
exclude_patterns = [
    "_build",
    "_ext",
    "_templates",
    # examples/README.md is the gallery's header (included by sphinx-gallery's index page)
    "examples",
    "auto_examples/*.ipynb",
    "auto_examples/*.py",
]

# --- procedure parameters --------------------------------------------------------------------------
# The reference page of every procedure parameter (unit, default, range) is generated from the
# parameter models themselves (rigtools.procedures.reference_table), so it cannot drift from them.
from rigtools.procedures.reference import reference_table

_PARAMETERS_PAGE = DOCS / "generated" / "procedure-parameters.md"
_PARAMETERS_PAGE.parent.mkdir(exist_ok=True)
if not _PARAMETERS_PAGE.exists() or _PARAMETERS_PAGE.read_text(encoding="utf-8") != reference_table():
    _PARAMETERS_PAGE.write_text(reference_table(), encoding="utf-8")  # rewritten only when it changed

# --- API reference ---------------------------------------------------------------------------------
# Two parts. The reference (api/index.rst) is the public API: the front door's names (``rigtools.__all__``,
# one page each), what they take and return, and the main functions of rigtools.analysis and
# rigtools.sim, each listed by hand in api/index.rst. The internals (api/internals.rst) are every other
# module, one page per module (its members on it), for whoever changes the toolkit; an object on a
# public page is not documented again there (one page per object: reexports.py sends references to it).
autosummary_generate = True
# autosummary never removes the page of a module that was renamed or deleted, and the stale page
# then fails the build: start every build from no generated pages.
shutil.rmtree(DOCS / "api" / "generated", ignore_errors=True)
shutil.rmtree(DOCS / "api" / "internals", ignore_errors=True)
# A module's __all__ says what it offers: the front door ``rigtools`` lists its names (loaded lazily
# through the module's __getattr__) although they are defined in other modules.
autosummary_ignore_module_all = False
autosummary_imported_members = False
# The internals: every module of these packages but private ones (found on disk, so a new module
# appears without editing the docs). The CLI's command modules are not in it: `rig --help` is their
# documentation and they only parse, call the front door and print.
INTERNAL_PACKAGES = ["rigtools", "rigtools.sim", "rigtools.analysis", "rigtools.drivers"]
INTERNAL_EXCLUDED = ("rigtools.cli", "rigtools.commands")


def _internal_modules() -> list[str]:
    names = []
    for package in INTERNAL_PACKAGES:
        for info in pkgutil.walk_packages(importlib.import_module(package).__path__, f"{package}."):
            parts = info.name.split(".")
            if any(part.startswith("_") for part in parts) or info.name.startswith(INTERNAL_EXCLUDED):
                continue
            if package == "rigtools" and parts[1] in ("sim", "analysis", "drivers"):
                continue  # reached as rigtools.sim etc. through their own entry
            names.append(info.name)
    return sorted(names)


def _public_names() -> set[str]:
    """module.qualname of every object api/index.rst lists (and of the front door's names)."""
    from reexports import canonical, import_name

    names = {canonical(getattr(rigtools, name)) for name in rigtools.__all__}
    module = ""
    listing = False
    for line in (DOCS / "api" / "index.rst").read_text(encoding="utf-8").splitlines():
        if line.startswith(".. currentmodule::"):
            module = line.split("::", 1)[1].strip()
        elif line.startswith(".. autosummary::"):
            listing = True
        elif listing and line.strip() and not line.startswith("   "):
            listing = False
        elif listing and module and line.strip() and not line.strip().startswith(":"):
            names.add(canonical(import_name(f"{module}.{line.strip()}")))
    return {name for name in names if name}


PUBLIC = _public_names()


def _write_internals() -> None:
    folder = DOCS / "api" / "internals"
    folder.mkdir(parents=True, exist_ok=True)
    for name in _internal_modules():
        is_package = hasattr(importlib.import_module(name), "__path__")
        # a package's page is its docstring: the names its __init__ re-exports are documented once,
        # in the module that defines them
        members = "" if is_package else "   :members:\n   :undoc-members:\n   :show-inheritance:\n"
        public = {p.rsplit(".", 1)[1] for p in PUBLIC if p.rsplit(".", 1)[0] == name}
        # names a module re-exports (in its __all__, defined elsewhere) are documented where defined
        module = importlib.import_module(name)
        public |= {
            n
            for n in getattr(module, "__all__", [])
            if getattr(getattr(module, n, None), "__module__", name) != name
        }
        if members and public:  # documented on a public page, or in the module defining them
            members += f"   :exclude-members: {', '.join(sorted(public))}\n"
        title = f"``{name}``"
        text = f"{title}\n{'=' * len(title)}\n\n.. automodule:: {name}\n{members}"
        (folder / f"{name}.rst").write_text(text, encoding="utf-8")


_write_internals()


def _skip_foreign(app: object, what: str, name: str, obj: object, skip: bool, options: object) -> bool | None:
    """Leave out a member another library defined (a scipy function a module imported is scipy's)."""
    if what != "module" or not callable(obj):
        return None  # a constant's __module__ is its type's ("builtins" for a float)
    module = getattr(obj, "__module__", None)
    if isinstance(module, str) and not module.startswith("rigtools"):
        return True
    return None


def setup(app: Any) -> None:
    app.connect("autodoc-skip-member", _skip_foreign)


# nitpicky: every cross-reference must resolve. Sphinx's intersphinx would link the names of Python,
# numpy, scipy, matplotlib, h5py, pandas... to their sites, but it downloads their inventories at
# build time and neither this machine nor CI reaches the network beyond the package registry. So
# intersphinx is off, and a reference to another package's name (or a private base class shown by
# show-inheritance) is accepted as plain text; any reference into rigtools must resolve.
nitpicky = True
_EXTERNAL = (
    "numpy|scipy|matplotlib|pandas|h5py|pydantic|sdypy|pyvisa|nidaqmx|numba|rich|distributed|dask|tornado"
    "|abc|enum|io|logging|functools|pathlib|typing|collections|os|threading|concurrent|subprocess|json"
)
nitpick_ignore_regex = [
    (r"py:.*", rf"({_EXTERNAL})(\..+)?"),
    # Python's builtins as they appear in docstrings and signatures
    (
        r"py:.*",
        r"(int|float|str|bytes|bool|dict|list|tuple|set|object|None|type|Exception|ValueError|OSError)",
    ),
    (r"py:class", r"rigtools\..*\._\w+"),  # a private base class named by show-inheritance
]
autodoc_typehints = (
    "none"  # signatures stay short; signature_types.py writes each type into the parameter list
)
autodoc_member_order = "bysource"
autodoc_mock_imports: list[str] = []

numpydoc_show_class_members = False  # the class template lists members (no duplicate tables)
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = True
# numpydoc's validation, restricted to the checks that catch a docstring drifting from the code or
# one numpydoc cannot read: a documented parameter that does not exist (PR02) or is out of order
# (PR03), "name: type" without the space (PR10), an unknown section (GL06), sections out of order
# (GL07). numpydoc's full list ("all") finds about 2000 style points over the reference (no type
# on a parameter, no See Also, no Examples, no extended summary, undocumented **kwargs...): the
# house style gives units in the description and leaves types to the signature, so those are not
# enforced.
numpydoc_validation_checks = {"PR02", "PR03", "PR10", "GL06", "GL07"}

# --- user guide (the repository's markdown pages) ---------------------------------------------------
myst_enable_extensions = ["colon_fence", "dollarmath"]
myst_heading_anchors = 3
suppress_warnings = [
    # the pages name repository paths such as `docs/calibration.md` in text and link to files
    # outside the site (the README's image is included through relative-images)
    "myst.xref_missing",
]

# --- gallery -------------------------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/[^/]+\.py$",  # every example runs (none needs an argument)
    "ignore_pattern": r"__init__\.py",
    # the library's figures are matplotlib Figures outside pyplot: scrape those the example holds
    # (first: the matplotlib scraper closes pyplot's figures, after which they look like ours)
    "image_scrapers": ("library_figures.scraper", "matplotlib"),
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "show_signature": False,
    "min_reported_time": 1,
    "capture_repr": (),
}

# --- HTML --------------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"rigtools {version}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_static_path: list[str] = []
html_show_sourcelink = False
