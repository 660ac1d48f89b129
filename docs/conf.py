"""Sphinx configuration of the documentation site (build: ``sphinx-build -W -b html docs build/docs-html``).

The user guide is the repository's markdown pages (MyST), the API reference is generated from the
docstrings (autosummary + numpydoc), and the scripts of ``docs/examples/`` run as a sphinx-gallery.
"""

import importlib
import pkgutil
import shutil
import sys
from pathlib import Path

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
autosummary_generate = True
# autosummary never removes the page of a module that was renamed or deleted, and the stale page
# then fails the build: start every build from no generated pages.
shutil.rmtree(DOCS / "api" / "generated", ignore_errors=True)
# A module's __all__ says what it offers: the front door ``rigtools`` lists its names (loaded lazily
# through the module's __getattr__) although they are defined in other modules.
autosummary_ignore_module_all = False
autosummary_imported_members = False
# The packages of the reference and their modules (every module but private ones, found on disk, so
# a new module appears without editing the docs); the template "package" lists them.
API_PACKAGES = [
    "rigtools.procedures",
    "rigtools.recording",
    "rigtools.interop",
    "rigtools.sim",
    "rigtools.analysis",
    "rigtools.drivers",
]


def _submodules(package: str) -> list[str]:
    path = importlib.import_module(package).__path__
    return [f"{package}.{m.name}" for m in pkgutil.iter_modules(path) if not m.name.startswith("_")]


autosummary_context = {"api_submodules": {name: _submodules(name) for name in API_PACKAGES}}
autodoc_typehints = "none"  # numpydoc shows the documented types; signatures stay short
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
