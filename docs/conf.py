"""Sphinx configuration of pendfmu's documentation site (docs/build.py builds it; `make docs`).

Offline at build and at view time: no intersphinx (it would fetch other projects'
inventories), no CDN (furo ships its CSS and JavaScript; the pages have no math, which
would load MathJax from a CDN: tests/test_docs_site.py checks that every script and style
sheet is a local file). The reference pages' generated parts come from the extension in
_ext/pendfmu_docs, at build time, from the code itself.
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

from pendfmu import __version__  # noqa: E402

project = "pendfmu"
author = "the pendfmu developers"
copyright = "the pendfmu developers"
version = release = __version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "numpydoc",
    "matplotlib.sphinxext.plot_directive",
    "pendfmu_docs",
]

# Pictures drawn at build time from the code on the page ({plot}: the rig on the model page),
# as PNG only, without links to their source or other formats.
plot_formats = [("png", 110)]
plot_html_show_source_link = False
plot_html_show_formats = False

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}  # .rst: numpydoc's autosummary asks for it
root_doc = "index"
exclude_patterns = ["_build", "_ext"]

# Warnings are errors (docs/build.py: -W --keep-going -n): every cross-reference must resolve.
nitpicky = True
smartquotes = False  # --out stays --out (not an en dash), 'x' stays as typed
myst_heading_anchors = 3  # [text](page.md#a-heading) links to headings, checked like any other reference
suppress_warnings: list[str] = []

# The API reference: numpydoc renders the docstrings' sections; signatures keep their type
# hints, which name classes of numpy, the standard library and pendfmu's internal modules
# that the site does not document: those are ignored below, every other reference is checked.
autodoc_typehints = "signature"
autodoc_preserve_defaults = True  # a default as the source writes it (RIG), not its repr
autodoc_member_order = "bysource"
autodoc_default_options = {"undoc-members": False}
numpydoc_show_class_members = False  # the members are documented by autodoc itself
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()  # the docstrings' sections are checked by a test, not by the build
nitpick_ignore_regex = [
    # outside the site: Python's and the libraries' own types (no intersphinx: offline)
    (r"py:.*", r"(numpy|np|pandas|pd|pathlib|collections|typing|argparse|ctypes|concurrent|subprocess|os|io|"
               r"datetime|enum|dataclasses|lxml|fmpy|scipy|distributed|dask|pytest|_pytest)(\..*)?"),
    (r"py:.*", r"(int|float|str|bool|bytes|dict|list|tuple|set|frozenset|object|type|callable|None|"
               r"Path|Sequence|Mapping|Iterable|Iterator|Callable|Collection|Any|Self|Literal|Optional|"
               r"ndarray|DataFrame|Series|Element|ElementTree|ArrayLike|NDArray|Generator|ContextManager)"),
]

# pendfmu's internal classes that public signatures name: not documented (they may change),
# listed by name so that a new one shows (document it or list it here).
INTERNAL = ("pendfmu.fitting.checkpoint.Checkpoint", "pendfmu.fitting.ranking.LawComparison",
            "pendfmu.fitting.result.ExperimentFit", "pendfmu.simulator.model.Instance", "pendfmu.simulator.model.Port",
            "pendfmu.simulator.graph.Wire", "pendfmu.components.Component", "pendfmu.ssp._xml.Locator",
            "pendfmu.ssp.fmu.FmuDescription", "pendfmu.control.plant.RigModel")
nitpick_ignore = [("py:class", name) for name in INTERNAL]

html_theme = "furo"
html_title = f"pendfmu {__version__}"
html_static_path: list[str] = []
html_show_sourcelink = False
html_copy_source = False
html_last_updated_fmt = None
