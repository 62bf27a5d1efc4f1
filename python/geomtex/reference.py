"""Independent references for checking geomtex: distances computed by trimesh/scipy on the
original mesh, never by geomtex itself.

Units: everything is returned in the mesh's own units unless a name says ``_rel`` (divided by
the bounding-box diagonal).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

# trimesh's triangle closest-point test compares products of squared edge lengths with an
# absolute tolerance (~1e-12), so millimetre triangles in metre units land in the wrong Voronoi
# region and come back up to a triangle-size away. Distances scale linearly, so we measure on a
# copy scaled to this diagonal and scale back.
_REFERENCE_DIAGONAL = 1000.0


def _trimesh(mesh: Any) -> Any:
    import trimesh

    if isinstance(mesh, trimesh.Trimesh):
        return mesh
    return trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), process=False)


def diagonal(mesh: Any) -> float:
    tm = _trimesh(mesh)
    return float(np.linalg.norm(tm.bounds[1] - tm.bounds[0]))


def points_to_mesh(points: npt.ArrayLike, mesh: Any) -> npt.NDArray[np.float64]:
    """Exact distance from each point to the mesh surface (trimesh closest_point)."""
    import trimesh

    tm = _trimesh(mesh)
    pts = np.asarray(points, dtype=np.float64)
    centre = tm.bounds.mean(axis=0)
    k = _REFERENCE_DIAGONAL / max(diagonal(tm), 1e-300)
    scaled = trimesh.Trimesh((tm.vertices - centre) * k, tm.faces, process=False)
    _, d, _ = trimesh.proximity.closest_point(scaled, (pts - centre) * k)
    return np.asarray(d, dtype=np.float64) / k


def mesh_to_points(mesh: Any, points: npt.ArrayLike, samples: int = 200_000, seed: int = 1) -> npt.NDArray[np.float64]:
    """Distance from area-uniform samples of the mesh surface to the nearest of ``points``
    (how well the points cover the surface)."""
    import trimesh
    from scipy.spatial import cKDTree

    tm = _trimesh(mesh)
    samp, _ = trimesh.sample.sample_surface(tm, samples, seed=seed)
    d, _ = cKDTree(np.asarray(points, dtype=np.float64)).query(samp)
    return np.asarray(d, dtype=np.float64)


class RayCaster:
    """trimesh ray casting of one mesh with its intersector kept, as a trimesh user runs it
    (``mesh.ray`` caches embree's BVH after the first call): build it once, cast many times.

    Rays are cast on a copy centred on the mesh and scaled to a 1000-unit diagonal: embree
    intersects in float32 with absolute epsilons, so a model far from the origin would lose its
    detail and one of micrometre size (diagonal 2.5e-5, say) would be missed altogether. Hits are
    invariant under this similarity; positions are mapped back.
    """

    def __init__(self, mesh: Any) -> None:
        self.mesh = _trimesh(mesh)
        self.centre = self.mesh.bounds.mean(axis=0)
        self.scale = _REFERENCE_DIAGONAL / max(diagonal(self.mesh), 1e-300)
        local = type(self.mesh)((self.mesh.vertices - self.centre) * self.scale, self.mesh.faces, process=False)
        self.intersector = local.ray

    def first_hits(self, origins: npt.ArrayLike,
                   directions: npt.ArrayLike) -> tuple[npt.NDArray[Any], npt.NDArray[Any], npt.NDArray[Any]]:
        """(hit locations in world units, ray indices, triangle indices) of the rays that hit."""
        o = np.asarray(origins, dtype=np.float64)
        locations, ray_index, tri_index = self.intersector.intersects_location(
            (o - self.centre) * self.scale, np.asarray(directions, dtype=np.float64), multiple_hits=False)
        return locations / self.scale + self.centre, ray_index, tri_index

    def first_distances(self, origins: npt.ArrayLike, directions: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """(N,) distance from each origin to its first hit along a unit direction; inf on a miss."""
        o = np.asarray(origins, dtype=np.float64)
        locations, ray_index, _ = self.first_hits(o, directions)
        t = np.full(len(o), np.inf)
        t[ray_index] = np.linalg.norm(locations - o[ray_index], axis=1)
        return t

    def cast(self, camera: Any, width: int, height: int) -> dict[str, npt.NDArray[Any]]:
        """First hits of the camera's pixel rays; see ``raycast`` for what comes back."""
        origins, directions = camera.rays(width, height)
        o = origins.reshape(-1, 3)
        locations, ray_index, tri_index = self.first_hits(o, directions.reshape(-1, 3))
        depth = np.full(len(o), np.inf)
        normal = np.zeros((len(o), 3))
        triangle = np.full(len(o), -1, dtype=np.int64)
        # z-depth: the hit's distance from the ray's origin along the camera's forward axis (the
        # origin is the eye for perspective cameras and lies on the camera plane for orthographic).
        depth[ray_index] = (locations - o[ray_index]) @ np.asarray(camera.forward)
        normal[ray_index] = self.mesh.face_normals[tri_index]
        triangle[ray_index] = tri_index
        shape = (height, width)
        return {
            "depth": depth.reshape(shape).astype(np.float32),
            "normal": normal.reshape(shape + (3,)).astype(np.float32),
            "hit": np.isfinite(depth).reshape(shape),
            "triangle": triangle.reshape(shape),
        }


def raycast(mesh: Any, camera: Any, width: int, height: int) -> dict[str, npt.NDArray[Any]]:
    """First hits of the camera's pixel rays on the mesh, by trimesh (embreex when installed).

    Same conventions as ``Renderer.render``: row 0 at the top, ``depth`` is z-depth along the
    camera's forward axis (+inf on a miss), ``normal`` the hit triangle's unit normal (0 on a
    miss), ``hit`` a boolean mask, ``triangle`` the hit face (-1 on a miss). Builds a new
    intersector each call; keep a ``RayCaster`` to cast many times.
    """
    return RayCaster(mesh).cast(camera, width, height)


def _neighbours(a: npt.NDArray[Any], fill: Any) -> list[npt.NDArray[Any]]:
    """The nine 3 x 3 shifts of ``a`` (pixels shifted in from outside take ``fill``)."""
    padded = np.pad(a, 1, constant_values=fill)
    h, w = a.shape
    return [padded[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)]


def _dilate(mask: npt.NDArray[np.bool_]) -> npt.NDArray[np.bool_]:
    """The mask grown by one pixel (3 x 3)."""
    return np.logical_or.reduce(_neighbours(mask, False))


def compare(frame: Any, ref: dict[str, npt.NDArray[Any]], diagonal: float,
            ref_normal: npt.NDArray[Any] | None = None) -> dict[str, Any]:
    """How a rendered frame agrees with a reference ray cast (``raycast``'s dict).

    Depth differences are taken on pixels both hit and divided by ``diagonal``: ``depth_median``,
    ``depth_p99``, ``depth_max``. ``iou`` is the hit masks' intersection over union;
    ``normal_deg_median``/``_p99`` the angle between the frame's normals and ``ref_normal``
    (default: the reference's face normals). ``nan_depth``/``nan_normal`` count NaN pixels.
    ``depth_p99_1px`` is the p99 with a one-pixel tolerance at depth discontinuities: each pixel's
    difference to the nearest of the reference's 3 x 3 neighbourhood (a silhouette that moved by
    less than a pixel costs nothing; a camera next to a surface sees its silhouette as a whole
    line of pixels). ``mask_far_px`` counts hit/miss disagreements more than a pixel from any
    pixel where the other image hits (a silhouette moved by a pixel does not count).
    ``crack_px`` counts pixels the reference hits and the frame misses inside the reference's
    silhouette eroded by one pixel: holes, not a silhouette drawn a pixel thinner.
    """
    depth = np.asarray(frame.depth)
    hit = np.isfinite(depth)
    ref_hit = np.asarray(ref["hit"])
    both = hit & ref_hit
    union = hit | ref_hit
    out: dict[str, Any] = {
        "covered_px": int(hit.sum()),
        "ref_px": int(ref_hit.sum()),
        "both_px": int(both.sum()),
        "only_frame_px": int((hit & ~ref_hit).sum()),
        "only_ref_px": int((ref_hit & ~hit).sum()),
        "iou": float(both.sum() / union.sum()) if union.any() else float("nan"),
        "nan_depth": int(np.isnan(depth).sum()),
        "mask_far_px": int((hit & ~_dilate(ref_hit)).sum() + (ref_hit & ~_dilate(hit)).sum()),
        "crack_px": int((ref_hit & ~_dilate(~ref_hit) & ~hit).sum()),
    }
    if both.any():
        dz = np.abs(depth[both].astype(np.float64) - np.asarray(ref["depth"])[both]) / diagonal
        near = np.full(depth.shape, np.inf)
        with np.errstate(invalid="ignore"):  # inf - inf where both miss: those pixels are not used
            for shifted in _neighbours(np.asarray(ref["depth"], dtype=np.float64), np.inf):
                near = np.fmin(near, np.abs(depth - shifted))
        dz1 = near[both] / diagonal
        out.update(depth_median=float(np.median(dz)), depth_p99=float(np.percentile(dz, 99)),
                   depth_max=float(dz.max()), depth_p99_1px=float(np.percentile(dz1, 99)))
    else:
        out.update(depth_median=float("nan"), depth_p99=float("nan"), depth_max=float("nan"),
                   depth_p99_1px=float("nan"))
    n0 = np.asarray(frame.normal)[both].astype(np.float64)
    n1 = np.asarray(ref["normal"] if ref_normal is None else ref_normal)[both].astype(np.float64)
    cos = np.sum(n0 * n1, axis=1) / np.maximum(np.linalg.norm(n0, axis=1) * np.linalg.norm(n1, axis=1), 1e-30)
    ang = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    out["normal_deg_median"] = float(np.median(ang)) if len(ang) else float("nan")
    out["normal_deg_p99"] = float(np.percentile(ang, 99)) if len(ang) else float("nan")
    out["nan_normal"] = int(np.isnan(np.asarray(frame.normal)).any(axis=-1).sum())
    return out


def agreement(renderer: Any, gts: Any, mesh: Any, camera: Any, **render_options: Any) -> dict[str, float]:
    """Renders ``gts`` and compares it (``compare``) with trimesh's ray cast of ``mesh`` seen by
    the same camera at the renderer's size; ``nan`` counts NaN depths and normals together."""
    tm = _trimesh(mesh)  # built once for both the ray cast and the diagonal
    frame = renderer.render(gts, camera, **render_options)
    m = compare(frame, raycast(tm, camera, renderer.width, renderer.height), diagonal(tm))
    m["nan"] = m["nan_depth"] + m["nan_normal"]
    return m
