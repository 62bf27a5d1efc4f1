"""Ray queries on the GPU, shaped like trimesh's ``RayMeshIntersector`` so a trimesh user can swap
them in: ``intersects_first`` (everything about each ray's nearest hit), ``intersects_location``
and ``intersects_any``. They trace through a hierarchy over thin pieces of the patches' boxes and,
for the meshes and displacement shells in a scene, their own hierarchies (see the README's "Ray
queries"; surfels and IGT meshes are not traced).

``GeometryTextureSet`` and ``Scene`` inherit them from `RayQueries`.
"""

from __future__ import annotations

import threading
from typing import Any, Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from . import _check, _core

_lock = threading.Lock()
_renderers: dict[str, _core.Renderer] = {}

def _query_renderer(device: Literal["auto", "cpu", "gpu"] | None = None) -> _core.Renderer:
    """One renderer per device kept for queries (its device and uploaded sets are reused
    between calls)."""
    key = "default" if device is None else device
    with _lock:
        r = _renderers.get(key)
        if r is None:
            # None: GEOMTEX_DEVICE's default, else "auto", as every Renderer.
            r = _renderers[key] = _core.Renderer(1, 1, device)
        return r


class RayHits(NamedTuple):
    """What ``intersects_first`` returns: per ray the hit point, distance, patch id, normal and
    whether it hit (a NamedTuple: ``hits.distances`` or ``locations, distances, *_ = hits``)."""

    #: (N, 3) float64 world hit points, NaN on a miss.
    locations: npt.NDArray[np.float64]
    #: (N,) float64 distance along each ray's unit direction, +inf on a miss.
    distances: npt.NDArray[np.float64]
    #: (N,) int32 patch index, -1 on a miss, -2 - k for the scene's k-th mesh or displacement
    #: shell (counted together, in order), as in ``Frame.patch_id``.
    patch_ids: npt.NDArray[np.int32]
    #: (N, 3) float32 world unit normals at the hits, 0 on a miss.
    normals: npt.NDArray[np.float32]
    #: (N,) bool, whether each ray hit.
    hit: npt.NDArray[np.bool_]


def _rays(origins: npt.ArrayLike, directions: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) float64 origins and directions; one origin (3,) serves every ray. At most 2^26
    rays, counted before anything is copied. Finiteness and non-zero directions are checked by
    the extension as it reads the rays (one pass; it names the first bad row as
    "(origins row i)" or "(directions row i)")."""
    d = _check.array("directions", directions, shape="(N, 3)")
    o = _check.array("origins", origins, shape="(N, 3)")
    if o.shape == (3,) and d.ndim == 2:
        o = np.broadcast_to(o, d.shape)
    if d.ndim != 2 or d.shape[1] != 3 or o.shape != d.shape:
        raise _core.ParameterError(f"origins and directions must both be (N, 3); got {o.shape} and {d.shape}")
    if len(d) > _check.MAX_RAYS:
        raise _core.ParameterError(f"origins and directions hold {len(d)} rays, more than the limit of "
                                   f"{_check.MAX_RAYS}")
    return np.ascontiguousarray(o, dtype=np.float64), np.ascontiguousarray(d, dtype=np.float64)


def _named(origins: npt.ArrayLike | None, directions: npt.ArrayLike | None,
           ray_origins: npt.ArrayLike | None, ray_directions: npt.ArrayLike | None
           ) -> tuple[np.ndarray, np.ndarray]:
    """The rays of a query called with our names (``origins``, ``directions``) or trimesh's
    (``ray_origins``, ``ray_directions``), so code written for trimesh runs unchanged; one name
    per argument."""
    pairs = {"origins": (origins, ray_origins), "directions": (directions, ray_directions)}
    for name, (ours, theirs) in pairs.items():
        if ours is not None and theirs is not None:
            raise _core.ParameterError(f"{name} given twice: as {name} and as ray_{name} (trimesh's name); "
                                       "pass one")
        if ours is None and theirs is None:
            raise _core.ParameterError(f"missing argument {name!r} (or trimesh's ray_{name})")
    o = origins if origins is not None else ray_origins
    d = directions if directions is not None else ray_directions
    assert o is not None and d is not None  # checked above
    return _rays(o, d)


#: Directions of `contains`'s parity rays: unit, not along any axis or diagonal (an axis-aligned
#: model's faces and edges are the likeliest to be grazed).
_PARITY_DIRECTIONS = np.array([[0.5773, 0.5774, 0.5774], [-0.7071, 0.4082, 0.5774], [0.2357, -0.8660, 0.4410]])
_PARITY_DIRECTIONS /= np.linalg.norm(_PARITY_DIRECTIONS, axis=1, keepdims=True)


class RayQueries:
    """The ray queries of an object whose extension handle ``_core`` the renderer traces (a set,
    a scene). Texture sets, meshes and displacement shells are traced; a scene holding surfels or
    an IGT mesh is a ParameterError (query the set or the detailed mesh instead)."""

    _core: Any

    @_check.keywords
    def intersects_first(self, origins: npt.ArrayLike | None = None, directions: npt.ArrayLike | None = None,
                         *, quality: Literal["fast", "balanced", "exact"] | None = None,
                         method: Literal["linear_binary", "maxmip"] | None = None,
                         ray_origins: npt.ArrayLike | None = None, ray_directions: npt.ArrayLike | None = None,
                         device: Literal["auto", "cpu", "gpu"] | None = None) -> RayHits:
        """The nearest hit of every ray (``quality`` "exact" by default): origins (N, 3) or one
        (3,) for every ray, directions (N, 3), any length but zero. Every ray query also takes
        trimesh's names, ``ray_origins`` and ``ray_directions``, and ``device`` ("auto", "cpu"
        or "gpu", as `Renderer` takes it; the CPU backend always searches exactly)."""
        o, d = _named(origins, directions, ray_origins, ray_directions)
        return RayHits(*_query_renderer(device)._intersects_first(self._core, o, d, quality=quality, method=method))

    @_check.keywords
    def intersects_location(self, origins: npt.ArrayLike | None = None, directions: npt.ArrayLike | None = None,
                            multiple_hits: bool = False, *,
                            quality: Literal["fast", "balanced", "exact"] | None = None,
                            method: Literal["linear_binary", "maxmip"] | None = None,
                            ray_origins: npt.ArrayLike | None = None, ray_directions: npt.ArrayLike | None = None,
                            device: Literal["auto", "cpu", "gpu"] | None = None
                            ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.int32]]:
        """Like trimesh's: (hit locations (M, 3), index of the ray of each (M,), patch id of each
        (M,)) for the rays that hit; the nearest hit only, or with ``multiple_hits=True`` every
        crossing (`list_intersections`, on the CPU backend)."""
        if _check.flag("multiple_hits", multiple_hits):
            o, d = _named(origins, directions, ray_origins, ray_directions)
            index, distances, ids = self.list_intersections(o, d)
            unit = d / np.linalg.norm(d, axis=1, keepdims=True)
            return o[index] + unit[index] * distances[:, None], index, ids
        hits = self.intersects_first(origins, directions, quality=quality, method=method,
                                     ray_origins=ray_origins, ray_directions=ray_directions, device=device)
        index = np.flatnonzero(hits.hit)
        return hits.locations[index], index, hits.patch_ids[index]

    @_check.keywords
    def intersects_any(self, origins: npt.ArrayLike | None = None, directions: npt.ArrayLike | None = None, *,
                       quality: Literal["fast", "balanced", "exact"] | None = None,
                       method: Literal["linear_binary", "maxmip"] | None = None,
                       ray_origins: npt.ArrayLike | None = None, ray_directions: npt.ArrayLike | None = None,
                       device: Literal["auto", "cpu", "gpu"] | None = None) -> npt.NDArray[np.bool_]:
        """Whether each ray hits anything (each stops at the first hit found)."""
        o, d = _named(origins, directions, ray_origins, ray_directions)
        _, ids, _ = _query_renderer(device).intersect(self._core, o, d, any_hit=True, quality=quality,
                                                      method=method)
        return ids != -1  # type: ignore[no-any-return]

    @_check.keywords
    def list_intersections(self, origins: npt.ArrayLike | None = None, directions: npt.ArrayLike | None = None, *,
                           ray_origins: npt.ArrayLike | None = None, ray_directions: npt.ArrayLike | None = None
                           ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.int32]]:
        """Every crossing of every ray with the surfaces, on the CPU backend (exact searches,
        every core, whatever adapter there is): (ray index (M,) int64, distance along the ray's
        unit direction (M,) float64, id (M,) int32 as in ``patch_ids``), grouped by ray and
        nearest first. A mesh gives one crossing per face crossed (a ray through a shared edge
        or vertex may count each face there); a set one per crossing of each patch's surface,
        and patches overlap along their seams, so there a crossing may come from both."""
        o, d = _named(origins, directions, ray_origins, ray_directions)
        return _query_renderer("cpu").list_intersections(self._core, o, d)

    def _merge_distance(self) -> float:
        """How far apart two crossings of one ray may be and still be one surface's (a set's
        seams hold the surface twice, a texel apart at most); 0 for meshes alone."""
        return 0.0

    @_check.keywords
    def contains(self, points: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """Whether each point (N, 3) lies inside the closed surfaces, by ray parity on the CPU
        backend: crossings counted along three fixed directions (crossings of one ray closer
        than a texel merged, as a set's seams hold the surface twice; 1e-9 of the distance
        for meshes, whose rays through an edge meet both faces), a point inside when at least
        two of the three counts are odd. Meant for closed (watertight) surfaces, as trimesh's
        ``contains``; points within a texel of a set's surface may go either way."""
        pts = _check.array("points", points, shape="(N, 3)")
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise _core.ParameterError(f"points must be (N, 3); got {pts.shape}")
        pts = np.ascontiguousarray(pts, dtype=np.float64)
        if not np.isfinite(pts).all():
            i = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
            raise _core.ParameterError(f"point {i}: {pts[i].tolist()} must be finite (points row {i})")
        merge = self._merge_distance()
        odd = np.zeros(len(pts), dtype=np.int64)
        for direction in _PARITY_DIRECTIONS:
            index, distances, _ = self.list_intersections(pts, np.broadcast_to(direction, pts.shape))
            # Crossings are grouped by ray, nearest first: a crossing within `merge` of the one
            # before it on the same ray is the same surface again.
            again = (index[1:] == index[:-1]) & (np.diff(distances) <= np.maximum(merge, 1e-9 * distances[1:]))
            kept = index[np.concatenate(([True], ~again))] if len(index) else index
            odd += np.bincount(kept, minlength=len(pts)) % 2
        return odd >= 2  # type: ignore[no-any-return]

    @_check.keywords
    def count_intersections(self, origins: npt.ArrayLike | None = None, directions: npt.ArrayLike | None = None,
                            *, ray_origins: npt.ArrayLike | None = None,
                            ray_directions: npt.ArrayLike | None = None) -> npt.NDArray[np.int64]:
        """How many crossings each ray has (N,) int64: `list_intersections` counted per ray."""
        o, d = _named(origins, directions, ray_origins, ray_directions)
        index, _, _ = self.list_intersections(o, d)
        return np.bincount(index, minlength=len(o)).astype(np.int64)
