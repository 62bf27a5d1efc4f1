"""The renderer's Python face: `Renderer` (frames and ray queries of anything a Scene takes, trimesh
objects and mesh files read as meshes first), the lights, and the render keywords' checks."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal, Mapping, Sequence, TypedDict, Unpack

import numpy as np
import numpy.typing as npt

from . import _check, _core
from ._bridge import Flag, Int, Real, Wrapped, forward, keyword_parameters, spelled_out, unwrap
from ._camera import Camera
from ._errors import ParameterError
from ._frame import Frame
from ._kinds import renderable


@dataclass(frozen=True)
class DirectionalLight:
    """Parallel light travelling along ``direction`` (world space, three finite numbers, any
    length but zero): pass it as ``render(..., light=...)`` for shadows."""

    #: (3,) float64 world direction the light travels along, as given (not normalised).
    direction: npt.ArrayLike

    def __post_init__(self) -> None:
        object.__setattr__(self, "direction", _check.direction("direction", self.direction))


@dataclass(frozen=True)
class PointLight:
    """Light from ``position`` (world space, three finite numbers): pass it as
    ``render(..., light=...)`` for shadows."""

    #: (3,) float64 world position of the light.
    position: npt.ArrayLike

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _check.vector("position", self.position))


def check_light(light: Any) -> None:
    """`render`'s ``light``: None, or a DirectionalLight or PointLight (or any object with a
    ``direction`` or a ``position``) whose vector is finite, a direction non-zero. Checked again
    here: a light's array can be changed in place after it was made."""
    if light is None:
        return
    if hasattr(light, "direction"):
        _check.direction("light.direction", light.direction)
    elif hasattr(light, "position"):
        _check.vector("light.position", light.position)
    else:
        raise _check.fail("light", "a geomtex.DirectionalLight or PointLight", light)


#: Renderer.render's keywords by the kind of value each takes (the extension checks ranges).
_RENDER_KEYWORDS = {
    "quality": "text", "method": "text", "primary": "text", "count_fetches": "flag", "lod": "flag",
    "steps_per_texel": "real", "max_pixel_error": "real", "min_linear_steps": "int", "max_linear_steps": "int",
    "binary_steps": "int", "max_traversal_steps": "int", "background": "rgba", "light": "light",
    "outputs": "names",
}


def check_render_options(options: Mapping[str, Any]) -> None:
    """`Renderer.render`'s keywords: known names, each of the right kind of value (None is every
    keyword's default); the light checked in full. For callers that cannot wait for the
    extension's own checks (a batch job checks them before any worker starts)."""
    for name, value in options.items():
        kind = _RENDER_KEYWORDS.get(name)
        if kind is None:
            raise ParameterError(f"unknown render keyword {name!r}; Renderer.render takes "
                                 + ", ".join(sorted(_RENDER_KEYWORDS)))
        if value is None:
            continue
        if kind == "text" and not isinstance(value, str):
            raise _check.fail(name, "a str", value)
        if kind == "names" and not (isinstance(value, str)
                                    or (isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value))):
            raise _check.fail(name, "a str or a sequence of str", value)
        if kind == "flag":
            _check.flag(name, value)
        elif kind in ("real", "int"):
            _check.number(name, value, float if kind == "real" else int)
        elif kind == "rgba":
            _check.rgba(name, value)
        elif kind == "light":
            check_light(value)


class RenderOptions(TypedDict, total=False):
    """`Renderer.render`'s keywords (every one None by default: the extension's own default).
    ``light``: a DirectionalLight, a PointLight, or any object with a ``direction`` or a
    ``position``."""

    quality: Literal["fast", "balanced", "exact"] | None
    method: Literal["linear_binary", "maxmip"] | None
    steps_per_texel: Real | None
    min_linear_steps: Int | None
    max_linear_steps: Int | None
    binary_steps: Int | None
    max_traversal_steps: Int | None
    count_fetches: Flag | None
    lod: Flag | None
    background: npt.ArrayLike | None
    light: Any
    max_pixel_error: Real | None
    primary: Literal["tiles", "boxes"] | None
    outputs: str | Sequence[str] | None


RayHitArrays = tuple[npt.NDArray[np.float64], npt.NDArray[np.int32], npt.NDArray[np.float32]]


class Renderer(Wrapped, core=_core.Renderer):
    """A headless renderer of an image size (`resize` changes it).

    Every Renderer of a process shares one GPU device, its pipelines and the objects uploaded to
    it (and one CPU backend, its hierarchies kept per object): making a second Renderer, drawing
    at a second size or tracing rays costs no new device and no new upload. See `render` for the
    keywords.

    Parameters
    ----------
    width, height : int
        The image size in pixels.
    device : {"auto", "cpu", "gpu"}, optional
        Where frames and ray queries run. ``"gpu"``: wgpu on a Vulkan, Metal or DX12 adapter
        (lavapipe counts). ``"cpu"``: the native CPU tracer, on every core, with no graphics
        driver at all; it draws and traces texture sets and meshes (always with the exact
        search; ``lod`` and ``count_fetches`` are refused) and raises DeviceError for other
        kinds. ``"auto"`` (default): on a GPU, the GPU backend; on a CPU adapter (lavapipe,
        llvmpipe), the CPU backend for sets and meshes, where it is faster, and the adapter for
        the other kinds and the GPU tracer's own options (``quality`` "fast" or "balanced",
        ``lod``, ``count_fetches``, ``primary``); with no usable adapter, the CPU backend alone.
        `device` says which was chosen, ``frame.stats["device"]`` which drew a frame; an adapter
        named in ``GEOMTEX_ADAPTER`` is required, with no fallback. Not given: the environment
        variable ``GEOMTEX_DEVICE``'s value, else ``"auto"`` (ray queries' default too).

    Raises
    ------
    ParameterError
        A size that is not an integer in [1, 16384], or an unknown device.
    DeviceError
        ``device="gpu"`` and no usable GPU adapter (``gt.info()`` says why).
    """

    _core: _core.Renderer

    def __init__(self, width: Int, height: Int, device: Literal["auto", "cpu", "gpu"] | None = None) -> None:
        self._core = _core.Renderer(width, height, device)
        self._requested = "auto" if device is None else device

    def __reduce__(self) -> tuple[Any, ...]:
        from ._pickle import restore_renderer

        # The device asked for, not the one chosen here: a worker chooses for its own machine.
        return restore_renderer, (self.width, self.height, getattr(self, "_requested", "auto"))

    device = forward[str]("Where frames and queries run: \"gpu\", \"cpu\", or \"cpu+gpu\" (``auto`` on a CPU "
                          "adapter: sets and meshes on the CPU backend, the rest on the adapter).")
    width = forward[int]("Image width in pixels.")
    height = forward[int]("Image height in pixels.")
    adapter_info = forward[dict[str, str]]("The adapter in use: name, backend, device_type, driver, driver_info "
                                           "(the CPU tracer's own on the CPU backend).")

    def resize(self, width: Int, height: Int) -> None:
        """Makes later frames `width` x `height`; the device, pipelines and uploads are kept (every
        Renderer shares them), and so are the targets of sizes drawn lately.

        Raises
        ------
        ParameterError
            A size that is not an integer in [1, 16384].
        """
        self._core.resize(width, height)

    @spelled_out(*keyword_parameters(RenderOptions))
    def render(self, obj: Any, camera: Camera, **options: Unpack[RenderOptions]) -> Frame:
        """Renders a Scene or any one object a Scene takes, seen by `camera`.

        Every keyword is None by default, which means the extension's own default.

        Parameters
        ----------
        obj : Scene, GeometryTextureSet, Mesh, Surfels, igt.IgtMesh, gdm.Shell, trimesh or path
            What to draw; a trimesh object or a mesh path is read as a :class:`Mesh`.
        camera : Camera
            Where it is seen from.
        quality : {"fast", "balanced", "exact"}, optional
            Measured settings of the height-field search (default ``"exact"``).
        method : {"linear_binary", "maxmip"}, optional
            The search: linear steps then a binary refinement, or a max-pyramid descent.
            Overrides `quality`'s, as do the step keywords.
        steps_per_texel : float, optional
            Linear search steps per texel crossed, overriding `quality`'s.
        min_linear_steps, max_linear_steps, binary_steps, max_traversal_steps : int, optional
            The search's step counts, overriding `quality`'s.
        count_fetches : bool, optional
            Use a counting build of the pipeline and report height fetches in ``frame.stats``
            (fetches, fetches_per_pixel, fetches_per_search, piece_tests_per_pixel).
        lod : bool, optional
            Max-pyramid search only: stop each patch's descent where its nodes are about a
            pixel, or, with `max_pixel_error`, at each patch's coarsest pyramid level whose
            error bound (the nodes' height range plus the cells' bounds) projects to at most
            that many pixels at the patch's nearest point (``stats['lod_rule']``,
            ``stats['lod_levels']``).
        background : array-like of 4 numbers, optional
            RGBA where nothing is hit (uint8 values, or floats in [0, 1]).
        light : DirectionalLight or PointLight, optional
            Casts shadows: ``frame.shadow``, and shadowed pixels at half brightness.
        max_pixel_error : float, optional
            With ``lod``, the level-of-detail rule by bound above. Surfels (default 1): a cut
            of each patch's tiles and the nodes above them is drawn, each part at its coarsest
            level whose perpendicular error projects to at most this many pixels of depth (1/16
            of it where a silhouette may show).
        primary : {"tiles", "boxes"}, optional
            How camera rays meet the texture sets' boxes: per pixel nearest first, stopping
            behind the nearest hit (``"tiles"``, default), or every box over a pixel searched.
        outputs : str or sequence of str, optional
            The arrays read back or computed, among ``"color"``, ``"albedo"``, ``"depth"``,
            ``"normal"``, ``"patch_id"``, ``"error_bound"`` and ``"coverage_uncertain"``
            (default all but ``"coverage_uncertain"``, which casts probe rays): a depth-only
            frame skips the others' copies and conversions. ``"error_bound"`` and
            ``"coverage_uncertain"`` are computed from the depth and patch ids, read for them
            (and not returned unless named). The frame's other arrays raise ParameterError when
            read, and without ``"patch_id"`` its per-pixel figures are None.

        Returns
        -------
        Frame
            The image's arrays and ``stats``.

        Raises
        ------
        ParameterError
            An unknown keyword (named in the message), a value of the wrong type or out of
            range, or an object the renderer does not draw.
        DeviceError
            No usable GPU adapter, or the GPU refused a resource.
        """
        check_render_options(options)
        return Frame._wrap(self._core.render(renderable(obj), unwrap(camera), **options))

    def intersect(self, obj: Any, origins: npt.ArrayLike, directions: npt.ArrayLike, *,
                  any_hit: bool | None = None, quality: Literal["fast", "balanced", "exact"] | None = None,
                  method: Literal["linear_binary", "maxmip"] | None = None) -> RayHitArrays:
        """Ray queries on the GPU against a Scene or any one object a Scene takes.

        Texture sets, meshes and displacement shells are traced; surfels and IGT meshes are a
        ParameterError (query the set or the detailed mesh instead).
        ``Scene.intersects_first`` and ``GeometryTextureSet.intersects_first`` (and
        ``intersects_location``, ``intersects_any``) are the trimesh-shaped form.

        Parameters
        ----------
        obj : Scene, GeometryTextureSet, Mesh, gdm.Shell, trimesh or path
            What to trace; a trimesh object or a mesh path is read as a :class:`Mesh`.
        origins : (N, 3) array-like
            Ray origins, world space.
        directions : (N, 3) array-like
            Ray directions, any length but zero.
        any_hit : bool, optional
            Stop each ray at the first hit found (shadow-style visibility, not the nearest).
        quality : {"fast", "balanced", "exact"}, optional
            As for `render`; ``"exact"`` by default here.
        method : {"linear_binary", "maxmip"}, optional
            As for `render`.

        Returns
        -------
        distances : (N,) float64 ndarray
            Distance to the nearest hit along each ray's unit direction, +inf on a miss.
        patch_ids : (N,) int32 ndarray
            The patch hit, -1 on a miss, -2 - k for the scene's k-th mesh or shell, as in
            ``Frame.patch_id``.
        normals : (N, 3) float32 ndarray
            World unit normals at the hits, 0 on a miss.

        Raises
        ------
        ParameterError
            Rays of the wrong shape or not finite, a zero direction, or an object that is not
            traced.
        """
        return self._core.intersect(renderable(obj), origins, directions, any_hit=any_hit, quality=quality,
                                    method=method)


#: This process's renderers, one per image size, kept for its life. Every Renderer shares the
#: process's one device and its uploads, so these cost no device each: one per size keeps threads
#: drawing at different sizes from resizing one another's renderer.
_SHARED: dict[tuple[int, int], Renderer] = {}


def shared_renderer(width: int, height: int) -> Renderer:
    """The renderer of that size for this process, made on first use and kept."""
    r = _SHARED.get((width, height))
    if r is None:
        r = _SHARED[(width, height)] = Renderer(width, height)
    return r
