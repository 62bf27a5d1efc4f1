"""Conversion quality on real and generated meshes, checked against independent references:
folding recomputed here in numpy from the mesh and the patch frames, distances by trimesh
(closest point) and scipy (k-d tree) on the original mesh."""

from __future__ import annotations

import numpy as np
import pytest

import geomtex as gt
from geomtex import reference

from conftest import GENERATED, SHARED_NAMES, Converted, converted

# Bounds per mesh, as fractions of the bounding-box diagonal: texel points → mesh (RMS) and mesh →
# nearest texel point (99th percentile), at most ~3x the measured figure written beside them and
# never above the conversion issue's targets (0.05% and 0.2%). Fandisk's RMS is set by the flat
# lips at its creases, the single triangle's by its rim; coverage is ~0.7 texel everywhere.
DISTANCE_BOUNDS = {  # name: (rms, p99)
    "stanford-bunny": (1.6e-5, 1.0e-3),  # 6.3e-6, 4.1e-4
    "pymeshlab-bunny": (9e-6, 1.0e-3),  # 3.5e-6, 4.0e-4
    "fandisk": (2e-4, 2e-3),  # 8.0e-5, 1.8e-3
    "rocker-arm": (1.9e-5, 1.3e-3),  # 7.6e-6, 5.2e-4
    "spot": (8e-6, 1.3e-3),  # 3.3e-6, 5.2e-4
    "homer": (1.9e-5, 1.5e-3),  # 7.5e-6, 5.8e-4
    "teapot": (6e-5, 1.8e-3),  # 2.3e-5, 7.3e-4
    "fractal_terrain": (7.5e-6, 5.5e-4),  # 3.0e-6, 2.2e-4
    "open_sheet": (1.1e-6, 2e-3),  # 4.4e-7, 1.8e-3
    "single_triangle": (2.9e-4, 2e-3),  # 1.1e-4, 1.9e-3
    "sphere": (6e-7, 2e-3),  # 2.2e-7, 8.2e-4
    "torus": (4e-7, 1.5e-3),  # 1.5e-7, 5.9e-4
}


def face_normals(mesh: gt.Mesh) -> tuple[np.ndarray, np.ndarray]:
    v, f = mesh.vertices, mesh.faces.astype(np.int64)
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    length = np.linalg.norm(cross, axis=1)
    return cross / np.maximum(length, 1e-300)[:, None], 0.5 * length


def check_no_folding(c: Converted) -> int:
    """Every chart face must face up (normal·z > 0) in its patch's frame. Returns the checked
    count."""
    normals, area = face_normals(c.mesh)
    wfp = c.gts.world_from_patch
    face_patch = c.gts.face_patch()
    assigned = face_patch >= 0
    z = wfp[face_patch[assigned], :3, 2]
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    dots = np.einsum("ij,ij->i", normals[assigned], z)
    assert dots.min() > 0.0, f"{(dots <= 0).sum()} inverted faces; worst normal·z {dots.min():.3g}"
    # Every face with an area is in exactly one chart.
    diag = c.mesh.diagonal
    assert np.all(assigned[area > (diag * 1e-9) ** 2])
    return int(assigned.sum())


def check_distances(c: Converted, n_points: int = 5000, n_samples: int = 50_000) -> tuple[float, float]:
    diag = reference.diagonal(c.mesh)
    rng = np.random.default_rng(0)
    pick = rng.choice(len(c.points), min(n_points, len(c.points)), replace=False)
    d = reference.points_to_mesh(c.points[pick], c.mesh)
    rms = float(np.sqrt(np.mean(d**2)) / diag)
    cover = reference.mesh_to_points(c.mesh, c.points, samples=n_samples)
    p99 = float(np.percentile(cover, 99) / diag)
    rms_bound, p99_bound = DISTANCE_BOUNDS[c.name]
    assert rms <= rms_bound, f"{c.name}: texel points lie {rms:.2e} (RMS, of the diagonal) off the mesh"
    assert p99 <= p99_bound, f"{c.name}: mesh covered only to {p99:.2e} of the diagonal (p99)"
    return rms, p99


def test_bunny_meets_the_issue_targets(bunny: Converted) -> None:
    st = bunny.gts.stats
    assert st["folding_charts"] == 0 and st["inverted_triangles"] == 0
    check_no_folding(bunny)
    assert st["empty_fraction"] <= 0.30, f"{st['empty_fraction']:.3f} empty (measured 0.287; paper: 0.388)"
    # Empty fraction recounted from the maps themselves: no height, or a centre outside the outline.
    maps = [bunny.gts.patch(i) for i in range(len(bunny.gts))]
    recount = (sum(int(((p["height"] == 0) | (p["outline"] < 0)).sum()) for p in maps)
               / sum(p["height"].size for p in maps))
    assert recount == pytest.approx(st["empty_fraction"], abs=1e-12)
    assert max(max(p["height"].shape) for p in maps) <= 256
    check_distances(bunny, n_points=20_000, n_samples=200_000)


@pytest.mark.parametrize("name", ["pymeshlab-bunny"] + [n for n in SHARED_NAMES if n != "stanford-bunny"])
def test_real_meshes(name: str) -> None:
    """The shared scans, and the watertight bunny inside the pymeshlab wheel (always present)."""
    c = converted(name)
    assert c.gts.stats["folding_charts"] == 0
    check_no_folding(c)
    check_distances(c)
    assert c.gts.stats["empty_fraction"] < 0.40


@pytest.mark.parametrize("name", sorted(GENERATED))
def test_generated_meshes(name: str) -> None:
    c = converted(name)
    check_no_folding(c)
    check_distances(c)
    if name == "single_triangle":
        assert len(c.gts) == 1
    if name == "sphere":
        # A closed convex surface cannot be one height field: it needs at least 2 charts.
        assert len(c.gts) >= 2


def test_open_sheet_heights_follow_the_surface() -> None:
    """Texel points of z = 0.15 sin 3x cos 2y lie on the analytic surface up to the mesh's own
    piecewise-linear error (grid spacing 1/30: |f''| h^2 / 8 ~ 6e-4; measured 2.7e-4)."""
    c = converted("open_sheet")
    x, y, z = c.points.T
    err = np.abs(z - 0.15 * np.sin(3 * x) * np.cos(2 * y))
    assert err.max() < 8e-4


def test_normals_agree_with_the_mesh(bunny: Converted) -> None:
    """Smooth texel normals vs the face normal of the closest triangle (trimesh): median angle."""
    import trimesh

    tm = trimesh.Trimesh(bunny.mesh.vertices, bunny.mesh.faces, process=False)
    k = 1000.0 / reference.diagonal(tm)
    scaled = trimesh.Trimesh(tm.vertices * k, tm.faces, process=False)
    pick = np.random.default_rng(1).choice(len(bunny.points), 4000, replace=False)
    _, _, tri = trimesh.proximity.closest_point(scaled, bunny.points[pick] * k)
    n = bunny.normals[pick].astype(np.float64)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)
    angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n, tm.face_normals[tri]), -1, 1)))
    assert np.median(angle) < 5.0, f"median normal error {np.median(angle):.2f} degrees (measured 3.18)"


def test_min_area_frames_waste_no_more_than_pca(bunny: Converted) -> None:
    pca = gt.convert(bunny.mesh, frame="pca")
    assert pca.stats["folding_charts"] == 0
    assert bunny.gts.stats["empty_fraction"] <= pca.stats["empty_fraction"]


def test_far_from_origin_keeps_detail(bunny: Converted) -> None:
    """The same bunny placed at 1e6 converts as well as at the origin: its texel points lie on the
    mesh as closely (f64 core, frames relative to each chart). The partition itself may differ:
    VSA's greedy flooding turns a 1e-10 rounding difference into another seed now and then."""
    offset = np.array([1e6, -2e6, 5e5])
    moved = gt.Mesh(bunny.mesh.vertices + offset, bunny.mesh.faces)
    gts = gt.convert(moved, max_resolution=256)
    diag = bunny.mesh.diagonal
    points, _ = gts.to_points()

    def distances(pts: np.ndarray) -> np.ndarray:
        sample = pts[np.random.default_rng(3).choice(len(pts), 5000, replace=False)]
        return reference.points_to_mesh(sample, bunny.mesh)

    d = distances(points - offset)
    d0 = distances(bunny.points)
    rms, rms0 = (np.sqrt(np.mean(x**2)) / diag for x in (d, d0))
    # f32 anywhere on the way would cost ~1e6 * 6e-8 = 0.06 world units here (~0.2 of the
    # diagonal); the f64 core stays at the origin's level. Measured moved / at the origin: RMS
    # 2.1e-6 / 2.4e-6 of the diagonal and max 0.24 / 0.28 texel (pymeshlab bunny); 8.0e-8 / 3.5e-6
    # and 5.6e-4 / 0.41 texel (Stanford bunny, whose moved partition differs).
    assert rms <= 2.0 * rms0, (rms, rms0)
    assert d.max() <= 2.0 * d0.max(), (d.max(), d0.max())
    # Measured: one texel in 3.07 M (the same partition); left loose for the other partition
    # the docstring allows.
    assert abs(len(points) / len(bunny.points) - 1) < 0.15
    assert gts.stats["folding_charts"] == 0


def test_conversion_is_deterministic(bunny: Converted) -> None:
    again = gt.convert(bunny.mesh, max_resolution=256)
    assert len(again) == len(bunny.gts)
    for i in (0, len(again) // 2, len(again) - 1):
        a, b = again.patch(i), bunny.gts.patch(i)
        for key in ("height", "normal", "color", "world_from_patch", "faces"):
            assert np.array_equal(a[key], b[key]), key


def test_keywords_change_what_they_say(bunny: Converted) -> None:
    m = bunny.mesh
    few = gt.convert(m, charts=40, max_resolution=64)
    assert 40 <= few.stats["charts"] <= 40 + few.stats["repair_splits"]
    assert max(max(few.patch(i)["height"].shape) for i in range(len(few))) <= 64
    no_ring = gt.convert(m, charts=40, max_resolution=64, overlap_rings=0)
    assert no_ring.stats["ring_faces"] == 0 and few.stats["ring_faces"] > 0
    # The rings' surface is drawn too: more covered area (texel sizes differ, so in world units).
    area = lambda g: (g.stats["texels"] - g.stats["empty_texels"]) * g.texel_size**2  # noqa: E731
    assert area(few) > 1.02 * area(no_ring)
    fixed = gt.convert(m, charts=40, texel_size=few.texel_size * 2)
    assert fixed.texel_size == pytest.approx(few.texel_size * 2)
    assert fixed.stats["texels"] < few.stats["texels"]


def test_vertex_colors_reach_the_color_maps() -> None:
    sheet = wavy_sheet_colored()
    gts = gt.convert(sheet, max_resolution=256)
    for i in range(len(gts)):
        p = gts.patch(i)
        filled = p["height"] > 0
        # Red rises with x from 0 to 255 across the sheet; green is constant.
        assert np.all(p["color"][filled][:, 1] == 100)
    pts, _ = gts.to_points()
    reds = np.concatenate([gts.patch(i)["color"][gts.patch(i)["height"] > 0][:, 0] for i in range(len(gts))])
    want = (pts[:, 0] + 1) / 2 * 255
    assert np.abs(reds.astype(float) - want).max() <= 2.0


def wavy_sheet_colored() -> gt.Mesh:
    from geomtex.testing import wavy_sheet

    s = wavy_sheet(40)
    v = s.vertices
    n = len(v)
    colors = np.column_stack([np.round((v[:, 0] + 1) / 2 * 255), np.full(n, 100), np.zeros(n), np.full(n, 255)])
    return gt.Mesh(v, s.faces, colors.astype(np.uint8))


def test_reconstruction_error_is_measured_and_converges(bunny: Converted) -> None:
    """Every conversion measures each patch's error: the vertical gap between its bilinear
    surface and points sampled on its own triangles (p99). Below a texel, and bilinear
    convergence: halving the texel cuts it by 2.5-5x (h^2 would be 4x; scan noise and creases)."""
    s = bunny.gts.stats
    assert len(s["patch_error"]) == len(bunny.gts) == len(s["patch_resolution"])
    assert np.all(s["patch_resolution"] <= 256) and s["patch_resolution"].max() == 256
    assert 0 < s["reconstruction_error_p99"] <= s["reconstruction_error_max"]
    assert s["reconstruction_error_p99"] < 0.1 * s["texel_size"]
    coarse = gt.convert(bunny.mesh, max_resolution=128).stats
    assert 2.5 <= coarse["reconstruction_error_p99"] / s["reconstruction_error_p99"] <= 5.0
