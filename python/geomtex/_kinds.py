"""The kinds of object a Scene draws, in one table: per kind its Python class, the extension class
the scene takes, how an object becomes that, its label in reprs, how it pickles, its stats and its
box. `Scene.add`, `Scene.__repr__`, pickling, `renderable` (what `Renderer.render` and ray
queries hand the extension) and the viewer's framing all read it; adding a kind (its Rust side
aside: see the README's "Adding an object kind") is one `register` call.

Anything that is no registered kind is read as a mesh (a trimesh, a trimesh.Scene, a mesh file):
the fallback kind, ``"mesh"``.
"""

from __future__ import annotations

import copyreg
from collections import Counter
from dataclasses import dataclass
from typing import Any, Callable, Iterable

import numpy as np
import numpy.typing as npt

from . import _core, _pickle, _preview
from ._bridge import unwrap
from ._errors import InternalError, ParameterError
from ._igt import IgtMesh
from ._mesh import Mesh, as_mesh
from ._set import GeometryTextureSet
from ._surfels import Surfels
from .gdm import Shell

Box = tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]


@dataclass(frozen=True)
class Kind:
    """One kind of drawable object.

    name: the key in `KINDS`. cls: the Python class users hold. core: the extension class the
    scene takes for it. to_core(obj): what the scene takes: an extension object, or a geomtex
    object (unwrapped). label: (singular, plural) in reprs. reduce(obj) -> args and restore(*args)
    -> obj: pickling (restore must be importable by name: a module-level function or a class).
    stats(obj) -> dict: a summary of the object. bounds(obj) -> (lo, hi): its object-space box;
    None for the box of what the extension draws (a mesh's)."""

    name: str
    cls: type
    core: type
    to_core: Callable[[Any], Any]
    label: tuple[str, str]
    reduce: Callable[[Any], tuple[Any, ...]]
    restore: Callable[..., Any]
    stats: Callable[[Any], dict[str, Any]]
    bounds: Callable[[Any], Box] | None = None

    def core_of(self, obj: Any) -> Any:
        """The extension object the scene takes for `obj`, checked to be of this kind's class."""
        handle = unwrap(self.to_core(obj))
        if not isinstance(handle, self.core):
            raise InternalError(f"the {self.name!r} kind made a {type(handle).__name__} of a {type(obj).__name__}, "
                                f"not the extension's {self.core.__name__}")
        return handle

    def box(self, obj: Any) -> Box:
        """(lo, hi) corners of `obj`'s box, in its own space."""
        if self.bounds is not None:
            return self.bounds(obj)
        lo, hi = np.asarray(self.core_of(obj).bounds, dtype=np.float64)
        return lo, hi

    def pickled(self, obj: Any) -> tuple[Any, ...]:
        """`obj` for pickle and copy (registered with copyreg for `cls`)."""
        return self.restore, self.reduce(obj)


#: Every kind by name, in registration order (the order of `describe`).
KINDS: dict[str, Kind] = {}
#: The kind of anything `kind_of` does not know: read as a mesh.
FALLBACK = "mesh"


def register(name: str, cls: type, core: type, to_core: Callable[[Any], Any] = unwrap, *,
             reduce: Callable[[Any], tuple[Any, ...]], restore: Callable[..., Any],
             stats: Callable[[Any], dict[str, Any]], label: tuple[str, str] | None = None,
             bounds: Callable[[Any], Box] | None = None) -> Kind:
    """Adds a kind to the table (or replaces the one of that name) and makes its class pickle
    through it: pickle and copy look a class up in copyreg's table before its ``__reduce__``."""
    taken = [k.name for k in KINDS.values() if k.cls is cls and k.name != name]
    if taken:
        raise ParameterError(f"{cls.__name__} is already the kind {taken[0]!r}")
    kind = Kind(name, cls, core, to_core, label or (name, name + "s"), reduce, restore, stats, bounds)
    KINDS[name] = kind
    copyreg.pickle(cls, kind.pickled)
    return kind


def kind_of(obj: Any) -> Kind | None:
    """The kind of `obj` (a subclass of a kind's class is of that kind), or None."""
    by_class = {kind.cls: kind for kind in KINDS.values()}
    return next((by_class[c] for c in type(obj).__mro__ if c in by_class), None)


def adopt(obj: Any) -> tuple[Kind, Any]:
    """(kind, object) for what a Scene is given: a registered kind's object as it is, anything
    else read as a mesh (MeshError for what is none)."""
    kind = kind_of(obj)
    if kind is not None:
        return kind, obj
    if isinstance(unwrap(obj), _core.Scene):
        raise ParameterError("a Scene cannot hold a Scene: add its objects one by one")
    return KINDS[FALLBACK], as_mesh(obj)


def renderable(obj: Any) -> Any:
    """What the extension draws or traces for `obj`: a Scene's handle, a kind's extension object,
    or a mesh read from anything else."""
    handle = unwrap(obj)
    if isinstance(handle, _core.Scene):
        return handle
    kind, item = adopt(obj)
    return kind.core_of(item)


def describe(objects: Iterable[Any]) -> str:
    """How many objects of each kind, in the table's order: "2 texture sets, 1 mesh"."""
    counts = Counter(kind.name for kind in map(kind_of, objects) if kind is not None)
    return ", ".join(f"{counts[name]} {kind.label[counts[name] != 1]}" for name, kind in KINDS.items()
                     if counts[name])


# ---------------------------------------------------------------------------------------------
# The kinds geomtex draws.


def _set_bounds(gts: GeometryTextureSet) -> Box:
    if len(gts) == 0:
        raise ParameterError("the set has no patches: nothing to show")
    return _preview.box_bounds(gts)


def _surfel_bounds(surfels: Surfels) -> Box:
    if len(surfels) == 0:
        raise ParameterError("the surfels are empty: nothing to show")
    reach = surfels.radii[:, None]
    return (surfels.positions - reach).min(axis=0), (surfels.positions + reach).max(axis=0)


def _vertex_bounds(mesh: IgtMesh) -> Box:
    return mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)


def _shell_bounds(shell: Shell) -> Box:
    lo, hi = shell.bounds
    return lo, hi


def _shell_stats(shell: Shell) -> dict[str, Any]:
    return {"prisms": len(shell.faces), "thickness": shell.thickness, "pieces": shell.pieces,
            "untangled": shell.untangled, "uv_source": shell.uv_source, "lookup": shell.lookup is not None}


register("set", GeometryTextureSet, _core.GeometryTextureSet, label=("texture set", "texture sets"),
         reduce=lambda gts: (gts.to_bytes(),), restore=_pickle.restore_set, stats=lambda gts: gts.stats,
         bounds=_set_bounds)
register("mesh", Mesh, _core.Mesh, label=("mesh", "meshes"), reduce=_pickle.mesh_arrays, restore=_pickle.restore_mesh,
         stats=lambda m: {"vertices": m.n_vertices, "faces": m.n_faces, "textured": m.textured,
                          "diagonal": m.diagonal})
register("surfels", Surfels, _core.Surfels, label=("surfel hierarchy", "surfel hierarchies"),
         reduce=lambda s: (s.to_bytes(),), restore=_pickle.restore_surfels, stats=lambda s: s.stats,
         bounds=_surfel_bounds)
register("igt_mesh", IgtMesh, _core.IgtMesh, label=("IGT mesh", "IGT meshes"),
         reduce=lambda m: (m.igt, m.vertices, m.faces, m.face_grid, m.lookup, m.samples, m.lod),
         restore=_pickle.restore_igt_mesh,
         stats=lambda m: {"vertices": len(m.vertices), "faces": len(m), "lookup": m.lookup, "samples": m.samples,
                          "lod": m.lod},
         bounds=_vertex_bounds)
register("gdm_shell", Shell, _core.GdmShell, Shell._to_core, label=("GDM shell", "GDM shells"),
         reduce=lambda shell: (shell.__getstate__(),), restore=_pickle.restore_shell, stats=_shell_stats,
         bounds=_shell_bounds)
