"""The API reference and discoverability: every public name has a docstring and an entry on the
pages under docs/api/, ``dir(gt)`` shows only public names, the submodules are attributes of the
package without importing their optional dependencies, and callables that take their keywords as
``**options`` still name them to ``help()``.

Fast (no Sphinx build): the pages' autodoc directives are read as text. "Public" is each public
module's ``__all__``, and for a public class every name without a leading underscore that the
class or one of geomtex's classes it derives from defines (methods, properties, attributes, a
NamedTuple's or dataclass's fields); what it inherits from Python (``tuple.count``,
``Exception.args``) is Python's to document.
"""

from __future__ import annotations

import importlib
import inspect
import re
import subprocess
import sys
import types
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

import geomtex as gt

API_DOCS = Path(__file__).resolve().parents[1] / "docs" / "api"
#: The public modules: the package and the submodules its ``__all__`` names.
PUBLIC_MODULES = ["geomtex", *(f"geomtex.{name}" for name in gt.__all__
                               if isinstance(getattr(gt, name), types.ModuleType))]
#: What ``import geomtex`` must not import (each public submodule imports them when called).
OPTIONAL = ["dask", "distributed", "zarr", "matplotlib", "pymeshlab", "ipywidgets", "ipyevents", "skimage",
            "embreex", "scipy", "nbclient", "tqdm"]

#: ``.. autoclass:: name`` in an eval-rst block, or MyST's ``\`\`\`{autoclass} name`` fence.
_DIRECTIVE = re.compile(r"^(?:\.\. (auto\w+|py:\w+)::|```\{(auto\w+|py:\w+)\})\s*(\S+)\s*$")
_OPTION = re.compile(r"^\s*:([\w-]+):\s*(.*)$")


@dataclass
class Entry:
    """One directive of the API pages: ``.. autoclass:: geomtex.Scene`` and its options."""

    directive: str
    page: str
    options: dict[str, str] = field(default_factory=dict)
    body: list[str] = field(default_factory=list)

    def lists(self, option: str) -> set[str]:
        return {name.strip() for name in self.options.get(option, "").split(",") if name.strip()}


def read_entries(folder: Path = API_DOCS) -> dict[str, Entry]:
    """Every documented name on the pages, fully qualified (``py:`` directives name theirs
    relative to the last ``automodule`` or ``py:currentmodule``)."""
    entries: dict[str, Entry] = {}
    for page in sorted(folder.glob("*.md")):
        module = ""
        current: Entry | None = None
        myst = False  # inside a MyST directive fence: options and body are not indented
        for line in page.read_text().splitlines():
            match = _DIRECTIVE.match(line)
            if match:
                rst, fence, name = match.groups()
                directive = rst or fence
                myst = fence is not None
                if directive in ("automodule", "py:currentmodule", "py:module"):
                    module = name
                if directive == "py:currentmodule":
                    current = None
                    continue
                if directive.startswith("py:") and module and not name.startswith(module + "."):
                    name = f"{module}.{name}"
                current = entries[name] = Entry(directive, page.name)
                continue
            if current is None:
                continue
            option = _OPTION.match(line)
            if myst and line.startswith("```"):
                current, myst = None, False
            elif option and not current.body and (myst or line.startswith(" ")):
                current.options[option.group(1)] = option.group(2)
            elif line.strip() and (myst or line.startswith("   ")):
                current.body.append(line.strip())
            elif line.strip() and not line.startswith(" "):
                current = None
    return entries


ENTRIES = read_entries()


def public_names() -> list[tuple[str, str]]:
    return [(modname, name) for modname in PUBLIC_MODULES for name in importlib.import_module(modname).__all__]


def public_classes() -> list[tuple[str, type]]:
    found = []
    for modname, name in public_names():
        obj = getattr(importlib.import_module(modname), name)
        if isinstance(obj, type):
            found.append((f"{modname}.{name}", obj))
    return found


def class_members(cls: type) -> dict[str, type]:
    """The public members of `cls` and the geomtex class that defines each."""
    members: dict[str, type] = {}
    for klass in cls.__mro__:
        if not klass.__module__.startswith("geomtex"):
            continue
        for name in [*vars(klass), *getattr(klass, "__annotations__", {})]:
            if not name.startswith("_"):
                members.setdefault(name, klass)
    return members


def _comment_above(klass: type, name: str) -> bool:
    """Whether the class body documents `name` with a ``#:`` comment above it (how autodoc reads
    the docs of fields and constants)."""
    try:
        lines = inspect.getsource(klass).splitlines()
    except (OSError, TypeError):
        return False
    for i, line in enumerate(lines):
        if re.match(rf"^\s+{re.escape(name)}\s*[:=]", line):
            return i > 0 and lines[i - 1].strip().startswith("#:")
    return False


def member_doc(klass: type, name: str) -> str:
    """The documentation autodoc would show for a member: its ``#:`` comment, or its own
    docstring (not one it inherits from its type, as an int constant or a NamedTuple field's
    "Alias for field number 0" would)."""
    if _comment_above(klass, name):
        return "#:"
    value = vars(klass).get(name)
    if isinstance(value, (staticmethod, classmethod)):
        value = value.__func__
    if value is None or isinstance(value, (int, float, str, tuple, list, dict, bool)):
        return ""
    doc = inspect.getdoc(value) or ""
    if doc.startswith("Alias for field number") or doc == inspect.getdoc(type(value)):
        return ""
    return doc


def has_own_doc(obj: Any) -> bool:
    """A docstring written for `obj`: a class's own (a NamedTuple or dataclass without one gets
    its signature as ``__doc__``), a function's, a module's."""
    doc = obj.__dict__.get("__doc__") if isinstance(obj, type) else getattr(obj, "__doc__", None)
    name = getattr(obj, "__name__", "")
    return bool(doc and doc.strip() and not doc.startswith(f"{name}("))


# -- every public name: a docstring and an entry --------------------------------------------------


@pytest.mark.parametrize("modname", PUBLIC_MODULES)
def test_public_module_has_all_a_docstring_and_a_page(modname: str) -> None:
    module = importlib.import_module(modname)
    assert isinstance(getattr(module, "__all__", None), list), f"{modname} has no __all__"
    assert has_own_doc(module), f"{modname} has no docstring"
    entry = ENTRIES.get(modname)
    assert entry is not None and entry.directive == "automodule", f"{modname}: no automodule in docs/api/"


@pytest.mark.parametrize("modname, name", public_names(), ids=lambda x: str(x))
def test_public_name_has_a_docstring_and_an_entry(modname: str, name: str) -> None:
    obj = getattr(importlib.import_module(modname), name)
    full = f"{modname}.{name}"
    if isinstance(obj, types.ModuleType):
        assert obj.__name__ in PUBLIC_MODULES
        return
    entry = ENTRIES.get(full)
    assert entry is not None, f"{full} has no entry in docs/api/*.md (autofunction, autoclass, ...)"
    if inspect.isroutine(obj) or isinstance(obj, type):
        assert has_own_doc(obj), f"{full} has no docstring of its own"
        assert entry.directive in ("autofunction", "autoclass", "autoexception"), (
            f"{full}: documented by {entry.directive}")
    else:  # data: its entry says what it is
        assert entry.directive == "py:data" and entry.body, f"{full}: a py:data entry with a description"


@pytest.mark.parametrize("full, cls", public_classes(), ids=lambda x: x if isinstance(x, str) else "")
def test_public_class_members_have_docstrings_and_entries(full: str, cls: type) -> None:
    entry = ENTRIES[full]
    all_members = "members" in entry.options and not entry.lists("members")
    for name, klass in class_members(cls).items():
        where = f"{full}.{name}" + ("" if klass is cls else f" (from {klass.__qualname__})")
        assert member_doc(klass, name), f"{where} has no docstring (or #: comment)"
        listed = (name in entry.lists("members")
                  or (all_members and (klass is cls or "inherited-members" in entry.options))
                  or f"{full}.{name}" in ENTRIES)
        assert listed and name not in entry.lists("exclude-members"), (
            f"{where} is not in the API reference: {entry.page}'s autoclass needs :members:"
            + ("" if klass is cls else " and :inherited-members:"))


def test_pages_name_only_what_exists() -> None:
    """An entry for a name that was renamed or removed fails here, not only in the Sphinx build."""
    for full, entry in ENTRIES.items():
        if not entry.directive.startswith("auto"):
            continue
        modname, _, rest = full.partition(".")
        obj: Any = importlib.import_module(modname)
        for part in rest.split(".") if rest else []:
            obj = getattr(obj, part, None) if not isinstance(obj, types.ModuleType) or hasattr(obj, part) \
                else importlib.import_module(f"{obj.__name__}.{part}")
            assert obj is not None, f"{entry.page}: {full} does not exist"


def test_the_check_sees_a_missing_docstring_and_entry(tmp_path: Path) -> None:
    """The checks above on a made-up page: a member without a docstring, a class without
    :inherited-members: and a name without an entry are all found."""
    (tmp_path / "page.md").write_text(
        "```{eval-rst}\n.. automodule:: geomtex\n   :no-members:\n\n"
        ".. autoclass:: geomtex.Scene\n   :members:\n```\n")
    (tmp_path / "myst.md").write_text(
        "```{autoclass} geomtex.Camera\n:members: look_at\n```\n\n"
        "```{py:data} geomtex.testing.GENERATED\nThe generated meshes.\n```\n")
    entries = read_entries(tmp_path)
    assert set(entries) == {"geomtex", "geomtex.Scene", "geomtex.Camera", "geomtex.testing.GENERATED"}
    assert entries["geomtex.Scene"].options == {"members": ""}
    assert entries["geomtex.Camera"].lists("members") == {"look_at"}
    assert entries["geomtex.testing.GENERATED"].body == ["The generated meshes."]
    assert class_members(gt.Scene)["intersects_first"].__name__ == "RayQueries"  # needs :inherited-members:

    class Undocumented:
        def method(self) -> None:
            pass

    assert member_doc(Undocumented, "method") == "" and not has_own_doc(Undocumented)
    assert member_doc(gt.Frame, "depth") and member_doc(gt.RayHits, "locations")


# -- discoverability --------------------------------------------------------------------------


def test_dir_shows_the_public_names_only() -> None:
    assert dir(gt) == sorted(gt.__all__)
    for leaked in ("Any", "Callable", "Literal", "np", "numbers", "os", "warnings", "annotations"):
        assert leaked not in dir(gt)


def test_import_geomtex_imports_no_optional_dependency() -> None:
    """In a fresh process: ``import geomtex`` and reaching every public submodule as an attribute
    import none of the optional dependencies (each is imported where a call needs it)."""
    script = (
        "import sys, geomtex as gt\n"
        f"optional = {OPTIONAL!r}\n"
        "early = [m for m in optional if m in sys.modules]\n"
        "mods = [getattr(gt, n).__name__ for n in ('batch', 'reference', 'viewer', 'testing', 'igt', 'gdm')]\n"
        "late = [m for m in optional if m in sys.modules]\n"
        "print(early, late, mods)\n"
        "assert not early and not late, (early, late)\n"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.mark.parametrize("func, keywords", [
    (lambda: gt.Renderer.render, {"quality", "method", "light", "outputs", "background", "max_pixel_error"}),
    (lambda: gt.show, {"mesh", "width", "height", "compare", "azimuth_deg", "shading", "quality", "lod"}),
    (lambda: gt.viewer.show, {"mesh", "compare", "azimuth_deg", "shading"}),
    (lambda: gt.viewer.Viewer, {"mesh", "compare", "azimuth_deg", "distance"}),
    (lambda: gt.viewer.Viewer.set, {"azimuth_deg", "compare", "shading"}),
    (lambda: gt.batch.convert_many, {"client", "max_error_rel", "partition", "max_bytes"}),
    (lambda: gt.batch.render_views, {"width", "outputs", "quality", "light"}),
    (lambda: gt.reference.agreement, {"quality", "light"}),
], ids=["Renderer.render", "show", "viewer.show", "Viewer", "Viewer.set", "batch.convert_many",
        "batch.render_views", "reference.agreement"])
def test_keywords_are_named_in_signatures(func: Any, keywords: set[str]) -> None:
    params = inspect.signature(func()).parameters
    assert keywords <= set(params), keywords - set(params)
    assert not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())


def test_render_signature_names_every_render_keyword() -> None:
    from geomtex._render import _RENDER_KEYWORDS

    params = inspect.signature(gt.Renderer.render).parameters
    assert set(_RENDER_KEYWORDS) <= set(params)
    assert all(params[name].kind is inspect.Parameter.KEYWORD_ONLY and params[name].default is None
               for name in _RENDER_KEYWORDS)
