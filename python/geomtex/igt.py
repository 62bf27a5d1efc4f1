"""Inverse geometric textures: shade a strongly simplified mesh with a detailed mesh's attributes.

>>> import geomtex as gt
>>> igt = gt.igt.build(gt.load_mesh("bunny.obj"), primary="charts", resolution=512)
>>> igt.stats["list_mean"], igt.stats["bytes"]
>>> low = gt.igt.simplify(igt, 1400)          # IgtMesh: render it like a mesh
>>> frame = gt.Renderer(512, 512).render(low, camera)

Per cell of a primary parameterization (the conversion's charts, each projected along its own
axis, or a spherical or cylindrical map) the texture lists the detailed triangles overlapping
the cell. A point of the simplified surface is projected into the primary space, the listed
triangle containing it is found, and that triangle's normal, color or texture coordinates are
interpolated there.
"""

from __future__ import annotations

import os
from typing import Any, Callable, Literal, Sequence

import numpy as np

from . import _check, _core, _optional
from ._errors import ParameterError
from ._igt import IgtMesh, InverseGeometricTexture, shading
from ._mesh import as_mesh

__all__ = ["IgtMesh", "InverseGeometricTexture", "attach", "build", "load", "simplify"]


def build(
    mesh: Any,
    *,
    primary: Literal["charts", "spherical", "cylindrical"] = "charts",
    resolution: int | None = None,
    attributes: Sequence[str] | None = None,
    normals: Literal["crease", "smooth", "flat"] | None = None,
    crease_angle: float | None = None,
    charts: int | None = None,
    ao_rays: int | None = None,
    ao_distance: float | None = None,
    progress: Callable[[str, float], Any] | None = None,
) -> InverseGeometricTexture:
    """The inverse geometric texture of a detailed mesh (Mesh, trimesh or path).

    primary: "charts" (the conversion's fold-free charts, bijective by construction),
    "spherical" (star-shaped meshes) or "cylindrical". resolution: about resolution² cells over
    the whole primary space (default 512). attributes: which of "normals", "colors", "uv" to
    keep (default the normals, and the colors and texture coordinates the mesh has), and "ao" to
    compute ambient occlusion per vertex: the unoccluded fraction of `ao_rays` (default 64)
    cosine-weighted rays over the hemisphere around the vertex normal, cast against the detailed
    mesh on the CPU, hits beyond `ao_distance` (mesh units; default none) not counting. It
    darkens the base color where the texture shades (frame.color and frame.albedo), leaving
    normals alone. normals / crease_angle: the normal rule, as for convert. charts: a fixed
    chart count for the partition. progress(stage, fraction)."""
    if isinstance(attributes, str):
        attributes = [attributes]
    if attributes is not None:
        if not isinstance(attributes, (list, tuple)) or not all(isinstance(a, str) for a in attributes):
            raise _check.fail("attributes", 'a str or a list of "normals", "colors", "uv", "ao"', attributes)
    _check.callback("progress", progress)
    return InverseGeometricTexture._wrap(_core.build_igt(
        as_mesh(mesh)._core,
        primary=primary,
        resolution=resolution,
        attributes=None if attributes is None else list(attributes),
        normals=normals,
        crease_angle=crease_angle,
        charts=charts,
        ao_rays=ao_rays,
        ao_distance=ao_distance,
        progress=progress,
    ))


def load(path: str | os.PathLike[str]) -> InverseGeometricTexture:
    """Reads a .gtigt file (``InverseGeometricTexture.save``); FormatError if it is not an
    intact one; FileError if there is no such file."""
    return InverseGeometricTexture._wrap(_core.load_igt(_check.path("path", path, exists=True)))


def _texture(igt: Any) -> InverseGeometricTexture:
    if not isinstance(igt, InverseGeometricTexture):
        raise _check.fail("igt", "a geomtex.igt.InverseGeometricTexture (geomtex.igt.build or load)", igt)
    return igt


def simplify(
    igt: InverseGeometricTexture,
    target_faces: int,
    lookup: str = "ray",
    samples: int = 1,
    lod: str | float = "off",
) -> IgtMesh:
    """The detailed mesh simplified to about `target_faces` faces (pymeshlab's quadric edge
    collapse, normals preserved), as an IgtMesh shaded through `igt` (see `attach` for how its
    faces are given their grids, `lookup`, `samples` and `lod`)."""
    faces = _texture(igt).faces
    if not isinstance(target_faces, (int, np.integer)) or isinstance(target_faces, bool):
        raise ParameterError(f"target_faces must be an integer, got {target_faces!r}")
    if not 4 <= int(target_faces) <= len(faces):
        raise ParameterError(
            f"target_faces must be 4 to the detailed mesh's {len(faces)} faces, got {target_faces}"
        )
    shading(lookup, samples, lod)  # before the decimation, not after it
    pymeshlab = _optional.need("pymeshlab", "geomtex.igt.simplify")

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=igt.vertices, face_matrix=faces.astype(np.int32)))
    ms.meshing_decimation_quadric_edge_collapse(
        targetfacenum=int(target_faces), preservenormal=True, qualitythr=0.5
    )
    low = ms.current_mesh()
    return attach(igt, low.vertex_matrix(), low.face_matrix(), lookup=lookup, samples=samples, lod=lod)


def attach(
    igt: InverseGeometricTexture,
    vertices: Any,
    faces: Any,
    lookup: str = "ray",
    samples: int = 1,
    lod: str | float = "off",
) -> IgtMesh:
    """A mesh simplified from the detailed one (by `simplify` or elsewhere; same space), as an
    IgtMesh shaded through `igt`.

    `lookup`: "ray" (default) shows, per pixel, the first detailed triangle the view ray meets
    near the simplified surface (within each face's measured window, `IgtMesh.face_window`), as
    a ray caster of the detailed mesh would; "projection" the one under the point projected
    along its chart's axis (the paper's lookup: cheaper, but off wherever the two surfaces part
    by more than a triangle). A spherical or cylindrical map always projects.

    `samples`: lookups per pixel, 1 (default: the pixel's centre) or 5 (the centre and four
    points of its footprint on the simplified surface, from the screen-space derivatives of the
    lookup position; normals and colors averaged): the paper's filtering option, against
    aliasing where a pixel covers several detailed triangles, at 5x the lookup cost.

    `lod`, the shader LoD: "off" (default) always looks up through the lists; "auto" shades a
    pixel from a plain texture baked from the same attributes (one value per cell of the
    primary space, read bilinearly) where one cell covers less than a pixel, so the lists would
    resolve detail the pixel cannot show; a number: beyond that distance from the camera (world
    units). The texture is baked once per texture when first drawn (stats["bytes_lod"]).

    Every face is assigned the grid (chart) of the detailed face nearest to its centroid, and its
    points are projected along that chart's axis: the simplified surface lies close to the
    detailed surface it replaces, so that chart is the one whose projection is bijective there.
    (Keeping chart boundaries in the decimation would pin the boundaries' detailed edges and cap
    how far a mesh can be simplified.) A spherical or cylindrical map has one grid."""
    igt = _texture(igt)
    v = _check.rows("vertices", vertices, label="V", min_rows=3, max_rows=2**31)
    f = _check.indices("faces", faces, 3, len(v), label="F", min_rows=1)
    lk, n, level = shading(lookup, samples, lod)
    igt.check_near(v, f)  # before the grids' nearest-face search, which a far mesh makes slow
    face_grid = np.zeros(len(f), dtype=np.int64)
    if igt.primary == "charts":
        from scipy.spatial import cKDTree

        listed = np.flatnonzero(igt.face_grid >= 0)
        centroids = igt.vertices[igt.faces[listed]].mean(axis=1)
        _, nearest = cKDTree(centroids).query(v[f].mean(axis=1))
        face_grid = igt.face_grid[listed[nearest]]
    return IgtMesh._wrap(igt._core.shade(v, f, face_grid.tolist(), lookup=lk, samples=n, lod=level))

