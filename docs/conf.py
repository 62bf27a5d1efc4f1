"""Sphinx configuration for geomtex's documentation (built with -W: warnings are errors)."""

from __future__ import annotations

import geomtex

project = "geomtex"
author = "the geomtex developers"
copyright = "2026, the geomtex developers"
release = geomtex.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "myst_nb",
]
# Notebooks are stored executed (tests/test_notebooks.py runs them); the build renders their outputs.
nb_execution_mode = "off"
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints"]

napoleon_google_docstring = False
napoleon_numpy_docstring = True
autodoc_typehints = "description"
nitpicky = True

html_theme = "furo"
html_title = "geomtex"


def setup(app):  # noqa: ANN001, ANN201 - Sphinx's extension hook
    """Writes the benchmark pages (docs/benchmarks/, from bench/results/*.json) and copies the
    stored example notebooks into docs/examples/ before Sphinx looks for source files."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import bench_pages

    bench_pages.generate()
    return {"parallel_read_safe": True}
