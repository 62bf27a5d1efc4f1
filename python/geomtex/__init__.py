"""geomtex: dense triangle meshes as geometry textures — height-map patches in oriented boxes.

>>> import geomtex as gt
>>> gts = gt.convert(gt.load_mesh("bunny.obj"), max_resolution=256)
>>> gts.stats["charts"], gts.stats["empty_fraction"]
"""

from __future__ import annotations

import os
import warnings
from typing import Any, Callable, Literal

# Mesa's Vulkan device-select layer prints a spurious "XDG_RUNTIME_DIR is invalid" on headless
# machines; geomtex picks its adapter itself, so the layer is not needed.
os.environ.setdefault("NODEVICE_SELECT", "1")

from . import _check, _core, _progress, data, gdm, igt  # noqa: E402
from ._bridge import spelled_out as _spelled_out  # noqa: E402
from ._camera import Camera  # noqa: E402
from ._check import flag as _flag  # noqa: E402
from ._check import number as _number  # noqa: E402
from ._core import __version__  # noqa: E402
from ._errors import (  # noqa: E402
    CancelledError,
    CapWarning,
    DeviceError,
    FileError,
    FormatError,
    GeomtexError,
    InternalError,
    MeshError,
    ParameterError,
)
from ._frame import Frame  # noqa: E402
from ._info import info  # noqa: E402
from ._mesh import AppearanceWarning, Mesh, as_mesh, load_mesh  # noqa: E402
from ._rays import RayHits  # noqa: E402
from ._render import DirectionalLight, PointLight, Renderer  # noqa: E402
from ._scene import Scene  # noqa: E402
from ._set import GeometryTextureSet  # noqa: E402
from ._surfels import Surfels  # noqa: E402
from ._viewstate import SHOW_KEYWORDS as _SHOW_KEYWORDS  # noqa: E402

__all__ = [
    "AppearanceWarning",
    "Camera",
    "CancelledError",
    "CapWarning",
    "DeviceError",
    "FileError",
    "DirectionalLight",
    "FormatError",
    "Frame",
    "GeometryTextureSet",
    "GeomtexError",
    "InternalError",
    "Mesh",
    "MeshError",
    "ParameterError",
    "PointLight",
    "RayHits",
    "Renderer",
    "Scene",
    "Surfels",
    "__version__",
    "as_mesh",
    "batch",
    "convert",
    "data",
    "gdm",
    "igt",
    "info",
    "load",
    "load_mesh",
    "load_surfels",
    "reference",
    "show",
    "testing",
    "viewer",
]

ProgressCallback = Callable[[str, float], "bool | None"]


def convert(
    mesh: Any,
    *,
    max_resolution: int | None = None,
    texel_size: float | None = None,
    max_error: float | None = None,
    max_error_rel: float | None = None,
    error_scope: Literal["set", "chart"] | None = None,
    partition: Literal["cone", "vsa"] | None = None,
    cone_angle: float | None = None,
    chart_size: float | None = None,
    charts: int | None = None,
    chart_error: float | None = None,
    max_charts: int | None = None,
    compactness: float | None = None,
    lloyd_iterations: int | None = None,
    overlap_rings: int | None = None,
    dilation: int | None = None,
    frame: Literal["min_area", "pca"] | None = None,
    normals: Literal["crease", "smooth", "flat"] | None = None,
    crease_angle: float | None = None,
    height_bits: Literal[8, 16] | None = None,
    max_bytes: int | None = None,
    guarantee: bool | None = None,
    hybrid: bool | None = None,
    progress: bool | ProgressCallback | None = None,
) -> GeometryTextureSet:
    """Converts a mesh into geometry textures: height-map patches in oriented boxes.

    With none of `max_resolution`, `texel_size`, `max_error`, `max_error_rel` and `max_bytes` the
    conversion is error-driven with the cone partition: ``max_error_rel=2e-4`` for a mesh that
    shows no more outline for its area than the Stanford bunny, tighter by
    10.5 / ``stats["outline_ratio"]`` for one that shows more (outline length over projected area
    times the diagonal, on its three axis projections; thin parts lose more IoU for the same
    error, homer: 15.9, 1.32e-4), at most 4x tighter. The set is hybrid (see `hybrid`): each
    chart is a height map only where one within the bound takes fewer bytes than the chart's own
    triangles, and the rest stay the mesh's faces, so it never takes more bytes than the mesh.
    ``hybrid=False`` gives all height maps within ``max_bytes`` = the mesh's float32/uint32
    bytes, or for a mesh under 50,000 faces an allowance of 4 MB x (1 - faces / 50,000) x 2e-4 /
    bound if that is more; a rough mesh that cannot meet the bound within them gets the least
    error the budget buys (``stats["max_bytes_binding"]`` is 1, and a :class:`CapWarning` says
    by how much it missed and how to meet it). Any of those keywords converts as before.

    The work runs in Rust on all cores with the GIL released.

    Parameters
    ----------
    mesh : Mesh, trimesh.Trimesh, trimesh.Scene or path
        The mesh to convert; a path is read with :func:`load_mesh`, a trimesh object with
        :meth:`Mesh.from_trimesh`.
    max_resolution : int, optional
        Longest side of any patch in texels (default 256; 1024 with `max_error`, where it only
        caps a chart's memory). Without `max_error` one texel size serves every patch, chosen so
        the largest chart just fits.
    texel_size : float, optional
        World size of a texel (grown if a chart would exceed `max_resolution`).
    max_error : float, optional
        Error-driven resolution, in world units. Each chart gets its own texel size, from
        long-side resolutions `max_resolution` down to 2 in steps of 2^(1/4), chosen for the
        fewest bytes that keep the reconstruction error within `max_error` (see `error_scope`);
        `max_resolution` stays the cap. Error is the 99th percentile, by area, of the distances
        from points on a chart's triangles to its height field and from its rim texels to the
        triangles they copy, measured on the maps as stored. ``stats["patch_resolution"]``,
        ``["patch_texel"]`` and ``["patch_error"]`` give each chart's choice;
        ``stats["texel_size"]`` is then the finest chart's texel. Without it one texel size
        serves every chart.
    max_error_rel : float, optional
        `max_error` as a fraction of the bounding-box diagonal.
    error_scope : {"set", "chart"}, optional
        ``"set"`` (default) bounds the set's error, ``stats["reconstruction_error_p99"]``, with
        the fewest bytes: charts whose tail (a crease, a steep rim) would be dear to remove keep
        it while cheaper charts get finer. ``"chart"`` bounds every chart's own error, which
        costs more where charts differ.
    partition : {"cone", "vsa"}, optional
        How the mesh is cut into charts (default ``"cone"`` when error-driven without `charts`
        or `chart_error`, else ``"vsa"``). ``"vsa"``: the paper's Variational Shape
        Approximation, driven by `chart_error` or `charts`. ``"cone"``: each chart grows from a
        seed while its face normals stay within `cone_angle` degrees of one axis, so no face
        comes near folding, and within `chart_size` of the bounding-box diagonal from its seed;
        VSA's L2,1 error only orders the faces a chart takes, a chart turns away faces that
        would lie over or under its surface (a second sheet), and small charts merge into a
        neighbour while the cone and size still fit. No cap, no folding repair, linear time
        (see bench/partition.py).
    cone_angle : float, optional
        Half-angle of a cone chart's normal cone, degrees, in (0, 85] (default 60).
    chart_size : float, optional
        Largest distance from a cone chart's seed to its faces, as a fraction of the
        bounding-box diagonal (default 0.1); without `max_error` the largest chart sets every
        patch's texel, so smaller charts mean finer texels and more bytes.
    charts : int, optional
        Exact VSA chart count. By default charts are added until the area-weighted mean L2,1
        error ``sum(area |n - N|^2) / sum(area)`` is at most `chart_error`.
    chart_error : float, optional
        VSA's target mean L2,1 error (default 0.1; with `max_error`, ``partition="vsa"`` and
        neither `charts` nor `chart_error` given, 0.1, 0.2 and 0.3 are tried and the set within
        the bound with the fewest bytes is kept, since a chart with its own texel no longer sets
        everyone's and fewer, larger charts draw fewer ring faces twice; ``stats["chart_error"]``
        says which).
    max_charts : int, optional
        Most VSA charts (default 4096). ``stats["charts_capped"]`` is 1 when it stopped VSA
        before its target (a :class:`CapWarning` is also issued).
    compactness : float, optional
        Weight of the distance term that keeps VSA charts round (default 1.0).
    lloyd_iterations : int, optional
        VSA refinement rounds (default 6).
    overlap_rings : int, optional
        Rings of neighbouring faces each patch also draws (default 1: seamless borders).
    dilation : int, optional
        Texels of normal/color dilation into empty space (default 2).
    frame : {"min_area", "pca"}, optional
        In-plane axes from the minimum-area rectangle (default) or 2D PCA (the paper's).
    normals : {"crease", "smooth", "flat"}, optional
        ``"crease"`` (default): smooth within a surface, split at edges where the faces' normals
        differ by `crease_angle` degrees or more (trimesh's ``smooth_shade``); ``"smooth"``:
        vertex normals averaged over every edge; ``"flat"``: face normals. Vertex normals are
        weighted by corner angle, as trimesh's.
    crease_angle : float, optional
        Degrees, in (0, 180] (default 20).
    height_bits : {16, 8}, optional
        16 (default) or 8. Eight bits halve the height maps' bytes (a texel then takes 4 bytes
        instead of 5, 8 instead of 9 with colors) and round each height to 1/254 of its patch's
        height range; ``stats["max_quantization_error"]`` gives the worst rounding in world
        units.
    max_bytes : int, optional
        Most bytes the maps may take (``stats["bytes"]``): the conversion is repeated with a
        coarser texel (scaled by the square root of the excess) until they fit, at most 6 times
        (``stats["max_bytes_coarsenings"]``). With `max_error` each chart's level is chosen
        within the budget instead: the bound where it fits, else the least area over it
        (``stats["max_bytes_binding"]`` is 1 and a :class:`CapWarning` says by how much the
        bound was missed; not with ``error_scope="chart"``). If they still do not fit,
        ``stats["max_bytes_exceeded"]`` is 1 and a :class:`CapWarning` says so.
    guarantee : bool, optional
        With `max_error` (or `max_error_rel`): choose each chart's level by its cells' error
        bounds instead of a sampled percentile, so that every point of the stored surface is
        within `max_error` of the mesh (``stats["error_bound_max"]`` <= ``stats["max_error"]``;
        see :doc:`/guides/error-bounds`). Raises :class:`ParameterError` where that cannot be
        met: a chart over the bound at `max_resolution`, or more bytes than `max_bytes`.
    hybrid : bool, optional
        Hybrid sets: each chart becomes a height map only where one within the error bound
        takes fewer bytes than the chart's own triangles (float32 vertices, uint32 indices);
        the rest stay the mesh's faces, exact, drawn and traced as a mesh
        (``GeometryTextureSet.triangles``; their pixels and hits get the next mesh id,
        ``-2 - k``). The set then never takes more bytes than the mesh (``stats["bytes"]`` <=
        ``stats["mesh_bytes"]``), and there is no byte budget. Default: on with the default
        bound or `max_error`/`max_error_rel`, unless `max_bytes` is given; True with a fixed
        resolution or `max_bytes` is a :class:`ParameterError`. A face-colored or textured mesh
        stays all height maps. ``to_surfels`` gives surfels for the height maps and draws the
        triangles beside them; ``first_hits`` traces both (id -2 on a triangle); ``filtered``
        leaves the triangles as they are.
    progress : bool or callable, optional
        True for a tqdm bar, or ``callback(stage, fraction)``; returning False cancels.

    Returns
    -------
    GeometryTextureSet
        The patches; ``stats`` holds the conversion's figures (charts, bytes, texel_size,
        reconstruction_error_p99, error_bound_max and error_bound_p99 (world units: the largest
        and 99th-percentile bound on the distance from a stored surface point to the mesh, over
        the bound map's blocks) and error_bound_bytes (counted in bytes), the caps above,
        per-stage seconds, ...).

    Raises
    ------
    MeshError
        The mesh is unusable (NaN or infinite vertices, bad indices, no faces).
    ParameterError
        A keyword is out of range, of the wrong type, or contradicts another.
    FileError, FormatError
        A mesh path that cannot be read, or does not hold a mesh.
    CancelledError
        The progress callback returned False.

    Warns
    -----
    CapWarning
        A cap was hit: VSA stopped at `max_charts`, the maps exceed `max_bytes`, or the error
        bound was missed within the byte budget. The set is returned all the same.
    """
    m = as_mesh(mesh)
    integers = {name: _number(name, value, int) for name, value in [
        ("max_resolution", max_resolution), ("charts", charts), ("max_charts", max_charts),
        ("lloyd_iterations", lloyd_iterations), ("overlap_rings", overlap_rings),
        ("dilation", dilation), ("height_bits", height_bits), ("max_bytes", max_bytes)]}
    reals = {name: _number(name, value, float) for name, value in [
        ("texel_size", texel_size), ("max_error", max_error), ("max_error_rel", max_error_rel),
        ("chart_error", chart_error), ("compactness", compactness), ("crease_angle", crease_angle),
        ("cone_angle", cone_angle), ("chart_size", chart_size)]}
    callback: ProgressCallback | None
    bar = None
    if progress is True:
        bar = callback = _progress.Stages()
    elif callable(progress):
        callback = progress
    elif progress in (None, False):
        callback = None
    else:
        raise ParameterError(f"progress must be True, False, None or a callable, got {progress!r}")
    try:
        gts = GeometryTextureSet._wrap(_core.convert(
            m._core, **integers, **reals, error_scope=error_scope, partition=partition, frame=frame,
            normals=normals, guarantee=None if guarantee is None else _flag("guarantee", guarantee),
            hybrid=None if hybrid is None else _flag("hybrid", hybrid), progress=callback))
    finally:
        if bar is not None:
            bar.close()
    _warn_caps(gts.stats, default_budget=all(v is None for v in (
        max_resolution, texel_size, max_error, max_error_rel, max_bytes)))
    return gts


def _warn_caps(stats: dict[str, Any], default_budget: bool = False) -> None:
    """A CapWarning for each cap the conversion hit (never silent). `default_budget`: the
    conversion ran with the default bound and budget (none of the keywords that choose them)."""
    if stats.get("charts_capped"):
        warnings.warn(f"the partition stopped at {stats['vsa_charts']:.0f} charts (max_charts) with mean "
                      f"L2,1 error {stats['vsa_mean_error']:.3g}, above its target {stats['chart_error']:.3g}; "
                      "stats['charts_capped'] is 1 (partition='cone' has no cap to hit)", CapWarning, stacklevel=3)
    if stats.get("max_bytes_exceeded"):
        warnings.warn(f"the maps take {stats['bytes']} bytes, over max_bytes={stats['max_bytes']}, "
                      f"after {stats['max_bytes_coarsenings']} coarser texels; "
                      f"stats['max_bytes_exceeded'] is 1", CapWarning, stacklevel=3)
    p99, bound = stats.get("reconstruction_error_p99", 0.0), stats.get("max_error", float("inf"))
    if stats.get("max_bytes_binding") and p99 > bound:
        # What would meet the bound is known (the same bound, no budget: each chart then takes
        # the level that meets it, up to max_resolution); the bytes that takes are not, short of
        # converting again.
        rel = bound / stats["diagonal"]
        if default_budget:
            budget = "the default budget (the mesh's own float32/uint32 bytes, or its allowance)"
            remedy = (f"gt.convert(mesh, max_error_rel={rel:.6g}) meets it (a hybrid set: triangles where "
                      "height maps cost more, within the mesh's bytes; with hybrid=False all height maps, "
                      "without a byte budget)")
        else:
            budget = "max_bytes"
            remedy = "a larger max_bytes, or max_bytes=None (no byte budget), meets it"
        warnings.warn(f"the conversion missed its error bound: reconstruction_error_p99 {p99:.3g} is "
                      f"{p99 / bound:.2f}x max_error {bound:.3g} ({rel:.3g} of the diagonal), as the maps had "
                      f"to fit {budget}, {stats['max_bytes']:.0f} bytes; {remedy} (how many bytes that takes "
                      "is not known without converting); stats['max_bytes_binding'] is 1", CapWarning,
                      stacklevel=3)


@_spelled_out(*_SHOW_KEYWORDS)
def show(obj: Any, **options: Any) -> Any:
    """An interactive viewer in Jupyter: drag to orbit, scroll to zoom, quality / LOD / shading
    selectors, the original mesh beside or over it with ``mesh=``.

    The keywords and what they do are :func:`geomtex.viewer.show`'s (this imports the viewer on
    first use).

    Returns
    -------
    geomtex.viewer.Viewer
        The view; Jupyter shows it as widgets, front ends without widgets as a PNG.
    """
    from .viewer import show as _show

    return _show(obj, **options)


def load(path: str | os.PathLike[str]) -> GeometryTextureSet:
    """Reads a .gtex file (:meth:`GeometryTextureSet.save`, versions 1 to 8).

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    GeometryTextureSet
        The set as saved. Files hold no stage timings, so its ``stats["seconds"]`` is empty.

    Raises
    ------
    FileError
        There is no such file, or it cannot be read.
    FormatError
        The file is not an intact .gtex file (truncated, corrupt, or of an unknown version).
    """
    return GeometryTextureSet._wrap(_core.load(_check.path("path", path, exists=True)))


def load_surfels(path: str | os.PathLike[str]) -> Surfels:
    """Reads a .gtsurf file (:meth:`Surfels.save`): the set and tile size it holds, the hierarchy
    rebuilt from them.

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    Surfels
        The hierarchy.

    Raises
    ------
    FileError
        There is no such file, or it cannot be read.
    FormatError
        The file is not an intact .gtsurf file.
    """
    return Surfels._wrap(_core.load_surfels(_check.path("path", path, exists=True)))


#: Public submodules imported on first use (PEP 562): ``gt.batch.convert_many`` works after a
#: plain ``import geomtex as gt``, while ``import geomtex`` stays fast and never imports their
#: optional dependencies (Dask, Zarr, ipywidgets, embreex; each submodule imports those only
#: when called).
_LAZY_SUBMODULES = ("batch", "reference", "testing", "viewer")


def __getattr__(name: str) -> Any:
    if name in _LAZY_SUBMODULES:
        import importlib

        return importlib.import_module(f".{name}", __name__)  # also binds it here: asked once
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    """The public names only (``__all__``, the lazy submodules among them): ``dir(gt)`` and tab
    completion show what users may use, not the modules and helpers the package imports."""
    return sorted(__all__)
