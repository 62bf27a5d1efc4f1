"""Independent references for checking geomtex: distances computed by trimesh/scipy on the
original mesh, never by geomtex itself.

Units: everything is returned in the mesh's own units unless a name says ``_rel`` (divided by
the bounding-box diagonal).
"""

from __future__ import annotations

import importlib.util
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from . import _optional
from ._bridge import keyword_parameters, spelled_out
from ._render import RenderOptions

__all__ = [
    "RayCaster",
    "agreement",
    "albedo_difference",
    "base_colors",
    "compare",
    "corner_normals",
    "diagonal",
    "mesh_to_points",
    "normal_angles",
    "occlusion",
    "points_to_mesh",
    "raycast",
    "raycast_albedo",
    "shading_normals",
]

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
    """Length of the bounding-box diagonal of `mesh` (a Mesh or trimesh), by trimesh."""
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


#: Most (ray, candidate triangle) pairs one call to trimesh's numpy intersector (the one it uses
#: without embreex) may hold. Its memory goes as those pairs, about 440 bytes each (measured: a
#: 64² view of the 69k-face Stanford bunny, 6.4M pairs, 1,558 a ray, +2.8 GB peak RSS in one
#: call; 256² was killed at 24 GB). A ray pairs with each triangle at most once, so chunks of
#: ``_PAIR_BUDGET // faces`` rays hold at most this many whatever the view: about 0.9 GB.
_PAIR_BUDGET = 2_000_000
#: Rays per embree call: embree keeps nothing per candidate, so chunks only bound one call's
#: arrays (a few hundred bytes a ray).
_EMBREE_CHUNK = 1 << 20

Intersector = Literal["auto", "embree", "numpy"]


def _intersector(local: Any, kind: str) -> Any:
    """trimesh's intersector of ``local``: its own choice (embree where embreex is installed,
    else numpy), or the one named."""
    if kind == "auto":
        if importlib.util.find_spec("embreex") is None:
            _optional.need("rtree", "geomtex.reference (trimesh's numpy ray intersector, used without embreex)")
        return local.ray
    if kind == "numpy":
        from trimesh.ray.ray_triangle import RayMeshIntersector

        _optional.need("rtree", "geomtex.reference (trimesh's numpy ray intersector)")

        return RayMeshIntersector(local)
    if kind == "embree":
        _optional.need("embreex", "geomtex.reference (trimesh's Embree ray intersector)")
        from trimesh.ray.ray_pyembree import RayMeshIntersector as EmbreeIntersector

        return EmbreeIntersector(local)
    raise ValueError(f"intersector must be 'auto', 'embree' or 'numpy', got {kind!r}")


def _chunk_rays(intersector: Any, faces: int) -> int:
    """Rays per call that bound an intersector's memory (see _PAIR_BUDGET)."""
    if type(intersector).__module__.endswith("ray_pyembree"):
        return _EMBREE_CHUNK
    return max(1, _PAIR_BUDGET // max(faces, 1))


class RayCaster:
    """trimesh ray casting of one mesh with its intersector kept, as a trimesh user runs it
    (``mesh.ray`` caches embree's BVH after the first call): build it once, cast many times.

    Rays are cast on a copy centred on the mesh and scaled to a 1000-unit diagonal: embree
    intersects in float32 with absolute epsilons, so a model far from the origin would lose its
    detail and one of micrometre size (diagonal 2.5e-5, say) would be missed altogether. Hits are
    invariant under this similarity; positions are mapped back.

    ``intersector``: trimesh's own choice (``"auto"``: embree where embreex is installed, else
    its numpy intersector), or ``"embree"`` / ``"numpy"``. Rays are cast ``chunk_rays`` at a
    time (default: as many as keep the numpy intersector's (ray, candidate triangle) pairs
    under 2M, about 0.9 GB, for any view; 2^20 with embree): each ray's hit does not depend on
    the others, so the chunks change memory, not results.
    """

    def __init__(self, mesh: Any, *, intersector: Intersector = "auto", chunk_rays: int | None = None) -> None:
        self.mesh = _trimesh(mesh)
        self.centre = self.mesh.bounds.mean(axis=0)
        self.scale = _REFERENCE_DIAGONAL / max(diagonal(self.mesh), 1e-300)
        local = type(self.mesh)((self.mesh.vertices - self.centre) * self.scale, self.mesh.faces, process=False)
        self.intersector = _intersector(local, intersector)
        if chunk_rays is not None and (isinstance(chunk_rays, bool) or not isinstance(chunk_rays, int)
                                       or chunk_rays < 1):
            raise ValueError(f"chunk_rays must be a positive integer or None, got {chunk_rays!r}")
        self.chunk_rays = chunk_rays or _chunk_rays(self.intersector, len(self.mesh.faces))

    def first_hits(self, origins: npt.ArrayLike,
                   directions: npt.ArrayLike) -> tuple[npt.NDArray[Any], npt.NDArray[Any], npt.NDArray[Any]]:
        """(hit locations in world units, ray indices, triangle indices) of the rays that hit,
        cast ``chunk_rays`` at a time."""
        o = (np.asarray(origins, dtype=np.float64).reshape(-1, 3) - self.centre) * self.scale
        d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
        locations, rays, triangles = [np.zeros((0, 3))], [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
        for start in range(0, len(o), self.chunk_rays):
            stop = start + self.chunk_rays
            loc, ray, tri = self.intersector.intersects_location(o[start:stop], d[start:stop], multiple_hits=False)
            locations.append(np.asarray(loc, dtype=np.float64).reshape(-1, 3))
            rays.append(np.asarray(ray, dtype=np.int64) + start)
            triangles.append(np.asarray(tri, dtype=np.int64))
        return np.concatenate(locations) / self.scale + self.centre, np.concatenate(rays), np.concatenate(triangles)

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
        point = np.zeros((len(o), 3))
        triangle = np.full(len(o), -1, dtype=np.int64)
        # z-depth: the hit's distance from the ray's origin along the camera's forward axis (the
        # origin is the eye for perspective cameras and lies on the camera plane for orthographic).
        depth[ray_index] = (locations - o[ray_index]) @ np.asarray(camera.forward)
        normal[ray_index] = self.mesh.face_normals[tri_index]
        point[ray_index] = locations
        triangle[ray_index] = tri_index
        shape = (height, width)
        return {
            "depth": depth.reshape(shape).astype(np.float32),
            "normal": normal.reshape(shape + (3,)).astype(np.float32),
            "hit": np.isfinite(depth).reshape(shape),
            "triangle": triangle.reshape(shape),
            "point": point.reshape(shape + (3,)),
        }


def raycast(mesh: Any, camera: Any, width: int, height: int, *, intersector: Intersector = "auto",
            chunk_rays: int | None = None) -> dict[str, npt.NDArray[Any]]:
    """First hits of the camera's pixel rays on the mesh, by trimesh (embreex when installed;
    ``intersector`` and ``chunk_rays`` as for ``RayCaster``: without embreex the rays go in
    chunks that keep the numpy intersector's memory under about 1 GB at any image size).

    Same conventions as ``Renderer.render``: row 0 at the top, ``depth`` is z-depth along the
    camera's forward axis (+inf on a miss), ``normal`` the hit triangle's unit normal (0 on a
    miss), ``hit`` a boolean mask, ``triangle`` the hit face (-1 on a miss), ``point`` the world
    hit point (float64, 0 on a miss). Builds a new
    intersector each call; keep a ``RayCaster`` to cast many times.
    """
    return RayCaster(mesh, intersector=intersector, chunk_rays=chunk_rays).cast(camera, width, height)


def corner_normals(mesh: Any, normals: str = "crease", crease_angle: float = 20.0,
                   rule: str = "fan") -> npt.NDArray[np.float64]:
    """(F, 3, 3) unit normal at each corner of each face, computed by trimesh (and scipy) on a
    copy of the mesh with coincident vertices merged, faces in the mesh's order.

    ``normals``: ``"flat"`` face normals; ``"smooth"`` trimesh's vertex normals (faces weighted
    by their corner angle); ``"crease"``: split at edges whose faces' normals differ by
    ``crease_angle`` degrees or more (trimesh's ``face_adjacency_angles``), by one of two rules:
    ``rule="fan"`` (default): each corner averages (corner-angle weighted) the faces around its
    vertex reachable from its own face across smooth edges *around that vertex* (as Blender's
    auto-smooth splits); ``rule="components"``: trimesh's ``graph.smooth_shade`` (faces of one
    edge-connected smooth component share their vertices, so a crease that ends inside a
    smooth region is smoothed over along its whole length).
    """
    import trimesh

    tm = _trimesh(mesh).copy()
    tm.merge_vertices()
    if normals == "flat":
        return np.repeat(tm.face_normals[:, None, :], 3, axis=1)
    if normals == "smooth":
        return np.asarray(tm.vertex_normals[tm.faces], dtype=np.float64)
    if normals != "crease":
        raise ValueError(f"normals must be 'crease', 'smooth' or 'flat', got {normals!r}")
    if rule == "components":
        smooth = trimesh.graph.smooth_shade(tm, angle=np.radians(crease_angle), facet_minarea=None)
        out = np.zeros((len(tm.faces), 3, 3))
        out[np.hstack(smooth.metadata["original_components"])] = smooth.vertex_normals[smooth.faces]
        return out
    if rule != "fan":
        raise ValueError(f"rule must be 'fan' or 'components', got {rule!r}")
    return _fan_normals(tm, crease_angle)


def _fan_normals(tm: Any, crease_angle: float) -> npt.NDArray[np.float64]:
    """``corner_normals``' fan rule: corners (3 f + k) joined across smooth edges at their shared
    vertices, then each connected set of corners takes its angle-weighted mean normal."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    smooth = tm.face_adjacency_angles < np.radians(crease_angle)
    pairs, edges = tm.face_adjacency[smooth], tm.face_adjacency_edges[smooth]
    rows, cols = [], []
    for v in (edges[:, 0], edges[:, 1]):
        # The corner of each face of a pair that sits on edge vertex v.
        rows.append(3 * pairs[:, 0] + np.argmax(tm.faces[pairs[:, 0]] == v[:, None], axis=1))
        cols.append(3 * pairs[:, 1] + np.argmax(tm.faces[pairs[:, 1]] == v[:, None], axis=1))
    n = 3 * len(tm.faces)
    r, c = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(len(r)), (r, c)), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    weighted = (np.nan_to_num(tm.face_angles)[:, :, None] * tm.face_normals[:, None, :]).reshape(-1, 3)
    sums = np.zeros((label.max() + 1, 3))
    np.add.at(sums, label, weighted)
    length = np.linalg.norm(sums, axis=1, keepdims=True)
    return (sums / np.maximum(length, 1e-300))[label].reshape(-1, 3, 3)


def shading_normals(mesh: Any, corners: npt.NDArray[Any], ref: dict[str, npt.NDArray[Any]]) -> npt.NDArray[np.float64]:
    """(H, W, 3) unit normals of a ray cast (``raycast``'s dict, with ``point`` and ``triangle``)
    interpolated from ``corners`` (``corner_normals``) at each hit's barycentric coordinates; 0 on
    a miss."""
    import trimesh

    tm = _trimesh(mesh)
    hit = np.asarray(ref["hit"])
    tri = np.asarray(ref["triangle"])[hit]
    bary = trimesh.triangles.points_to_barycentric(tm.triangles[tri], np.asarray(ref["point"])[hit])
    n = np.einsum("ij,ijk->ik", bary, corners[tri])
    out = np.zeros(hit.shape + (3,))
    out[hit] = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    return out


def _neighbours(a: npt.NDArray[Any], fill: Any) -> list[npt.NDArray[Any]]:
    """The nine 3 x 3 shifts of ``a`` (pixels shifted in from outside take ``fill``)."""
    padded = np.pad(a, 1, constant_values=fill)
    h, w = a.shape
    return [padded[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)]


def _dilate(mask: npt.NDArray[np.bool_]) -> npt.NDArray[np.bool_]:
    """The mask grown by one pixel (3 x 3)."""
    return np.logical_or.reduce(_neighbours(mask, False))


def normal_angles(a: npt.ArrayLike, b: npt.ArrayLike, mask: npt.NDArray[np.bool_]) -> npt.NDArray[np.float64]:
    """Degrees between two (H, W, 3) normal images on the pixels of ``mask``, each normal
    renormalized first (frames store half floats)."""
    n0 = np.asarray(a)[mask].astype(np.float64)
    n1 = np.asarray(b)[mask].astype(np.float64)
    cos = np.sum(n0 * n1, axis=1) / np.maximum(np.linalg.norm(n0, axis=1) * np.linalg.norm(n1, axis=1), 1e-30)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _normal_p99_1px(frame: Any, ref_normal: npt.ArrayLike, both: npt.NDArray[np.bool_]) -> float:
    """p99 over ``both`` of the angle between each frame normal and the closest reference normal
    in its 3 x 3 neighbourhood (degrees)."""
    if not both.any():
        return float("nan")
    n0 = np.asarray(frame.normal, dtype=np.float64)
    n0 = n0 / np.maximum(np.linalg.norm(n0, axis=-1, keepdims=True), 1e-30)
    n1 = np.asarray(ref_normal, dtype=np.float64)
    n1 = n1 / np.maximum(np.linalg.norm(n1, axis=-1, keepdims=True), 1e-30)
    best = np.full(both.shape, -1.0)
    shifted = [np.stack(c, axis=-1) for c in zip(*(_neighbours(n1[..., k], 0.0) for k in range(3)))]
    for n in shifted:
        best = np.maximum(best, np.sum(n0 * n, axis=-1))
    return float(np.percentile(np.degrees(np.arccos(np.clip(best[both], -1.0, 1.0))), 99))


def compare(frame: Any, ref: dict[str, npt.NDArray[Any]], diagonal: float,
            ref_normal: npt.NDArray[Any] | None = None) -> dict[str, Any]:
    """How a rendered frame agrees with a reference ray cast (``raycast``'s dict).

    Depth differences are taken on pixels both hit and divided by ``diagonal``: ``depth_median``,
    ``depth_p99``, ``depth_max``. ``iou`` is the hit masks' intersection over union;
    ``normal_deg_median``/``_p99`` the angle between the frame's normals and ``ref_normal``
    (default: the reference's face normals); ``normal_deg_p99_1px`` its p99 with the same
    one-pixel tolerance as depth (each pixel's angle to the nearest of the reference's 3 x 3
    normals: a crease or silhouette that moved by less than a pixel costs nothing).
    ``nan_depth``/``nan_normal`` count NaN pixels.
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
    ang = normal_angles(frame.normal, ref["normal"] if ref_normal is None else ref_normal, both)
    out["normal_deg_median"] = float(np.median(ang)) if len(ang) else float("nan")
    out["normal_deg_p99"] = float(np.percentile(ang, 99)) if len(ang) else float("nan")
    out["normal_deg_p99_1px"] = _normal_p99_1px(frame, ref_normal if ref_normal is not None else ref["normal"], both)
    out["nan_normal"] = int(np.isnan(np.asarray(frame.normal)).any(axis=-1).sum())
    return out


@spelled_out(*keyword_parameters(RenderOptions))
def agreement(renderer: Any, gts: Any, mesh: Any, camera: Any, **render_options: Any) -> dict[str, float]:
    """Renders ``gts`` and compares it (``compare``) with trimesh's ray cast of ``mesh`` seen by
    the same camera at the renderer's size; ``nan`` counts NaN depths and normals together."""
    tm = _trimesh(mesh)  # built once for both the ray cast and the diagonal
    frame = renderer.render(gts, camera, **render_options)
    m = compare(frame, raycast(tm, camera, renderer.width, renderer.height), diagonal(tm))
    m["nan"] = m["nan_depth"] + m["nan_normal"]
    return m


def _bilinear(image: npt.NDArray[np.uint8], uv: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Bilinear samples (N, 4) of an (H, W, 4) image (row 0 at the top) at texture coordinates
    (N, 2) with (0, 0) at the bottom-left corner, repeating; pixel centres at +0.5."""
    h, w = image.shape[:2]
    x = uv[:, 0] * w - 0.5
    y = (1.0 - uv[:, 1]) * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    i0, j0 = x0.astype(np.int64), y0.astype(np.int64)
    img = image.astype(np.float64)

    def at(i: npt.NDArray[np.int64], j: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        return img[np.mod(j, h), np.mod(i, w)]

    top = at(i0, j0) * (1 - fx) + at(i0 + 1, j0) * fx
    bottom = at(i0, j0 + 1) * (1 - fx) + at(i0 + 1, j0 + 1) * fx
    return top * (1 - fy) + bottom * fy


def base_colors(mesh: Any, faces: npt.ArrayLike, points: npt.ArrayLike) -> npt.NDArray[np.uint8]:
    """(N, 4) uint8 base color of a geomtex Mesh at ``points`` on ``faces``: the texture sampled
    bilinearly at the point's texture coordinate (barycentric interpolation of the face's), else
    the face color, else the interpolated vertex colors, else geomtex's neutral gray — computed
    here with numpy and trimesh from the mesh's arrays, never by geomtex."""
    import trimesh

    f = np.asarray(faces, dtype=np.int64)
    tri = np.asarray(mesh.faces, dtype=np.int64)[f]
    corners = np.asarray(mesh.vertices)[tri]
    bary = trimesh.triangles.points_to_barycentric(corners, np.asarray(points, dtype=np.float64))
    uv, texture = mesh.uv, mesh.texture
    if uv is not None and texture is not None:
        corner_uv = uv[tri] if uv.ndim == 2 else uv[f]
        rgba = _bilinear(texture, np.einsum("nk,nkc->nc", bary, corner_uv))
    elif mesh.face_colors is not None:
        rgba = mesh.face_colors[f].astype(np.float64)
    elif mesh.vertex_colors is not None:
        rgba = np.einsum("nk,nkc->nc", bary, mesh.vertex_colors[tri].astype(np.float64))
    else:
        rgba = np.tile([200.0, 200.0, 200.0, 255.0], (len(f), 1))
    return np.clip(np.round(rgba), 0, 255).astype(np.uint8)


def raycast_albedo(mesh: Any, camera: Any, width: int, height: int) -> dict[str, npt.NDArray[Any]]:
    """trimesh ray casting of a geomtex Mesh: ``albedo`` (H, W, 4) uint8, the base color at each
    pixel's first hit (``base_colors``; 0 on a miss), ``hit`` (H, W) bool and ``triangle``."""
    caster = RayCaster(mesh)
    origins, directions = camera.rays(width, height)
    locations, ray_index, tri_index = caster.first_hits(origins.reshape(-1, 3), directions.reshape(-1, 3))
    albedo = np.zeros((width * height, 4), dtype=np.uint8)
    triangle = np.full(width * height, -1, dtype=np.int64)
    if len(ray_index):
        albedo[ray_index] = base_colors(mesh, tri_index, locations)
        triangle[ray_index] = tri_index
    return {"albedo": albedo.reshape(height, width, 4), "hit": (triangle >= 0).reshape(height, width),
            "triangle": triangle.reshape(height, width)}


def albedo_difference(frame_albedo: npt.ArrayLike, ref: dict[str, npt.NDArray[Any]], frame_hit: npt.ArrayLike,
                      erode: int = 2) -> dict[str, float]:
    """Mean and p99 absolute RGB difference (0-255 units) between a frame's albedo and
    ``raycast_albedo``'s, on interior pixels: both hit and every pixel within ``erode`` pixels
    hits in both (silhouettes, where a pixel's colour comes from another surface, left out)."""
    both = np.asarray(frame_hit) & ref["hit"]
    interior = both
    for _ in range(erode):
        interior = np.logical_and.reduce(_neighbours(interior, False))
    d = np.abs(np.asarray(frame_albedo)[..., :3].astype(np.float64) - ref["albedo"][..., :3])[interior]
    return {"mean": float(d.mean()) if d.size else float("nan"),
            "p99": float(np.percentile(d.max(axis=1), 99)) if d.size else float("nan"),
            "interior_px": int(interior.sum())}


def occlusion(mesh: Any, vertices: npt.ArrayLike, rays: int, seed: int = 0) -> npt.NDArray[np.float64]:
    """Per vertex (indices ``vertices``), the unoccluded fraction of ``rays`` cosine-weighted
    random directions around trimesh's vertex normal, cast with trimesh's intersector (embree
    where installed): an independent sampler and tracer for geomtex's ambient occlusion."""
    tm = _trimesh(mesh)
    vertices = np.asarray(vertices)
    rng = np.random.default_rng(seed)
    n = tm.vertex_normals[vertices]
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t = np.cross(n, helper)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(n, t)
    u1, u2 = rng.random((2, len(vertices), rays))
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    d = (r * np.cos(phi))[..., None] * t[:, None] + (r * np.sin(phi))[..., None] * b[:, None] \
        + np.sqrt(1 - u1)[..., None] * n[:, None]
    # Embree works in float32: the rays start a little off the surface so the vertex's own faces
    # never count.
    lift = 1e-5 * float(np.linalg.norm(tm.extents))
    o = np.repeat(tm.vertices[vertices] + n * lift, rays, axis=0)
    d = d.reshape(-1, 3)
    chunk = _chunk_rays(tm.ray, len(tm.faces))
    hit = np.concatenate([np.zeros(0, bool)] + [np.asarray(tm.ray.intersects_any(o[k:k + chunk], d[k:k + chunk]))
                                                for k in range(0, len(o), chunk)])
    return 1.0 - hit.reshape(len(vertices), rays).mean(axis=1)
