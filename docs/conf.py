"""Sphinx configuration of vislod's documentation site (``make docs``).

Tools, the PyData ecosystem's: Sphinx with pydata-sphinx-theme; numpydoc reads the docstrings
(vislod's docstrings are numpydoc) and autosummary writes one page per public name of ``soc``
and ``lod`` (their ``__all__``). Pages are MyST markdown, read by myst-nb, which also renders
the notebooks. myst-nb rather than sphinx-gallery because vislod's worked examples already are
notebooks (one per source document, run in CI in quick mode) and its guides are markdown whose
Python blocks the test suite executes (sybil, ``tests/test_docs.py``): myst-nb renders both as
they are, where sphinx-gallery would need every example rewritten as a script.

Quick mode (the default, and CI's): the notebooks are rendered without executing them and the
method pictures are the stored ones (``docs/gallery/methods``). ``VISLOD_DOCS_EXECUTE=1``
executes the notebooks (in vislod's quick mode) so their outputs show; ``make docs-pictures``
redraws the method pictures.

Generated pages (``docs/generated/``, not in git) are written by ``docs/_ext/vislod_docs.py``
before Sphinx reads anything: a page per culling method from the registry
(:data:`soc.methods.METHODS`), the API reference from ``__all__``, and the reproductions and
benchmarks from ``results/REPORT.md`` and ``results/BENCHMARKS.md``.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS.parent))
sys.path.insert(0, str(DOCS / "_ext"))
os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

project = "vislod"
author = "the vislod developers"
copyright = "2026, the vislod developers"
try:
    from importlib.metadata import version as _version

    release = _version("vislod")
except Exception:  # not installed: read from the checkout
    release = "0.1.0"

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "myst_nb",
    "vislod_docs",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"
exclude_patterns = ["_build", "gallery/README.md", "tools", "Thumbs.db", ".DS_Store"]
templates_path = ["_templates"]

# Reference: one page per public name (autosummary), docstrings read by numpydoc.
autosummary_generate = True
autosummary_imported_members = True
autodoc_typehints = "none"  # the numpydoc sections carry the types
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# Notebooks: stored outputs in quick mode; VISLOD_DOCS_EXECUTE=1 runs them (vislod quick mode).
EXECUTE = os.environ.get("VISLOD_DOCS_EXECUTE", "") not in ("", "0")
nb_execution_mode = "force" if EXECUTE else "off"
nb_execution_timeout = 600
nb_execution_raise_on_error = True
if EXECUTE:
    os.environ.setdefault("VISLOD_QUICK", "1")

myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3
# The generated reproduction and benchmark pages keep results/*.md's own heading levels.
suppress_warnings = ["myst.header"]

html_theme = "pydata_sphinx_theme"
html_title = "vislod"
html_static_path: list[str] = []
html_theme_options = {
    "navbar_align": "left",
    "show_toc_level": 2,
    "navigation_with_keys": False,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
    "secondary_sidebar_items": ["page-toc"],
}
html_sidebars = {"**": ["sidebar-nav-bs"]}
html_show_sourcelink = False
