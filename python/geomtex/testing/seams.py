"""Where patches meet: rays at a mesh's chart borders (a crack between patches lets them through)
and texel points compared across a filter that may cut texels off."""

from __future__ import annotations

import numpy as np

from .._mesh import Mesh
from .._set import GeometryTextureSet


def seam_rays(mesh: Mesh, gts: GeometryTextureSet, per_face: int = 16, lift: float = 10.0,
              seed: int = 3) -> tuple[np.ndarray, np.ndarray, float]:
    """Rays falling on the faces next to ``gts``'s chart borders (faces with an edge shared with
    another patch's face): ``per_face`` random points on each, a ray along the face's inward
    normal from ``lift`` texels above it. Returns origins, directions and the lift (world units).
    A ray whose first hit lies far beyond the lift passed through a crack (or a hole)."""
    v = np.asarray(mesh.vertices)
    f = np.asarray(mesh.faces, np.int64)
    owner = np.asarray(gts.face_patch())
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    face_of = np.tile(np.arange(len(f)), 3)
    key = edges[:, 0] * (f.max() + 1) + edges[:, 1]
    order = np.argsort(key, kind="stable")
    key, face_of = key[order], face_of[order]
    pair = key[1:] == key[:-1]
    a, b = face_of[:-1][pair], face_of[1:][pair]
    across = owner[a] != owner[b]
    border = np.unique(np.concatenate([a[across], b[across]]))
    r = np.random.default_rng(seed).random((len(border), per_face, 2))
    r = np.where(r.sum(-1, keepdims=True) > 1, 1 - r, r)
    tri = v[f[border]]
    points = (tri[:, None, 0] + r[..., :1] * (tri[:, None, 1] - tri[:, None, 0])
              + r[..., 1:] * (tri[:, None, 2] - tri[:, None, 0])).reshape(-1, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n = np.repeat(n / np.linalg.norm(n, axis=1, keepdims=True), per_face, axis=0)
    d = lift * gts.texel_size
    return points + n * d, -n, d


def surface_mask(gts: GeometryTextureSet) -> np.ndarray:
    """Which texels of all patches (patch by patch, row by row, as ``to_points``) hold surface."""
    masks = []
    for i in range(len(gts)):
        p = gts.patch(i)
        masks.append(((np.asarray(p["height"]) > 0) & (np.asarray(p["outline"]) >= 0)).ravel())
    return np.concatenate(masks)


def common_points(a: GeometryTextureSet, b: GeometryTextureSet) -> tuple[np.ndarray, np.ndarray, int]:
    """The texel points of ``a`` and of ``b`` (a filtered copy: the same patches and maps) at the
    texels holding surface in both, and how many of ``a``'s surface texels ``b`` lacks."""
    ma, mb = surface_mask(a), surface_mask(b)
    both = ma & mb
    pa, _ = a.to_points()
    pb, _ = b.to_points()
    return pa[both[ma]], pb[both[mb]], int((ma & ~mb).sum())
