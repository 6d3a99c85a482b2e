"""Sphinx configuration of pftrack's documentation (``./dev docs`` builds it into docs/_build)."""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))

project = "pftrack"
author = "the pftrack developers"
copyright = "the pftrack developers, BSD-3-Clause"  # noqa: A001 - Sphinx's name

extensions = [
    "myst_nb",                 # Markdown pages and the executed notebooks
    "sphinx.ext.autodoc",      # the API reference from the docstrings
    "sphinx.ext.autosummary",
    "numpydoc",                # ... which are numpydoc
    "sphinx.ext.viewcode",
    "pftrack_docs",            # generated pages: configuration reference, API, gallery
]

exclude_patterns = ["_build", "_generated", "README.md", "**/.ipynb_checkpoints", "gallery/*.tmp"]
source_suffix = {".md": "myst-nb", ".ipynb": "myst-nb"}

# notebooks are executed by pftrack_docs (per-notebook short slices, as the tests run them)
nb_execution_mode = "off"
nb_merge_streams = True
nb_render_markdown_format = "myst"   # the notebooks' Markdown tables (CommonMark has none)
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3

autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"          # numpydoc's Parameters sections say the types
autodoc_mock_imports: list[str] = []
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False


html_theme = "furo"
html_title = "pftrack"
html_static_path = ["_static"]
html_css_files = ["pftrack.css"]
html_theme_options = {"navigation_with_keys": True}
nitpicky = False
