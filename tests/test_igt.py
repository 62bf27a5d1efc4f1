"""Inverse geometric textures (geomtex.igt): the lists against an independent numpy
computation, the CPU lookup against the known face of points sampled on the detailed surface,
simplification, files and bad input."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

import geomtex as gt
from geomtex import reference

from conftest import SHARED_MESHES, pymeshlab_bunny_path


def _bunny_mesh() -> gt.Mesh:
    path = SHARED_MESHES / "stanford-bunny.obj"
    return gt.load_mesh(path if path.exists() else pymeshlab_bunny_path())


_built: dict[tuple[str, int], gt.igt.InverseGeometricTexture] = {}


def _igt(primary: str = "charts", resolution: int = 256) -> gt.igt.InverseGeometricTexture:
    key = (primary, resolution)
    if key not in _built:
        _built[key] = gt.igt.build(_bunny_mesh(), primary=primary, resolution=resolution)
    return _built[key]


def _chart_corners(igt: gt.igt.InverseGeometricTexture) -> np.ndarray:
    """Each entry's corners in its chart's cell units, projected here with numpy."""
    g = igt.grids
    grid = igt.entry_grid
    p = igt.vertices[igt.faces[igt.entry_face]] - g["origin"][grid][:, None, :]
    axes = g["axes"][grid]
    u = np.einsum("ekc,ec->ek", p, axes[:, 0]) / g["cell"][grid, 0][:, None]
    v = np.einsum("ekc,ec->ek", p, axes[:, 1]) / g["cell"][grid, 1][:, None]
    return np.stack([u, v], axis=-1)


def test_every_triangle_is_listed_in_every_cell_it_covers() -> None:
    igt = _igt()
    corners = _chart_corners(igt)
    # The stored corners are the same projection (float32).
    assert np.abs(corners - igt.entry_corners).max() < 1e-3
    g = igt.grids
    shape, first = g["shape"][igt.entry_grid], g["first_cell"][igt.entry_grid]
    # Points on every triangle: corners, points along the edges and inside (barycentric lattice
    # of step 1/8), each mapped to its cell; that cell's list must hold the entry.
    n = 8
    lattice = np.array([(i, j, n - i - j) for i in range(n + 1) for j in range(n + 1 - i)], float) / n
    starts, entries = igt.cell_start, igt.cell_entries
    listed = set()
    for c in range(len(starts) - 1):
        for e in entries[starts[c]:starts[c + 1]]:
            listed.add((c, int(e)))
    missing = 0
    for lam in lattice:
        pts = np.einsum("k,ekd->ed", lam, corners)
        i = np.clip(np.floor(pts[:, 0]).astype(np.int64), 0, shape[:, 0] - 1)
        j = np.clip(np.floor(pts[:, 1]).astype(np.int64), 0, shape[:, 1] - 1)
        cells = first + j * shape[:, 0] + i
        missing += sum((int(c), e) not in listed for e, c in enumerate(cells))
    assert missing == 0
    # Not loose either: every listed pair's triangle reaches its cell (bounds within 1e-3).
    cell_of = np.repeat(np.arange(len(starts) - 1), np.diff(starts))
    grid_of = np.searchsorted(g["first_cell"], cell_of, side="right") - 1
    local = cell_of - g["first_cell"][grid_of]
    ci, cj = local % g["shape"][grid_of, 0], local // g["shape"][grid_of, 0]
    lo, hi = corners[entries].min(axis=1), corners[entries].max(axis=1)
    reach = (lo[:, 0] <= ci + 1 + 1e-3) & (hi[:, 0] >= ci - 1e-3)
    reach &= (lo[:, 1] <= cj + 1 + 1e-3) & (hi[:, 1] >= cj - 1e-3)
    assert reach.all()
    s = igt.stats
    assert s["faces"] == len(igt.faces) and sum(s["histogram"]) == s["cells"]
    # Measured on the 69k-face bunny at 256²: 6.5 triangles per non-empty cell, 16 at most.
    assert 3.0 <= s["list_mean"] <= 13.0, s["list_mean"]


@pytest.mark.parametrize("primary", ["charts", "spherical"])
def test_lookup_finds_the_face_of_points_on_it(primary: str) -> None:
    igt = _igt(primary, 512)
    rng = np.random.default_rng(7)
    faces = rng.integers(0, len(igt.faces), 20000)
    lam = rng.dirichlet([1.0, 1.0, 1.0], len(faces))
    pts = np.einsum("nk,nkd->nd", lam, igt.vertices[igt.faces[faces]])
    grids = igt.face_grid[faces].tolist() if primary == "charts" else None
    found, bary, inside = igt.lookup(pts, grids)
    agree = (found == faces).mean()
    if primary == "charts":
        # Each chart's projection is bijective and affine: every point is found, with its own
        # barycentrics (measured: 100%, 2e-5 from float32 corners).
        assert agree == 1.0 and inside.all()
        assert np.abs(bary - lam).max() < 1e-3
    else:
        # The bunny is not star-shaped (ears, folds): a sphere's rays meet it more than once,
        # so the spherical map cannot be bijective (measured 82.9% agreement).
        assert 0.78 <= agree < 0.9, agree


def test_simplified_faces_project_into_their_detailed_charts() -> None:
    igt = _igt("charts", 512)
    low = gt.igt.simplify(igt, 1400)
    assert 1300 <= len(low) <= 1400 and low.face_grid.min() >= 0
    # Centroids of the simplified faces, looked up in their grid: found inside a listed
    # detailed triangle (not the fallback) for nearly all (measured 99.8%).
    c = low.vertices[low.faces].mean(axis=1)
    found, _, inside = igt.lookup(c, low.face_grid.tolist())
    assert (found >= 0).all()
    assert inside.mean() >= 0.99, inside.mean()


def test_files_round_trip_and_damage_is_a_format_error(tmp_path: Path) -> None:
    igt = _igt()
    path = tmp_path / "bunny.gtigt"
    igt.save(path)
    back = gt.igt.load(path)
    for name in ["cell_start", "cell_entries", "entry_face", "entry_corners", "normals", "faces"]:
        assert np.array_equal(getattr(back, name), getattr(igt, name)), name
    assert back.stats["list_mean"] == igt.stats["list_mean"]
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x10
    with pytest.raises(gt.FormatError, match="checksum"):
        gt.igt.InverseGeometricTexture.from_bytes(bytes(data))
    with pytest.raises(gt.FormatError, match="truncated"):
        gt.igt.InverseGeometricTexture.from_bytes(bytes(path.read_bytes()[:-5]))
    with pytest.raises(gt.FormatError, match="not a .gtigt"):
        gt.igt.InverseGeometricTexture.from_bytes(b"GTEX\r\n\x1a\n" + bytes(40))


def test_bad_input_raises_parameter_errors() -> None:
    mesh = _bunny_mesh()
    for bad in [0, -3, 100_000]:
        with pytest.raises(gt.ParameterError, match="resolution"):
            gt.igt.build(mesh, resolution=bad)
    with pytest.raises(gt.ParameterError, match="primary"):
        gt.igt.build(mesh, primary="octahedral")  # type: ignore[arg-type]
    with pytest.raises(gt.ParameterError, match="attributes"):
        gt.igt.build(mesh, attributes=["ambient"])
    igt = _igt()
    with pytest.raises(gt.ParameterError, match="grid"):
        igt.lookup(np.zeros((2, 3)))
    with pytest.raises(gt.ParameterError, match="grid id"):
        igt.lookup(np.zeros((2, 3)), [0, 10**6])
    with pytest.raises(gt.ParameterError, match="target_faces"):
        gt.igt.simplify(igt, 2)
    with pytest.raises(gt.ParameterError, match="grid"):
        igt.shade(np.eye(3), np.array([[0, 1, 2]]), [len(igt.grids["origin"])])


def test_a_mesh_far_from_the_source_is_refused_at_once() -> None:
    """A mesh moved away from the detailed one (10 diagonals) sent attach's window search on for
    minutes (killed after 120 s); one more than 0.25 of the diagonal past the source's box is
    refused before that search, and a simplification moved by 1% of the diagonal still attaches.
    (Within the reach the search still grows with the gap: the bunny's convex hull, 3,000 faces,
    attaches in 16.6 s in place, 21.7 s moved by 6% of the diagonal.)"""
    igt = _igt()
    lo, hi = igt.vertices.min(axis=0), igt.vertices.max(axis=0)
    diagonal = float(np.linalg.norm(hi - lo))
    start = time.perf_counter()
    with pytest.raises(gt.ParameterError, match="past the texture's detailed mesh"):
        gt.igt.attach(igt, igt.vertices + 10 * diagonal, igt.faces)
    assert time.perf_counter() - start < 1.0  # measured 0.004-0.007 s (the bunny's texture)
    low = gt.igt.simplify(igt, 1400)
    start = time.perf_counter()
    with pytest.raises(gt.ParameterError, match="past the texture's detailed mesh"):
        gt.igt.attach(igt, low.vertices + 0.3 * diagonal, low.faces)
    assert time.perf_counter() - start < 1.0
    gt.igt.attach(igt, low.vertices + 0.01 * diagonal, low.faces)


def test_progress_reports_and_can_cancel() -> None:
    mesh = _bunny_mesh()
    seen: list[str] = []
    gt.igt.build(mesh, resolution=64, progress=lambda s, f: seen.append(s))
    assert "partition" in seen and "lists" in seen
    with pytest.raises(gt.CancelledError):
        gt.igt.build(mesh, resolution=64, progress=lambda s, f: s != "lists")


# Rendering (kinds/igt.rs, shaders/igt_*.wgsl).

_SIZE = 256


def _camera(igt: gt.igt.InverseGeometricTexture, direction: tuple[float, float, float]) -> gt.Camera:
    v = igt.vertices
    centre, diag = (v.min(0) + v.max(0)) / 2, float(np.linalg.norm(v.max(0) - v.min(0)))
    d = np.asarray(direction, float)
    return gt.Camera.look_at(centre + d / np.linalg.norm(d) * 1.6 * diag, centre)


def _points(frame: gt.Frame, camera: gt.Camera, mask: np.ndarray) -> np.ndarray:
    """World points of the pixels of `mask`, rebuilt from the frame's z-depth."""
    o, d = camera.rays(_SIZE, _SIZE)
    o, d = o[mask], d[mask]
    return o + d * (frame.depth[mask] / (d @ np.asarray(camera.forward)))[:, None]


def _interior(mask: np.ndarray) -> np.ndarray:
    """`mask` without its pixels within one pixel of its boundary (silhouettes)."""
    padded = np.pad(mask, 1)
    return np.logical_and.reduce([padded[dy:dy + mask.shape[0], dx:dx + mask.shape[1]]
                                  for dy in range(3) for dx in range(3)])


@pytest.mark.parametrize("primary", ["charts", "spherical"])
def test_the_shader_finds_what_the_cpu_lookup_finds(primary: str, renderer_256: gt.Renderer) -> None:
    """frame.face_id / frame.barycentric against igt.lookup at the same points (rebuilt from the
    frame's depth); each pixel's simplified face, hence its grid, from trimesh's ray cast of the
    simplified mesh."""
    import trimesh

    from geomtex.reference import RayCaster

    igt = _igt(primary, 512)
    # The projection lookup: the CPU's igt.lookup is its reference (the ray lookup's is embree,
    # below).
    low = gt.igt.simplify(igt, 1400, lookup="projection")
    assert low.lookup == "projection"
    cam = _camera(igt, (0.3, 0.2, 1.0))
    frame = renderer_256.render(low, cam)
    assert frame.face_id is not None and frame.barycentric is not None
    assert frame.face_id.shape == (_SIZE, _SIZE) and frame.barycentric.shape == (_SIZE, _SIZE, 3)
    drawn = np.isfinite(frame.depth)
    assert (frame.face_id[~drawn] == -1).all()
    # Drawn pixels with no listed triangle in their cell or the ring around it (the CPU lookup
    # finds none either): measured 2.2% (charts: the simplified surface strays from its chart), 0%.
    assert (frame.face_id[drawn] < 0).mean() <= (0.05 if primary == "charts" else 0.001)
    ref = RayCaster(trimesh.Trimesh(low.vertices, low.faces, process=False)).cast(cam, _SIZE, _SIZE)
    px = drawn & ref["hit"]
    grids = low.face_grid[ref["triangle"][px]].tolist() if primary == "charts" else None
    face, bary, _ = igt.lookup(_points(frame, cam, px), grids)
    same = face == frame.face_id[px]
    # Measured 99.97% (charts) and 99.98% (spherical) of 9,343 pixels: the rest lie within
    # float32 rounding of a triangle's edge.
    assert same.mean() >= 0.999, same.mean()
    spread = np.abs(bary[same] - frame.barycentric[px][same]).max(axis=1)
    # p99 measured 7.8e-5 (charts), 6.9e-4 (spherical: longitude and colatitude in float32).
    assert np.percentile(spread, 99) <= (2.5e-4 if primary == "charts" else 2e-3)
    found = frame.face_id >= 0
    assert np.allclose(frame.barycentric[found].sum(axis=1), 1.0, atol=1e-4)
    assert (frame.barycentric[~found] == 0).all()


@pytest.fixture(scope="module")
def renderer_256() -> gt.Renderer:
    return gt.Renderer(_SIZE, _SIZE)


@pytest.mark.parametrize("fraction", [0.1, 0.02, 0.005])
def test_rendered_normals_and_faces_against_ray_casting(fraction: float, renderer_256: gt.Renderer) -> None:
    """The bunny simplified to 10%, 2% and 0.5% of its faces, shaded through its IGT (the ray
    lookup), against trimesh's ray cast of the detailed mesh (normals interpolated by the same
    crease rule), on pixels both hit that are not within a pixel of either silhouette; the plain
    simplified mesh beside it."""
    import trimesh

    from geomtex.reference import RayCaster, corner_normals, normal_angles, shading_normals

    igt = _igt("charts", 512)
    low = gt.igt.simplify(igt, int(len(igt.faces) * fraction))
    assert low.lookup == "ray"
    detailed = trimesh.Trimesh(igt.vertices, igt.faces, process=False)
    cam = _camera(igt, (0.3, 0.2, 1.0))
    ref = RayCaster(detailed).cast(cam, _SIZE, _SIZE)
    ref_normal = shading_normals(detailed, corner_normals(detailed), ref)
    frame = renderer_256.render(low, cam)
    plain = renderer_256.render(gt.Mesh(low.vertices, low.faces), cam)
    mask = _interior(ref["hit"]) & _interior(np.isfinite(frame.depth))
    igt_deg = float(np.median(normal_angles(frame.normal, ref_normal, mask)))
    plain_deg = float(np.median(normal_angles(plain.normal, ref_normal, mask)))
    agree = float((frame.face_id[mask] == ref["triangle"][mask]).mean())
    # Measured (256², this view, ~9,000 pixels): normals 0.0054° at every fraction (the
    # octahedral snorm16 encoding's rounding; plain 4.07°, 8.35°, 17.1°), faces 99.978%,
    # 99.902%, 99.933% (the projection lookup: 90.1% and 63.2% at 10% and 2%). Bounds: 3x the
    # error and 3x the disagreement.
    bounds = {0.1: (0.016, 250.0, 0.9993), 0.02: (0.016, 500.0, 0.997), 0.005: (0.016, 1000.0, 0.998)}[fraction]
    assert igt_deg <= bounds[0], igt_deg
    assert plain_deg / igt_deg >= bounds[1], (plain_deg, igt_deg)
    assert agree >= bounds[2], agree


def test_faces_agree_from_the_side_at_half_a_percent(renderer_256: gt.Renderer) -> None:
    """The bunny simplified to 0.5% seen from +x and -x, where the detailed surface stands in
    front of the simplified faces that the decimation cut it off from: the detailed face under
    each pixel against embree's, on pixels both hit not within a pixel of either silhouette
    (the issue asks 99%)."""
    import trimesh

    from geomtex.reference import RayCaster

    igt = _igt("charts", 512)
    low = gt.igt.simplify(igt, int(len(igt.faces) * 0.005))
    caster = RayCaster(trimesh.Trimesh(igt.vertices, igt.faces, process=False))
    for direction in ((1.0, 0.0, 0.0), (-1.0, 0.0, 0.0)):
        cam = _camera(igt, direction)
        ref = caster.cast(cam, _SIZE, _SIZE)
        frame = renderer_256.render(low, cam)
        mask = _interior(ref["hit"]) & _interior(np.isfinite(frame.depth))
        agree = float((frame.face_id[mask] == ref["triangle"][mask]).mean())
        # Measured (256²): 99.27% (+x) and 99.19% (-x); a build without window.rs's `reach`
        # (the windows of before) gave 98.58% at +x. The bound is the issue's.
        assert agree >= 0.99, (direction, agree)
    # The window on the camera's side reaches past the one inside for the faces that needed
    # it.
    w = low.face_window
    assert (w > 0).all() and (w[:, 0] > w[:, 1]).any() and (w[:, 1] > w[:, 0]).any()


def test_five_samples_filter_against_a_supersampled_reference(renderer_256: gt.Renderer) -> None:
    """samples=5 (the pixel's centre and four points of its footprint, averaged) against
    embree's ray cast of the detailed bunny at 4 x 4 rays per pixel, its normals averaged per
    pixel (pixels whose 16 rays all hit, not within a pixel of a silhouette): where a pixel
    covers several detailed triangles one sample aliases."""
    import trimesh

    from geomtex.reference import RayCaster, corner_normals, normal_angles, shading_normals

    igt = _igt("charts", 512)
    one = gt.igt.simplify(igt, int(len(igt.faces) * 0.02))
    five = gt.igt.attach(igt, one.vertices, one.faces, samples=5)
    assert (one.samples, five.samples) == (1, 5)
    detailed = trimesh.Trimesh(igt.vertices, igt.faces, process=False)
    cam = _camera(igt, (0.3, 0.2, 1.0))
    k = 4
    ref = RayCaster(detailed).cast(cam, _SIZE * k, _SIZE * k)
    normals = shading_normals(detailed, corner_normals(detailed), ref).reshape(_SIZE, k, _SIZE, k, 3).sum(axis=(1, 3))
    hit = ref["hit"].reshape(_SIZE, k, _SIZE, k).all(axis=(1, 3))
    errors = []
    for low in (one, five):
        frame = renderer_256.render(low, cam)
        mask = _interior(hit) & _interior(np.isfinite(frame.depth))
        errors.append(float(np.median(normal_angles(frame.normal, normals, mask))))
    # Measured (256², this view): median 0.342° with one sample, 0.0654° with five (5.2x
    # lower; a build that ignored samples drew 0.342° for both). Bounds: 3x the error, a
    # third of the gain.
    assert errors[1] <= 0.2 and errors[0] / errors[1] >= 1.75, errors
    with pytest.raises(gt.ParameterError, match="samples"):
        gt.igt.attach(igt, one.vertices, one.faces, samples=4)


@pytest.mark.skipif(not (SHARED_MESHES / "spot.obj").exists(), reason="needs the shared spot mesh")
def test_textured_colors_against_ray_casting(renderer_256: gt.Renderer) -> None:
    """Spot simplified to 5%, shaded with its texture through its IGT (the ray lookup), against
    trimesh's ray cast of the textured detailed mesh (texture sampled at the hit's coordinates):
    mean absolute color difference on interior pixels."""
    import trimesh
    from PIL import Image

    from geomtex.reference import albedo_difference, raycast_albedo

    tm = trimesh.load(SHARED_MESHES / "spot.obj", force="mesh", process=False)
    image = Image.open(SHARED_MESHES / "spot_texture.png")
    tm.visual = trimesh.visual.TextureVisuals(uv=tm.visual.uv, image=image)
    spot = gt.Mesh.from_trimesh(tm)
    igt = gt.igt.build(spot, resolution=512)
    low = gt.igt.simplify(igt, int(spot.n_faces * 0.05))
    cam = _camera(igt, (1.0, 0.3, 0.2))
    frame = renderer_256.render(low, cam)
    ref = raycast_albedo(spot, cam, _SIZE, _SIZE)
    d = albedo_difference(frame.albedo, ref, np.isfinite(frame.depth))
    # Measured 0.10/255 on 6,769 interior pixels (the projection lookup: 6.90/255).
    assert d["mean"] <= 0.31, d


def test_lookup_is_chosen_and_checked() -> None:
    igt = _igt("charts", 512)
    low = gt.igt.simplify(igt, 1400)
    projected = gt.igt.attach(igt, low.vertices, low.faces, lookup="projection")
    assert (low.lookup, projected.lookup) == ("ray", "projection")
    # Windows and search grids: measured per face, the face's own grid first.
    assert low.face_window.shape == (len(low), 2) and (low.face_window > 0).all()
    assert np.array_equal(low.search_grids[:, 0], low.face_grid)
    with pytest.raises(gt.ParameterError, match="lookup"):
        gt.igt.attach(igt, low.vertices, low.faces, lookup="nearest")


def test_an_igt_mesh_composites_with_other_objects(renderer_256: gt.Renderer) -> None:
    """Scene.add takes an IgtMesh; where another mesh is nearer, the pixel is that mesh's and
    has no detailed face; face ids come only with an IgtMesh in the scene, and pickle."""
    import pickle

    igt = _igt("charts", 512)
    low = gt.igt.simplify(igt, 1400)
    v = igt.vertices
    lo, hi = v.min(0), v.max(0)
    # A quad in front of the bunny's left half, facing the camera (+z).
    z = hi[2] + 0.1 * (hi[2] - lo[2])
    mid = (lo[0] + hi[0]) / 2
    quad = gt.Mesh(np.array([[lo[0] - 1, lo[1] - 1, z], [mid, lo[1] - 1, z], [mid, hi[1] + 1, z],
                             [lo[0] - 1, hi[1] + 1, z]]), np.array([[0, 1, 2], [0, 2, 3]]))
    scene = gt.Scene()
    scene.add(quad)
    scene.add(low)
    frame = renderer_256.render(scene, _camera(igt, (0.0, 0.0, 1.0)))
    assert frame.face_id is not None
    ids = frame.patch_id
    assert (ids == -2).any() and (ids == -3).any()
    assert (frame.face_id[ids == -2] == -1).all()
    # Every pixel showing the IgtMesh has a face but those nothing is listed near (measured
    # 0.024% with the ray lookup; 2.6% with the projection).
    shown = ids == -3
    assert (frame.face_id[~shown] == -1).all() and (frame.face_id[shown] >= 0).mean() >= 0.9993
    back = pickle.loads(pickle.dumps(frame))
    assert np.array_equal(back.face_id, frame.face_id) and np.array_equal(back.barycentric, frame.barycentric)
    # The scene pickles too (the texture as its .gtigt bytes, the mesh with its grids) and draws
    # the same frame.
    again = renderer_256.render(pickle.loads(pickle.dumps(scene)), _camera(igt, (0.0, 0.0, 1.0)))
    assert np.array_equal(again.face_id, frame.face_id) and np.array_equal(again.color, frame.color)
    assert renderer_256.render(quad, _camera(igt, (0.0, 0.0, 1.0))).face_id is None


def test_rendering_bad_input(renderer_256: gt.Renderer) -> None:
    igt = _igt("charts", 512)
    low = gt.igt.simplify(igt, 1400)
    with pytest.raises(gt.ParameterError, match="IgtMesh"):
        gt.Scene().add(low, normals="flat")
    with pytest.raises(gt.ParameterError, match="not supported"):
        renderer_256.intersect(low, np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))
    with pytest.raises(gt.ParameterError, match="faces reference"):
        gt.igt.attach(igt, low.vertices, low.faces + len(low.vertices))
    with pytest.raises(gt.ParameterError, match=r"\(V, 3\)"):
        gt.igt.attach(igt, low.vertices[:, :2], low.faces)


# Ambient occlusion (src/igt/occlusion.rs) and the shader LoD (src/igt_data/bake.rs, igt_baked).

_ao_built: dict[int, gt.igt.InverseGeometricTexture] = {}


def _ao_igt() -> gt.igt.InverseGeometricTexture:
    if not _ao_built:
        # Occlusion does not depend on the resolution: the smallest that shades well.
        _ao_built[0] = gt.igt.build(_bunny_mesh(), resolution=128, attributes=["normals", "ao"])
    return _ao_built[0]


def test_ambient_occlusion_against_embree() -> None:
    """Per-vertex occlusion (64 rays, the default) on 200 bunny vertices, half the most occluded,
    against embree's estimate from 1,024 independent random rays each."""
    import trimesh

    igt = _ao_igt()
    ao = igt.ao
    assert ao is not None and ao.shape == (len(igt.faces), 3)
    vertex_ao = np.ones(len(igt.vertices), np.float32)
    vertex_ao[igt.faces] = ao
    tm = trimesh.Trimesh(igt.vertices, igt.faces, process=False)
    rng = np.random.default_rng(1)
    picked = np.concatenate([np.argsort(vertex_ao)[:100], rng.choice(len(igt.vertices), 100, replace=False)])
    ref = reference.occlusion(tm, picked, 1024)
    diff = vertex_ao[picked] - ref
    # Measured: mean |difference| 0.0156, mean difference (bias) -0.0063, on 200 vertices whose
    # reference runs 0.27-1.0 (sampling noise alone: 64 rays give up to 0.0625 standard
    # deviation). Bounds: 3x.
    assert np.abs(diff).mean() <= 0.047, np.abs(diff).mean()
    assert abs(diff.mean()) <= 0.019, diff.mean()


def test_ambient_occlusion_darkens_the_frame(renderer_256: gt.Renderer) -> None:
    """With "ao" the base color (frame.albedo) is the neutral gray times the occlusion
    interpolated at the pixel's detailed face and barycentrics; the normals do not change."""
    plain = _igt("charts", 128)
    shaded = _ao_igt()
    low = gt.igt.simplify(plain, 1400)
    cam = _camera(plain, (0.3, 0.2, 1.0))
    without = renderer_256.render(low, cam)
    frame = renderer_256.render(gt.igt.attach(shaded, low.vertices, low.faces), cam)
    assert frame.face_id is not None and frame.barycentric is not None
    found = frame.face_id >= 0
    assert np.array_equal(frame.face_id, without.face_id)
    assert np.array_equal(frame.normal, without.normal)
    ao = shaded.ao
    assert ao is not None
    expected = 200.0 * (frame.barycentric[found] * ao[frame.face_id[found]]).sum(axis=1)
    err = np.abs(frame.albedo[found][:, 0].astype(float) - expected)
    # Measured: at most 0.5 (the albedo's rounding to 8 bits) on 9,816 pixels, 30% of them
    # darker than 180 of the neutral 200. Bounds: one level; a third of the share.
    assert err.max() <= 1.0, err.max()
    assert (frame.albedo[found][:, 0] < 180).mean() >= 0.1
    with pytest.raises(gt.ParameterError, match="ao_rays"):
        gt.igt.build(_bunny_mesh(), resolution=64, ao_rays=16)
    with pytest.raises(gt.ParameterError, match="ao_distance"):
        gt.igt.build(_bunny_mesh(), resolution=64, attributes=["ao"], ao_distance=-1.0)


def test_occlusion_survives_files() -> None:
    igt = _ao_igt()
    back = gt.igt.InverseGeometricTexture.from_bytes(igt.to_bytes())
    assert back.ao is not None and np.array_equal(back.ao, igt.ao)
    assert _igt().ao is None and gt.igt.InverseGeometricTexture.from_bytes(_igt().to_bytes()).ao is None


def test_shader_lod_switches_without_a_pop(renderer_256: gt.Renderer) -> None:
    """The shader LoD on the bunny simplified to 2%, its texture at resolution 128, the camera
    where a cell spans about a pixel ("auto"'s switch): a lod distance beyond the whole bunny
    changes nothing, one before it bakes every pixel, and "auto" shows each pixel one way or
    the other; the two differ little there (the pop), and both stay near embree's ray cast of
    the detailed mesh."""
    import trimesh

    from geomtex.reference import RayCaster, corner_normals, normal_angles, shading_normals

    igt = _igt("charts", 128)
    low = gt.igt.simplify(igt, int(len(igt.faces) * 0.02))
    v = igt.vertices
    centre, radius = (v.min(0) + v.max(0)) / 2, float(np.linalg.norm(v.max(0) - v.min(0))) / 2
    # A pixel spans a cell where the cell's size over the distance is the pixel's angle.
    switch = float(igt.grids["cell"][0, 0]) / (2 * np.tan(np.radians(45.0) / 2) / _SIZE)
    d = np.array([0.3, 0.2, 1.0]) / np.linalg.norm([0.3, 0.2, 1.0])
    cam = gt.Camera.look_at(centre + d * switch, centre)
    frames = {}
    for lod in ["off", "auto", switch + 2 * radius, switch - 2 * radius]:
        shaded = gt.igt.attach(igt, low.vertices, low.faces, lod=lod)
        assert shaded.lod == (lod if isinstance(lod, str) else pytest.approx(lod))
        frames[lod] = renderer_256.render(shaded, cam)
    off, auto, before, after = frames.values()
    assert np.array_equal(before.normal, off.normal) and np.array_equal(before.color, off.color)
    detailed = trimesh.Trimesh(v, igt.faces, process=False)
    ref = RayCaster(detailed).cast(cam, _SIZE, _SIZE)
    ref_normal = shading_normals(detailed, corner_normals(detailed), ref)
    mask = _interior(ref["hit"]) & _interior(np.isfinite(off.depth))
    as_off = (auto.normal == off.normal).all(axis=-1)[mask]
    as_baked = (auto.normal == after.normal).all(axis=-1)[mask]
    pop = float(np.mean(normal_angles(off.normal, after.normal, mask)))
    errors = [float(np.median(normal_angles(f.normal, ref_normal, mask))) for f in (off, after)]
    # Measured (256², 1,997 pixels): "auto" showed every pixel as one of the two, 27% through
    # the lists (the near side) and 73% baked; pop (mean normal difference between them)
    # 3.53°; median error against embree 0.0054° through the lists, 2.01° baked (a cell's
    # detail under one value). Bounds: 3x, and a third of the smaller share.
    assert (as_off | as_baked).mean() >= 0.99 and min(as_off.mean(), as_baked.mean()) >= 0.09
    assert pop <= 10.6, pop
    assert errors[0] <= 0.016 and errors[1] <= 6.0, errors
    # The face ids (surface pass) are always the lookup's.
    assert np.array_equal(before.face_id, after.face_id)
    with pytest.raises(gt.ParameterError, match="lod"):
        gt.igt.attach(igt, low.vertices, low.faces, lod="near")
    with pytest.raises(gt.ParameterError, match="lod"):
        gt.igt.attach(igt, low.vertices, low.faces, lod=-1.0)
