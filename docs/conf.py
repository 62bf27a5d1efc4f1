"""Sphinx configuration for geomtex's documentation (built with -W: warnings are errors)."""

from __future__ import annotations

import re
from typing import Any

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
# Notebooks are stored executed (tests/test_notebooks.py runs them); the build shows their outputs.
nb_execution_mode = "off"
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints"]

# -- API reference (docs/api/; tests/test_api_docs.py checks that it lists every public name) --

napoleon_google_docstring = False
napoleon_numpy_docstring = True
# Parameter and return types written in a docstring ("(N, 3) float64 array-like") are prose, shown
# as written: as :type: fields the Python domain would try to cross-reference every word.
napoleon_use_param = False
napoleon_use_rtype = False
autodoc_typehints = "signature"
autodoc_typehints_format = "short"
autodoc_member_order = "bysource"
autosummary_generate = False
# The package's number aliases (numpy scalars accepted) and numpy's array-like, named as written
# instead of spelled out as the unions they stand for; docs/api/geomtex.md describes them.
autodoc_type_aliases = {
    "Int": "geomtex.Int",
    "Real": "geomtex.Real",
    "Flag": "geomtex.Flag",
    "npt.ArrayLike": "ArrayLike",
    "Compare": "geomtex.viewer.Compare",
    "Pattern": "geomtex.gdm.Pattern",
    "Intersector": "geomtex.reference.Intersector",
}
nitpicky = True
# No intersphinx: the build must work offline. Types from numpy, trimesh, the standard library's
# abc and os modules, dask and matplotlib are left unlinked, deliberately; everything of geomtex's
# own must resolve.
nitpick_ignore_regex = [
    ("py:.*", r"(numpy|np|npt|trimesh|dask|distributed|zarr|matplotlib|PIL|ipywidgets)(\..*)?"),
    ("py:.*", r"(os\.PathLike|collections\.abc\..*|typing\..*|types\..*|pathlib\..*)"),
    ("py:.*", r"(NDArray|ArrayLike|ndarray|dtype|Callable|Iterable|Iterator|Sequence|Mapping|PathLike)"),
]

html_theme = "furo"
html_title = "geomtex"

#: Where the public objects live for the reader: ``geomtex._camera.Camera`` (its __module__) is
#: documented as ``geomtex.Camera``. Filled from the public modules' ``__all__``.
_PUBLIC: dict[str, str] = {}
_PUBLIC_MODULES = ("geomtex", "geomtex.igt", "geomtex.gdm", "geomtex.batch", "geomtex.reference",
                   "geomtex.viewer", "geomtex.testing", "geomtex.data")


def _public_names() -> dict[str, str]:
    import importlib

    if not _PUBLIC:
        for modname in _PUBLIC_MODULES:
            module = importlib.import_module(modname)
            for name in module.__all__:
                obj = getattr(module, name)
                home = getattr(obj, "__module__", None)
                qualname = getattr(obj, "__qualname__", None)
                if isinstance(home, str) and isinstance(qualname, str):
                    _PUBLIC.setdefault(f"{home}.{qualname}", f"{modname}.{name}")
    return _PUBLIC


def _public_reference(app: Any, env: Any, node: Any, contnode: Any) -> Any:
    """Resolves a reference to a public object by its private path (``geomtex._camera.Camera``,
    as annotations name it) to its documented public name."""
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"]
    public = _public_names().get(target)
    if public is None:
        # A member: geomtex._set.GeometryTextureSet.save -> geomtex.GeometryTextureSet.save.
        head, _, tail = target.rpartition(".")
        public = _public_names().get(head)
        if public is None:
            return None
        public = f"{public}.{tail}"
    domain = env.get_domain("py")
    return domain.resolve_xref(env, node.get("refdoc", ""), app.builder, node["reftype"], public, node, contnode)


_PROSE: dict[str, list[str]] = {}


def _keep_attribute_prose(app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]) -> None:
    """Attribute docstrings here are prose that begins with shape and dtype ("(H, W) int32: patch
    index ..."); napoleon would take what comes before the first colon as a type to
    cross-reference. Kept before napoleon's handler runs, put back after it."""
    if what in ("attribute", "property", "data"):
        _PROSE[name] = list(lines)


def _restore_attribute_prose(app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]) -> None:
    if name in _PROSE:
        lines[:] = _PROSE.pop(name)


#: Signature text as Sphinx 9 writes it -> as a reader wants it: an alias inside a union comes out
#: as "TypeAliasForwardRef('geomtex.Real') | None"; numpy's NDArray comes out spelled out.
_SIGNATURE_FIXES = [
    (re.compile(r"TypeAliasForwardRef\('([^']+)'\)"), r"\1"),
    (re.compile(r"(?:numpy\.)?ndarray\[tuple\[(?:typing\.)?Any, \.\.\.\], (?:numpy\.)?dtype\[(?:numpy\.)?([\w.]+)\]\]"),
     r"NDArray[\1]"),
    # A dataclass field's default_factory: "<factory>" is no Python, and the signature would be
    # shown unparsed.
    (re.compile(r"<factory>"), "..."),
]


def _readable_signature(app: Any, what: str, name: str, obj: Any, options: Any, signature: str | None,
                        return_annotation: str | None) -> tuple[str | None, str | None]:
    if what == "class" and getattr(obj, "_made_by", None):
        return "", None  # made by factories only: ``Camera(...)`` refuses, so show no constructor
    for pattern, repl in _SIGNATURE_FIXES:
        signature = None if signature is None else pattern.sub(repl, signature)
        return_annotation = None if return_annotation is None else pattern.sub(repl, return_annotation)
    return signature, return_annotation


def setup(app: Any) -> dict[str, Any]:
    """Writes the benchmark pages (docs/benchmarks/, from bench/results/*.json) and copies the
    stored example notebooks into docs/examples/ before Sphinx looks for source files; connects
    the API reference's handlers above."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import bench_pages

    bench_pages.generate()
    app.connect("autodoc-process-signature", _readable_signature)
    app.connect("missing-reference", _public_reference)
    app.connect("autodoc-process-docstring", _keep_attribute_prose, priority=400)
    app.connect("autodoc-process-docstring", _restore_attribute_prose, priority=600)
    return {"parallel_read_safe": True}
