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

from . import _check, _core, data, gdm, igt  # noqa: E402
from ._camera import Camera  # noqa: E402
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
    "convert",
    "data",
    "gdm",
    "igt",
    "info",
    "load",
    "load_mesh",
    "load_surfels",
    "show",
]

ProgressCallback = Callable[[str, float], "bool | None"]

# Share of a typical conversion's time per stage (measured on the bunny), for the progress bar.
_STAGE_SPAN = {
    "geometry": (0, 2), "partition": (2, 75), "repair": (75, 77), "overlap": (77, 79),
    "frame": (79, 80), "resolution": (80, 90), "raster": (90, 96), "dilate": (96, 99), "done": (100, 100),
}


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
    progress: bool | ProgressCallback | None = None,
) -> GeometryTextureSet:
    """Converts a mesh into geometry textures.

    mesh: a :class:`Mesh`, ``trimesh.Trimesh`` or a mesh file path.

    With none of ``max_resolution``, ``texel_size``, ``max_error``, ``max_error_rel`` and
    ``max_bytes`` the conversion is error-driven with the cone partition: ``max_error_rel=2e-4``
    for a mesh that shows no more outline for its area than the Stanford bunny, tighter by
    10.5 / ``stats["outline_ratio"]`` for one that shows more (outline length over projected
    area times the diagonal, on its three axis projections; thin parts lose more IoU for the
    same error, homer: 15.9, 1.32e-4), at most 4x tighter; within ``max_bytes`` = the mesh's
    float32/uint32 bytes, or for a mesh under 50,000 faces an allowance of 4 MB x (1 - faces /
    50,000) x 2e-4 / bound if that is more. A rough mesh that cannot meet the bound within them
    gets the least error the budget buys (``stats["max_bytes_binding"]`` is 1, and a
    :class:`CapWarning` says by how much it missed and how to meet it). Any of those keywords
    converts as before.

    max_resolution: longest side of any patch in texels (default 256; 1024 with ``max_error``,
        where it only caps a chart's memory). Without ``max_error`` one texel size serves every
        patch, chosen so the largest chart just fits.
    texel_size: world size of a texel (grown if a chart would exceed ``max_resolution``).
    max_error: error-driven resolution, in world units. Each chart gets its own texel size,
        from long-side resolutions ``max_resolution`` down to 2 in steps of 2^(1/4), chosen for
        the fewest bytes that keep the reconstruction error within ``max_error`` (see
        ``error_scope``); ``max_resolution`` stays the cap. Error is the 99th percentile, by
        area, of the distances from points on a chart's triangles to its height field and from
        its rim texels to the triangles they copy, measured on the maps as stored.
        ``stats["patch_resolution"]``, ``["patch_texel"]`` and ``["patch_error"]`` give each
        chart's choice; ``stats["texel_size"]`` is then the finest chart's texel. Without it
        one texel size serves every chart.
    max_error_rel: ``max_error`` as a fraction of the bounding-box diagonal.
    error_scope: ``"set"`` (default) bounds the set's error, ``stats["reconstruction_error_p99"]``,
        with the fewest bytes: charts whose tail (a crease, a steep rim) would be dear to remove
        keep it while cheaper charts get finer. ``"chart"`` bounds every chart's own error,
        which costs more where charts differ.
    partition: how the mesh is cut into charts (default ``"cone"`` when error-driven without
        ``charts`` or ``chart_error``, else ``"vsa"``). ``"vsa"``: the paper's Variational Shape
        Approximation, driven by ``chart_error`` or ``charts`` (the keywords below). ``"cone"``:
        each chart grows from a seed while its face normals stay within ``cone_angle`` degrees
        (default 60) of one axis, so no face comes near folding, and within ``chart_size``
        (default 0.1) of the bounding-box diagonal from its seed; VSA's L2,1 error only orders
        the faces a chart takes, a chart turns away faces that would lie over or under its
        surface (a second sheet), and small charts merge into a neighbour while the cone and
        size still fit. No cap, no folding repair, linear time (see bench/partition.py).
        ``stats["charts_capped"]`` is 1 when ``max_charts`` stopped VSA before its target
        (a warning is also issued).
    cone_angle: half-angle of a cone chart's normal cone, degrees, in (0, 85].
    chart_size: largest distance from a cone chart's seed to its faces, as a fraction of the
        bounding-box diagonal; without ``max_error`` the largest chart sets every patch's
        texel, so smaller charts mean finer texels and more bytes.
    charts: exact VSA chart count; by default charts are added until the area-weighted mean
        L2,1 error ``sum(area |n - N|^2) / sum(area)`` is at most ``chart_error`` (0.1 by
        default; with ``max_error``, ``partition="vsa"`` and neither ``charts`` nor
        ``chart_error`` given, 0.1, 0.2 and 0.3 are tried and the set within the bound with
        the fewest bytes is kept, since a chart with its own texel no longer sets everyone's
        and fewer, larger charts draw fewer ring faces twice; ``stats["chart_error"]`` says which).
    max_charts: most VSA charts (default 4096). compactness: weight of the distance term that
        keeps charts round (default 1.0). lloyd_iterations: VSA refinement rounds (default 6).
    overlap_rings: rings of neighbouring faces each patch also draws (default 1: seamless
        borders).
    dilation: texels of normal/color dilation into empty space (default 2).
    frame: in-plane axes from the minimum-area rectangle (default) or 2D PCA (the paper's).
    normals: ``"crease"`` (default): smooth within a surface, split at edges where the faces'
        normals differ by ``crease_angle`` degrees or more (default 20, trimesh's
        ``smooth_shade``; in (0, 180]); ``"smooth"``: vertex normals averaged over every edge;
        ``"flat"``: face normals. Vertex normals are weighted by corner angle, as trimesh's.
    height_bits: 16 (default) or 8. Eight bits halve the height maps' bytes (a texel then takes
        4 bytes instead of 5, 8 instead of 9 with colors) and round each height to 1/254 of its
        patch's height range; ``stats["max_quantization_error"]`` gives the worst rounding in
        world units.
    max_bytes: most bytes the maps may take (``stats["bytes"]``): the conversion is repeated
        with a coarser texel (scaled by the square root of the excess) until they fit, at most
        6 times (``stats["max_bytes_coarsenings"]``). With ``max_error`` each chart's level is
        chosen within the budget instead: the bound where it fits, else the least area over it
        (``stats["max_bytes_binding"]`` is 1 and a :class:`CapWarning` says by how much the
        bound was missed; not with ``error_scope="chart"``). If they still do
        not fit, ``stats["max_bytes_exceeded"]`` is 1 and a :class:`CapWarning` says so, as it
        does when VSA stops at ``max_charts`` above its error target (``stats["charts_capped"]``).
    progress: True for a tqdm bar, or ``callback(stage, fraction)``; returning False cancels.

    The work runs in Rust on all cores with the GIL released.
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
        from tqdm.auto import tqdm

        bar = tqdm(total=100, desc="geomtex", unit="%", leave=False)

        def callback(stage: str, fraction: float) -> None:
            start, end = _STAGE_SPAN.get(stage, (bar.n, bar.n))
            bar.set_description(f"geomtex {stage}")
            bar.n = round(start + (end - start) * fraction)
            bar.refresh()
    elif callable(progress):
        callback = progress
    elif progress in (None, False):
        callback = None
    else:
        raise ParameterError(f"progress must be True, False, None or a callable, got {progress!r}")
    try:
        gts = GeometryTextureSet._wrap(_core.convert(
            m._core, **integers, **reals, error_scope=error_scope, partition=partition, frame=frame,
            normals=normals, progress=callback))
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
            remedy = f"gt.convert(mesh, max_error_rel={rel:.6g}) meets it without a byte budget"
        else:
            budget = "max_bytes"
            remedy = "a larger max_bytes, or max_bytes=None (no byte budget), meets it"
        warnings.warn(f"the conversion missed its error bound: reconstruction_error_p99 {p99:.3g} is "
                      f"{p99 / bound:.2f}x max_error {bound:.3g} ({rel:.3g} of the diagonal), as the maps had "
                      f"to fit {budget}, {stats['max_bytes']:.0f} bytes; {remedy} (how many bytes that takes "
                      "is not known without converting); stats['max_bytes_binding'] is 1", CapWarning,
                      stacklevel=3)


def show(obj: Any, **options: Any) -> Any:
    """An interactive viewer in Jupyter (drag to orbit, scroll to zoom, quality / LOD / shading
    selectors, the original mesh beside or over it with ``mesh=``); see `geomtex.viewer.show`."""
    from .viewer import show as _show

    return _show(obj, **options)


def load(path: str | os.PathLike[str]) -> GeometryTextureSet:
    """Reads a .gtex file. Raises FormatError for anything that is not an intact .gtex file
    (versions 1 to 5). Files hold no stage timings, so a loaded set's ``stats["seconds"]`` is
    empty."""
    return GeometryTextureSet._wrap(_core.load(_check.path("path", path, exists=True)))


def load_surfels(path: str | os.PathLike[str]) -> Surfels:
    """Reads a .gtsurf file (``Surfels.save``): the set and tile size it holds, the hierarchy
    rebuilt from them. Raises FormatError for anything that is not an intact one."""
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
    return sorted({*globals(), *_LAZY_SUBMODULES})
