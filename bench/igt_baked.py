"""The baseline an inverse geometric texture must beat (issue 17): the same simplified mesh with
its detailed mesh's normals and colors baked into textures at equal bytes, as users do today.

The baseline is built the usual way:

* UVs: xatlas (``xatlas.parametrize``) charts and packs the simplified mesh;
* an atlas of side ``sqrt(bytes / 4)`` texels, ``bytes`` being the IGT's whole size (its
  ``stats["bytes"]``: hash, lists, triangles and attributes), so each texel is one RGBA8 value;
* baking by ray casting (trimesh + embree): each texel centre covered by a simplified triangle
  is placed on that triangle, moved out along its interpolated normal by the largest distance
  between the two surfaces (pymeshlab's Hausdorff distance, one-sided from the simplified
  mesh), and cast back inward; the first detailed hit gives the normal (the crease rule of
  ``reference.corner_normals``, interpolated) or the base color (``reference.base_colors``);
* gutters: empty texels take the mean of their filled neighbours, eight texels deep, so bilinear
  lookups at chart borders do not blend in empty texels.

The baked color texture is drawn by geomtex's own mesh raster (which samples textures per
pixel). Object-space normal maps are not drawn by the raster, so the baked normals are looked up
where trimesh's ray cast of the simplified mesh hits it (bilinearly, at the hit's texture
coordinate): the same surface the raster draws.

Measured at 512² against trimesh ray casting of the detailed mesh, on pixels both hit and not
within one pixel of either silhouette (as ``bench/igt.py``):

* bunny at 10%, 2% and 0.5% of its faces, five views: median normal angle of the IGT frame, the
  baked baseline and the plain simplified mesh; and at seams, the pixels whose simplified-mesh
  hit lies within 1.5 atlas texels of an xatlas chart border: the baseline's median there
  against its median elsewhere (a seam artifact shows as a higher error at seams);
* spot with its texture at 5%, two views: mean |Δcolor| on interior pixels of the IGT frame and
  of the baked color texture.

Results: ``bench/results/igt_baked.json``. Run from the repository root::

    nice python bench/igt_baked.py
"""

from __future__ import annotations

import datetime
import json
import os
import platform
from pathlib import Path
from typing import Any

import numpy as np
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

import geomtex as gt
from geomtex import reference
from igt import BUNNY, FRACTIONS, SIZE, VIEWS, camera, interior, load_spot  # type: ignore[import-not-found]

OUT = Path(__file__).resolve().parents[1] / "bench" / "results"
GUTTER = 8
SPOT_FRACTION = 0.05
SPOT_VIEWS = ((1.0, 0.3, 0.2), (0.2, 0.3, 1.0))


def atlas(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """xatlas UVs of a mesh as (F, 3, 2) per corner, and per face the corners' vertex indices
    in xatlas's split mesh (a seam edge is one whose two faces give its ends different UVs)."""
    import xatlas

    vmapping, indices, uvs = xatlas.parametrize(np.asarray(vertices, np.float32), np.asarray(faces, np.uint32))
    # Baked and sampled with one convention (v up, rows down), whatever xatlas's orientation.
    corner_uv = uvs[indices].astype(np.float64)
    assert np.array_equal(vmapping[indices], np.asarray(faces)), "xatlas reordered the faces"
    return corner_uv, indices


def texel_samples(corner_uv: np.ndarray, side: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every texel centre covered by a triangle in UV space: texel (row, col) indices, the face,
    and barycentric coordinates."""
    rows, cols, faces, bary = [], [], [], []
    px = corner_uv * side  # texel units, x right, y up
    for f, tri in enumerate(px):
        lo = np.floor(tri.min(0) - 0.5).astype(int)
        hi = np.ceil(tri.max(0) + 0.5).astype(int)
        xs, ys = np.meshgrid(np.arange(max(lo[0], 0), min(hi[0], side)), np.arange(max(lo[1], 0), min(hi[1], side)))
        c = np.stack([xs.ravel() + 0.5, ys.ravel() + 0.5], axis=1)
        a, b, d = tri
        m = np.array([b - a, d - a]).T
        if abs(np.linalg.det(m)) < 1e-12:
            continue
        l12 = np.linalg.solve(m, (c - a).T).T
        lam = np.column_stack([1 - l12.sum(1), l12])
        inside = (lam >= -1e-9).all(1)
        rows.append(side - 1 - ys.ravel()[inside])
        cols.append(xs.ravel()[inside])
        faces.append(np.full(inside.sum(), f))
        bary.append(lam[inside])
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(faces), np.concatenate(bary)


def fill_gutters(image: np.ndarray, filled: np.ndarray) -> np.ndarray:
    """Empty texels take the mean of their filled 8-neighbours, GUTTER texels deep."""
    image, filled = image.astype(np.float64), filled.copy()
    for _ in range(GUTTER):
        total = np.zeros_like(image)
        count = np.zeros(filled.shape)
        padded_i = np.pad(image * filled[..., None], ((1, 1), (1, 1), (0, 0)))
        padded_f = np.pad(filled, 1).astype(np.float64)
        h, w = filled.shape
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                total += padded_i[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
                count += padded_f[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
        grow = ~filled & (count > 0)
        image[grow] = total[grow] / count[grow][:, None]
        filled = filled | grow
    return image


def hausdorff(low_v: np.ndarray, low_f: np.ndarray, high_v: np.ndarray, high_f: np.ndarray) -> float:
    """Largest distance from the simplified surface to the detailed one (pymeshlab)."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=low_v, face_matrix=np.asarray(low_f, np.int32)))
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=high_v, face_matrix=np.asarray(high_f, np.int32)))
    return float(ms.get_hausdorff_distance(sampledmesh=0, targetmesh=1, samplenum=200_000)["max"])


def bake(low_v: np.ndarray, low_f: np.ndarray, detailed: Any, side: int, value: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The atlas UVs (F, 3, 2), the baked (side, side, C) image and its filled mask: each texel
    gets ``value(faces, points)`` at the detailed surface its cage ray hits first."""
    import trimesh

    corner_uv, _ = atlas(low_v, low_f)
    rows, cols, faces, bary = texel_samples(corner_uv, side)
    low = trimesh.Trimesh(low_v, low_f, process=False)
    normals = reference.corner_normals(low, normals="smooth")
    point = np.einsum("nk,nkc->nc", bary, low_v[low_f[faces]])
    n = np.einsum("nk,nkc->nc", bary, normals[faces])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    reach = 1.05 * hausdorff(low_v, low_f, np.asarray(detailed.vertices), np.asarray(detailed.faces)) + 1e-9
    caster = reference.RayCaster(detailed)
    locations, ray, tri = caster.first_hits(point + n * reach, -n)
    got = np.zeros(len(point), bool)
    got[ray] = True
    values = value(tri, locations)
    image = np.zeros((side, side, values.shape[1]))
    filled = np.zeros((side, side), bool)
    image[rows[ray], cols[ray]] = values
    filled[rows[ray], cols[ray]] = True
    return corner_uv, fill_gutters(image, filled), filled


def seam_distance(corner_uv: np.ndarray, low_f: np.ndarray, hits: dict[str, Any], low_v: np.ndarray, side: int) -> np.ndarray:
    """Per hit pixel, the distance in atlas texels from its UV to the nearest chart border edge
    of the face it hit (inf for faces with no border edge)."""
    import trimesh

    edges: dict[tuple[int, int], list[tuple[int, int]]] = {}
    for f, tri in enumerate(low_f):
        for k in range(3):
            a, b = int(tri[k]), int(tri[(k + 1) % 3])
            edges.setdefault((min(a, b), max(a, b)), []).append((f, k))
    border: dict[int, list[np.ndarray]] = {}
    for uses in edges.values():
        uv_ends = [{int(low_f[f][k]): corner_uv[f][k], int(low_f[f][(k + 1) % 3]): corner_uv[f][(k + 1) % 3]} for f, k in uses]
        seam = len(uses) != 2 or any(not np.allclose(uv_ends[0][v], uv_ends[1][v]) for v in uv_ends[0])
        if seam:
            for (f, k), ends in zip(uses, uv_ends):
                border.setdefault(f, []).append(np.array(list(ends.values())))
    tri = hits["triangle"]
    out = np.full(tri.shape, np.inf)
    hit = hits["hit"]
    faces = tri[hit]
    bary = trimesh.triangles.points_to_barycentric(low_v[low_f[faces]], hits["point"][hit])
    uv = np.einsum("nk,nkc->nc", bary, corner_uv[faces]) * side
    d = np.full(len(faces), np.inf)
    for i, f in enumerate(faces):
        for seg in border.get(int(f), []):
            a, b = seg[0] * side, seg[1] * side
            ab = b - a
            s = np.clip(np.dot(uv[i] - a, ab) / max(np.dot(ab, ab), 1e-30), 0, 1)
            d[i] = min(d[i], float(np.linalg.norm(a + ab * s - uv[i])))
    out[hit] = d
    return out


def bunny_rows(renderer: gt.Renderer) -> list[dict[str, Any]]:
    import trimesh

    mesh = gt.load_mesh(BUNNY)
    igt = gt.igt.build(mesh, resolution=512)
    side = int(np.sqrt(igt.stats["bytes"] / 4))
    detailed = trimesh.Trimesh(igt.vertices, igt.faces, process=False)
    corners = reference.corner_normals(detailed)
    ref_caster = reference.RayCaster(detailed)

    def detailed_normal(tri: np.ndarray, points: np.ndarray) -> np.ndarray:
        bary = trimesh.triangles.points_to_barycentric(detailed.triangles[tri], points)
        n = np.einsum("nk,nkc->nc", bary, corners[tri])
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    rows = []
    for fraction in FRACTIONS:
        low = gt.igt.simplify(igt, int(len(igt.faces) * fraction))
        low_v, low_f = np.asarray(low.vertices), np.asarray(low.faces)
        corner_uv, normal_map, _ = bake(low_v, low_f, detailed, side, detailed_normal)
        low_caster = reference.RayCaster(trimesh.Trimesh(low_v, low_f, process=False))
        for k, view in enumerate(VIEWS):
            cam = camera(igt, view)
            ref = ref_caster.cast(cam, SIZE, SIZE)
            ref_normal = reference.shading_normals(detailed, corners, ref)
            frame = renderer.render(low, cam)
            hits = low_caster.cast(cam, SIZE, SIZE)
            baked = np.zeros((SIZE, SIZE, 3))
            faces = hits["triangle"][hits["hit"]]
            bary = trimesh.triangles.points_to_barycentric(low_v[low_f[faces]], hits["point"][hits["hit"]])
            uv = np.einsum("nk,nkc->nc", bary, corner_uv[faces])
            baked[hits["hit"]] = reference._bilinear(normal_map, uv)[:, :3]
            baked /= np.maximum(np.linalg.norm(baked, axis=2, keepdims=True), 1e-30)
            mask = interior(ref["hit"]) & interior(np.isfinite(frame.depth)) & interior(hits["hit"])
            seams = seam_distance(corner_uv, low_f, hits, low_v, side) <= 1.5
            igt_deg = reference.normal_angles(frame.normal, ref_normal, mask)
            baked_deg = reference.normal_angles(baked.astype(np.float32), ref_normal, mask)
            plain_deg = reference.normal_angles(hits["normal"], ref_normal, mask)
            at_seam = seams[mask]
            row = {"fraction": fraction, "faces": len(low), "view": k, "pixels": int(mask.sum()),
                   "atlas_side": side, "igt_bytes": int(igt.stats["bytes"]), "baked_bytes": 4 * side * side,
                   "igt_normal_deg_median": float(np.median(igt_deg)),
                   "baked_normal_deg_median": float(np.median(baked_deg)),
                   "plain_normal_deg_median": float(np.median(plain_deg)),
                   "seam_pixels": int(at_seam.sum()),
                   "baked_seam_deg_median": float(np.median(baked_deg[at_seam])) if at_seam.any() else None,
                   "baked_off_seam_deg_median": float(np.median(baked_deg[~at_seam])),
                   "igt_seam_deg_median": float(np.median(igt_deg[at_seam])) if at_seam.any() else None,
                   "igt_off_seam_deg_median": float(np.median(igt_deg[~at_seam]))}
            rows.append(row)
            print(f"bunny {fraction:5.3f} view {k}: normal median IGT {row['igt_normal_deg_median']:.2f}° "
                  f"baked {row['baked_normal_deg_median']:.2f}° plain {row['plain_normal_deg_median']:.2f}°; "
                  f"baked at seams {row['baked_seam_deg_median']} vs {row['baked_off_seam_deg_median']:.2f}° "
                  f"({row['seam_pixels']} px)", flush=True)
    return rows


def spot_rows(renderer: gt.Renderer) -> list[dict[str, Any]]:
    import trimesh

    spot = load_spot()
    igt = gt.igt.build(spot, resolution=512)
    side = int(np.sqrt(igt.stats["bytes"] / 4))
    detailed = trimesh.Trimesh(np.asarray(spot.vertices), np.asarray(spot.faces), process=False)
    low = gt.igt.simplify(igt, int(spot.n_faces * SPOT_FRACTION))
    low_v, low_f = np.asarray(low.vertices), np.asarray(low.faces)

    def color(tri: np.ndarray, points: np.ndarray) -> np.ndarray:
        return reference.base_colors(spot, tri, points).astype(np.float64)

    corner_uv, image, _ = bake(low_v, low_f, detailed, side, color)
    baked_mesh = gt.Mesh(low_v, low_f, uv=corner_uv, texture=np.clip(np.round(image), 0, 255).astype(np.uint8))
    rows = []
    for k, view in enumerate(SPOT_VIEWS):
        cam = camera(igt, view)
        ref = reference.raycast_albedo(spot, cam, SIZE, SIZE)
        frame = renderer.render(low, cam)
        baked = renderer.render(baked_mesh, cam)
        d_igt = reference.albedo_difference(frame.albedo, ref, np.isfinite(frame.depth))
        d_baked = reference.albedo_difference(baked.albedo, ref, np.isfinite(baked.depth))
        rows.append({"fraction": SPOT_FRACTION, "faces": len(low), "view": k, "atlas_side": side,
                     "igt_bytes": int(igt.stats["bytes"]), "igt_color_mean": d_igt["mean"],
                     "baked_color_mean": d_baked["mean"], "interior_px": d_igt["interior_px"]})
        print(f"spot {SPOT_FRACTION} view {k}: mean |Δcolor| IGT {d_igt['mean']:.2f} baked {d_baked['mean']:.2f} "
              f"(atlas {side}², {igt.stats['bytes'] / 1e6:.2f} MB)", flush=True)
    return rows


def main() -> None:
    renderer = gt.Renderer(SIZE, SIZE)
    start = os.getloadavg()
    data = {"date": datetime.datetime.now().isoformat(timespec="seconds"), "machine": platform.platform(),
            "adapter": renderer.adapter_info, "size": SIZE, "loadavg_start": start,
            "bunny": bunny_rows(renderer), "spot": spot_rows(renderer), "loadavg_end": os.getloadavg()}
    b = data["bunny"]
    data["summary"] = {str(f): {key: [min(r[key] for r in b if r["fraction"] == f and r[key] is not None),
                                      max(r[key] for r in b if r["fraction"] == f and r[key] is not None)]
                                for key in ("igt_normal_deg_median", "baked_normal_deg_median", "plain_normal_deg_median",
                                            "baked_seam_deg_median", "baked_off_seam_deg_median")}
                       for f in FRACTIONS}
    OUT.mkdir(parents=True, exist_ok=True)
    write_json(OUT / "igt_baked.json", data, indent=1)
    print(json.dumps(data["summary"], indent=1))


if __name__ == "__main__":
    main()
