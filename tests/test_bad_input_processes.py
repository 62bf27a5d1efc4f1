"""The bad-input suite, one child process per case: every bad input to the public API raises the
documented GeomtexError subclass with a message naming what and where, and never crashes the
interpreter (an abort or a panic kills only its child and fails its case); where a file would be
written, nothing is left behind. Valid input in the other forms numpy/trimesh users pass must
simply work, and give what the canonical form gives.

All children run at once (one per core) from one fixture; each imports only geomtex and numpy
(plus trimesh where the case needs it) and uses an 8 x 8-cell sheet and 32 x 32 images, so the
whole suite adds about 15 s on 2 cores. Each child runs under an 8 GiB address-space limit, so a
runaway allocation fails fast instead of swapping.
"""

from __future__ import annotations

import json
import os
import re
import resource
import subprocess
import sys
import textwrap
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, NamedTuple

import pytest

import geomtex as gt
from geomtex.testing.shapes import wavy_sheet

# Every child starts with this: the sheet the shared .gtex was converted from (4 charts), a
# camera that sees it, and helpers to rewrite a .gtex payload with a valid checksum.
PRELUDE = """
import json, os, struct, sys, zlib
import numpy as np
import geomtex as gt
from geomtex.testing.shapes import wavy_sheet
D, GTEX = sys.argv[1], sys.argv[2]
SHEET = wavy_sheet(8)
CAM = gt.Camera.look_at([0, 0, 3], [0, 0, 0])
V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.5]])
F = np.array([[0, 1, 2], [1, 3, 2]])

def sealed(payload):
    # A .gtex header (version 3) around `payload`, with its true CRC-32.
    head = open(GTEX, "rb").read()[:12]
    return head + struct.pack("<IQII", 0, len(payload), zlib.crc32(payload), 0) + payload

def patch_at(data):
    # Offset of patch 0's origin in a .gtex file (layout in src/gtex/file.rs).
    pos = 32 + 8
    for per_patch in (False, False, True):
        (count,) = struct.unpack_from("<I", data, pos); pos += 4
        for _ in range(count):
            (n,) = struct.unpack_from("<H", data, pos); pos += 2 + n
            if per_patch:
                (k,) = struct.unpack_from("<I", data, pos); pos += 4 + 8 * k
            else:
                pos += 8
    return pos + 4  # past the patch count

def crafted(edit):
    # The shared set's bytes after `edit(bytearray payload, offset of patch 0 in it)`, resealed.
    data = open(GTEX, "rb").read()
    payload = bytearray(data[32:])
    edit(payload, patch_at(data) - 32)
    path = os.path.join(D, "crafted.gtex")
    open(path, "wb").write(sealed(bytes(payload)))
    return path
"""

RUNNER = """
try:
{body}
except gt.GeomtexError as e:
    print(json.dumps({{"raised": type(e).__name__, "message": str(e)}}))
except BaseException as e:
    print(json.dumps({{"raised": "not a GeomtexError: " + type(e).__name__, "message": repr(e)}}))
else:
    print(json.dumps({{"raised": None, "message": ""}}))
"""


class Case(NamedTuple):
    name: str
    code: str
    raises: str | None  # the GeomtexError subclass, or None: valid input that must work
    match: str = ""  # regex the message must contain
    leaves_nothing: str = ""  # a file name in D that must not exist afterwards


def bad(name: str, code: str, raises: str, match: str, **kw: Any) -> Case:
    return Case(name, code, raises, match, **kw)


def ok(name: str, code: str) -> Case:
    return Case(name, code, None)


CASES = [
    # --- meshes
    bad("mesh_nan_vertex", "gt.Mesh(np.where(np.arange(12).reshape(4, 3) == 7, np.nan, V), F)",
        "MeshError", r"vertex 2 has a non-finite y"),
    bad("mesh_index_past_end", "gt.Mesh(V, [[0, 1, 2], [1, 3, 4]])",
        "MeshError", r"face 1 references vertex 4 but the mesh has 4 vertices"),
    bad("mesh_negative_index", "gt.Mesh(V, [[0, 1, 2], [-1, 3, 2]])", "MeshError", r"face 1 has a negative"),
    bad("mesh_no_faces", "gt.convert(gt.Mesh(V, np.zeros((0, 3), int)))", "MeshError", r"no faces"),
    bad("mesh_ragged_list", "gt.Mesh([[0, 0, 0], [1, 0]], F)", "MeshError", r"vertices"),
    bad("mesh_strings", "gt.Mesh(V.astype(str), F)", "MeshError", r"vertices must hold real numbers"),
    bad("mesh_all_degenerate", "gt.convert(gt.Mesh(V, [[0, 0, 1], [0, 1, 0]]))",
        "MeshError", r"all 2 faces are degenerate"),
    bad("mesh_colors_256", "gt.Mesh(V, F, np.full((4, 3), 256))", "MeshError", r"vertex_colors.*\[0, 255\]"),
    bad("mesh_not_a_mesh", "gt.convert(42)", "MeshError", r"expected a geomtex.Mesh.*got int"),
    bad("mesh_empty_trimesh_scene", "import trimesh; gt.convert(trimesh.Scene())",
        "MeshError", r"trimesh.Scene holds no triangles"),
    bad("mesh_scene_of_points", "import trimesh; gt.as_mesh(trimesh.Scene([trimesh.PointCloud(V)]))",
        "MeshError", r"holds no triangles \(it holds PointCloud\)"),
    # --- files
    bad("file_missing", "gt.load(os.path.join(D, 'nope.gtex'))", "FileError", r"no such file: .*nope.gtex"),
    bad("file_not_gtex", "open(D + '/t.gtex', 'w').write('hello' * 20); gt.load(D + '/t.gtex')",
        "FormatError", r"t.gtex: not a .gtex"),
    bad("file_truncated", "d = open(GTEX, 'rb').read(); open(D + '/t.gtex', 'wb').write(d[:len(d) // 2]);"
        " gt.load(D + '/t.gtex')", "FormatError", r"t.gtex.*truncated"),
    bad("file_bad_checksum", "d = bytearray(open(GTEX, 'rb').read()); d[100] ^= 1;"
        " open(D + '/t.gtex', 'wb').write(d); gt.load(D + '/t.gtex')", "FormatError", r"t.gtex.*checksum"),
    bad("file_sealed_huge_patch_count",
        "gt.load(crafted(lambda p, at: struct.pack_into('<I', p, at - 4, 2**32 - 1)))",
        "FormatError", r"crafted.gtex"),
    bad("file_sealed_huge_patch_size",
        "gt.load(crafted(lambda p, at: struct.pack_into('<II', p, at + 120, 60000, 60000)))",
        "FormatError", r"crafted.gtex"),
    bad("file_sealed_nan_origin",
        "gt.load(crafted(lambda p, at: struct.pack_into('<d', p, at, float('nan'))))",
        "FormatError", r"crafted.gtex"),
    bad("file_sealed_zero_width",
        "gt.load(crafted(lambda p, at: struct.pack_into('<I', p, at + 120, 0)))",
        "FormatError", r"crafted.gtex"),
    bad("file_sealed_face_past_source",
        "gt.load(crafted(lambda p, at: struct.pack_into('<I', p, at + 140, 2**31)))",
        "FormatError", r"crafted.gtex"),
    bad("file_save_into_missing_folder", "gt.load(GTEX).save(os.path.join(D, 'no_dir', 'x.gtex'))",
        "FileError", r"no_dir"),
    bad("file_frame_unknown_extension",
        "gt.Renderer(32, 32).render(gt.load(GTEX), CAM).save(os.path.join(D, 'frame.xyz'))",
        "ParameterError", r"frame.xyz.*'.xyz' names no image format", leaves_nothing="frame.xyz"),
    bad("file_gtex_over_a_folder", "os.mkdir(D + '/taken.gtex'); gt.load(GTEX).save(D + '/taken.gtex')",
        "FileError", r"taken.gtex"),
    bad("file_path_not_a_path", "gt.load(3)", "ParameterError", r"path must be a str or os.PathLike, got 3"),
    bad("file_mesh_path_not_a_path", "gt.load_mesh(3.5)", "ParameterError", r"path must be .*got 3.5"),
    bad("mesh_from_trimesh_of_a_number", "gt.Mesh.from_trimesh(7)", "MeshError", r"expected a trimesh.*got int"),
    bad("file_mesh_garbage", "open(D + '/g.obj', 'wb').write(bytes(range(256)) * 20); gt.load_mesh(D + '/g.obj')",
        "FormatError", r"g.obj"),
    # --- cameras
    bad("camera_rays_100000_squared", "CAM.rays(100000, 100000)",
        "ParameterError", r"width must be an integer in \[1, 16384\], got 100000"),
    bad("camera_rays_past_count", "CAM.rays(16384, 8192)",
        "ParameterError", r"16384 x 8192 = 134217728 pixels exceeds the limit of 67108864"),
    bad("camera_rays_negative", "CAM.rays(-1, 4)", "ParameterError", r"width .*got -1"),
    bad("camera_ortho_near_nan", "gt.Camera.orthographic(np.eye(4), 1.0, near=float('nan'))",
        "ParameterError", r"near must be positive, got NaN"),
    bad("camera_pose_nan", "gt.Camera.orthographic(np.full((4, 4), np.nan), 1.0)",
        "ParameterError", r"world_from_camera must be finite"),
    bad("camera_pose_inf", "gt.Camera.from_intrinsics(np.eye(3), np.diag([1, 1, np.inf, 1]), 32, 32)",
        "ParameterError", r"world_from_camera must be finite"),
    bad("camera_fov_nan", "gt.Camera.look_at([0, 0, 3], [0, 0, 0], yfov_deg=float('nan'))",
        "ParameterError", r"yfov_deg must be in \(0, 180\), got NaN"),
    bad("camera_zero_width", "gt.Camera.from_intrinsics(np.eye(3), np.eye(4), 0, 32)",
        "ParameterError", r"width must be an integer in \[1, 16384\], got 0"),
    bad("camera_K_shape", "gt.Camera.from_intrinsics(np.eye(2), np.eye(4), 32, 32)",
        "ParameterError", r"K must be an array of real numbers of shape \(3, 3\)"),
    bad("camera_eye_text", "gt.Camera.look_at('abc', [0, 0, 0])", "ParameterError", r"eye must be .*got 'abc'"),
    bad("camera_up_bools", "gt.Camera.look_at([0, 0, 3], [0, 0, 0], up=[True, False, False])",
        "ParameterError", r"up must be an array of real numbers"),
    # --- scenes
    bad("scene_pose_nan", "gt.Scene().add(gt.load(GTEX), np.full((4, 4), np.nan))",
        "ParameterError", r"world_from_object must be finite"),
    bad("scene_pose_3x3", "gt.Scene().add(gt.load(GTEX), np.eye(3))",
        "ParameterError", r"world_from_object must be an array of real numbers of shape \(4, 4\)"),
    bad("scene_add_number", "gt.Scene().add(42)", "MeshError", r"expected a geomtex.Mesh"),
    # --- renders
    bad("render_background_256", "gt.Renderer(32, 32).render(gt.load(GTEX), CAM, background=(256, 0, 0, 0))",
        "ParameterError", r"background must be four integers in \[0, 255\].*got \(256, 0, 0, 0\)"),
    bad("render_background_three", "gt.Renderer(32, 32).render(gt.load(GTEX), CAM, background=[255, 0, 0])",
        "ParameterError", r"background must be four integers"),
    bad("render_quality_number", "gt.Renderer(32, 32).render(gt.load(GTEX), CAM, quality=3)",
        "ParameterError", r"quality must be a str, got 3"),
    bad("render_quality_unknown", "gt.Renderer(32, 32).render(gt.load(GTEX), CAM, quality='best')",
        "ParameterError", r"quality.*best"),
    bad("render_camera_not_camera", "gt.Renderer(32, 32).render(gt.load(GTEX), 'cam')",
        "ParameterError", r"camera must be a geomtex.Camera, got str"),
    bad("render_size_float", "gt.Renderer(2.5, 32)", "ParameterError", r"width must be an integer.*got 2.5"),
    bad("render_size_huge", "gt.Renderer(32, 100000)", "ParameterError", r"height must be .*got 100000"),
    bad("render_steps_negative", "gt.Renderer(32, 32).render(gt.load(GTEX), CAM, min_linear_steps=-1)",
        "ParameterError", r"min_linear_steps must be an integer in \[0, 4294967295\], got -1"),
    bad("render_lod_text", "gt.Renderer(32, 32).render(gt.load(GTEX), CAM, lod='yes')",
        "ParameterError", r"lod must be True or False, got 'yes'"),
    # --- conversion keywords
    bad("convert_resolution_16384", "gt.convert(SHEET, max_resolution=16384)",
        "ParameterError", r"max_resolution must be in \[2, 4096\], got 16384"),
    bad("convert_charts_1e30", "gt.convert(SHEET, charts=10**30)", "ParameterError", r"charts is out of range"),
    bad("convert_frame_number", "gt.convert(SHEET, frame=3)", "ParameterError", r"frame must be a str, got 3"),
    bad("grids_resolution_8192", "gt.GeometryTextureSet.from_heightmaps(np.zeros((4, 4)), (0, 1, 0, 1),"
        " max_resolution=8192)", "ParameterError", r"max_resolution must be in \[2, 4096\], got 8192"),
    bad("grids_cmap_unknown", "gt.GeometryTextureSet.from_heightmaps(np.zeros((4, 4)), (0, 1, 0, 1),"
        " properties=np.zeros((4, 4)), cmap='no-such')", "ParameterError", r"cmap .*'no-such'"),
    bad("grids_extent_nan", "gt.GeometryTextureSet.from_heightmaps(np.zeros((4, 4)), (0, np.nan, 0, 1))",
        "ParameterError", r"extent must be finite"),
    # --- sets and filters
    bad("filter_sigma_text", "gt.load(GTEX).filtered('gaussian', 'a')", "ParameterError", r"sigma must be a number"),
    bad("filter_kind_number", "gt.load(GTEX).filtered(3, 0.1)", "ParameterError", r"kind must be a str, got 3"),
    bad("filter_kind_unknown", "gt.load(GTEX).filtered('median', 0.1)", "ParameterError", r"median"),
    bad("seams_unrelated_mesh", "gt.load(GTEX).seam_gaps(gt.Mesh(V, F))",
        "ParameterError", r"mesh has 2 faces, the set's source had 128: not the mesh it was converted from"),
    bad("seams_moved_mesh", "gt.load(GTEX).seam_gaps(gt.Mesh(SHEET.vertices + [5, 0, 0], SHEET.faces))",
        "ParameterError", r"sampled faces lie outside the boxes.*not the mesh it was"),
    bad("seams_grid_set", "gt.GeometryTextureSet.from_heightmaps(np.zeros((4, 4)), (0, 1, 0, 1)).seam_gaps(SHEET)",
        "ParameterError", r"no source face count"),
    bad("patch_index_float", "gt.load(GTEX).patch(1.5)", "ParameterError", r"index must be an integer, got 1.5"),
    bad("first_hits_ragged", "gt.load(GTEX).first_hits([[0, 0, 1], [0, 0]], [[0, 0, -1]])",
        "ParameterError", r"origins must be an array of real numbers of shape \(N, 3\)"),
    # --- valid input in other forms: must work and agree with the canonical form
    ok("valid_camera_lists_and_numpy_scalars", """
        a = gt.Camera.look_at(np.array([0.0, 0, 3]), np.zeros(3), up=(0.0, 1.0, 0.0), yfov_deg=40.0)
        b = gt.Camera.look_at([0, 0, 3], np.array([0, 0, 0], np.int32), up=[0, 1, 0], yfov_deg=np.float32(40))
        assert np.abs(a.world_from_camera - b.world_from_camera).max() <= 1e-12
        assert np.abs(a.rays(8, 8)[1] - b.rays(np.int64(8), np.uint32(8))[1]).max() <= 1e-6
    """),
    ok("valid_integer_K_and_float32_pose", """
        K = np.array([[40.0, 0, 16], [0, 40, 16], [0, 0, 1]]); P = np.diag([1.0, -1, -1, 1]); P[2, 3] = 3
        a = gt.Camera.from_intrinsics(K, P, 32, 32)
        b = gt.Camera.from_intrinsics(K.astype(int).tolist(), P.astype(np.float32), np.int64(32), 32)
        assert np.abs(a.rays(32, 32)[1] - b.rays(32, 32)[1]).max() <= 1e-12
    """),
    ok("valid_background_as_list_and_array", """
        r, s = gt.Renderer(np.int64(32), np.int32(32)), gt.load(GTEX)
        far = gt.Camera.look_at([0, 0, 3], [50, 0, 0])  # sees nothing: every pixel is background
        for bg in ([255, 0, 0, 255], np.array([255, 0, 0, 255], np.uint8), (np.int64(255), 0, 0, 255)):
            assert (r.render(s, far, background=bg).color == [255, 0, 0, 255]).all()
    """),
    ok("valid_float32_world_from_object", """
        r, s = gt.Renderer(32, 32), gt.load(GTEX)
        T = np.eye(4); T[0, 3] = 0.25
        depth = []
        for pose in (T, T.astype(np.float32), T.tolist()):
            scene = gt.Scene(); scene.add(s, pose); depth.append(r.render(scene, CAM).depth)
        hit = np.isfinite(depth[0])
        assert hit.sum() > 100 and all(np.array_equal(hit, np.isfinite(d)) for d in depth)
        assert max(np.abs(d[hit] - depth[0][hit]).max() for d in depth) <= 1e-6
    """),
    ok("valid_trimesh_scene_flattened", """
        import trimesh
        a, b = SHEET.to_trimesh(), SHEET.to_trimesh()
        scene = trimesh.Scene()
        scene.add_geometry(a); scene.add_geometry(b, transform=trimesh.transformations.translation_matrix([3, 0, 0]))
        m = gt.as_mesh(scene)
        assert m.n_faces == 256 and abs(m.bounds[1][0] - 4.0) <= 1e-12
        s = gt.convert(scene, max_resolution=np.int64(16))
        assert s.stats["faces"] == 256 and s.stats["patch_resolution"].dtype == np.uint32
        assert s.stats["patch_resolution"].max() <= 16
        assert gt.Renderer(32, 32).render(scene, gt.Camera.look_at([2, 0, 6], [2, 0, 0])).stats["meshes_drawn"] == 1
    """),
    ok("valid_seam_gaps_from_trimesh_and_path", """
        s = gt.load(GTEX)
        SHEET.to_trimesh().export(D + '/sheet.ply')
        g = [s.seam_gaps(SHEET), s.seam_gaps(SHEET.to_trimesh()), s.seam_gaps(D + '/sheet.ply')]
        assert len(g[0]) > 0 and np.array_equal(g[0], g[1])
        assert np.abs(g[0] - g[2]).max() <= 1e-6  # the PLY holds float32 positions
    """),
    ok("valid_colormap_object", """
        import matplotlib
        z = np.arange(16.0).reshape(4, 4)
        by_name = gt.GeometryTextureSet.from_heightmaps(z, (0, 1, 0, 1), properties=z, cmap='magma')
        by_map = gt.GeometryTextureSet.from_heightmaps(z, [0, 1, 0, 1], properties=z,
                                                       cmap=matplotlib.colormaps['magma'], max_resolution=np.int64(256))
        assert np.array_equal(by_name.patch(0)['color'], by_map.patch(np.int64(0))['color'])
    """),
    ok("valid_previews_of_every_kind_of_set", """
        s = gt.load(GTEX)
        grid = gt.GeometryTextureSet.from_heightmaps(np.random.default_rng(0).random((16, 16)), (0, 1, 0, 1))
        grid.save(D + '/grid.gtex')
        for each in (s, s.filtered('gaussian', 2 * s.texel_size), grid, gt.load(D + '/grid.gtex')):
            assert each._repr_png_()[:8] == bytes([137, 80, 78, 71, 13, 10, 26, 10])
    """),
    ok("valid_saves_in_named_format_with_umask", """
        from PIL import Image
        os.umask(0o022)
        frame = gt.Renderer(32, 32).render(gt.load(GTEX), CAM)
        for name, fmt in (('f.jpg', 'JPEG'), ('f.JPEG', 'JPEG'), ('f.png', 'PNG')):
            frame.save(os.path.join(D, name))
            assert Image.open(os.path.join(D, name)).format == fmt
        gt.load(GTEX).save(D + '/copy.gtex')
        modes = {n: os.stat(os.path.join(D, n)).st_mode & 0o777 for n in ('f.jpg', 'f.png', 'copy.gtex')}
        assert set(modes.values()) == {0o644}, modes
        assert sorted(os.listdir(D)) == ['copy.gtex', 'f.JPEG', 'f.jpg', 'f.png'], os.listdir(D)
    """),
]


class Outcome(NamedTuple):
    returncode: int
    result: dict[str, Any] | None
    stderr: str
    leftovers: list[str]


def _limit_memory() -> None:
    limit = 8 << 30
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))


def _run(case: Case, root: Path, gtex: Path) -> Outcome:
    folder = root / case.name
    folder.mkdir()
    body = textwrap.indent(textwrap.dedent(case.code).strip(), "    ")
    script = PRELUDE + RUNNER.format(body=body)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    proc = subprocess.run([sys.executable, "-c", script, str(folder), str(gtex)], capture_output=True, text=True,
                          timeout=120, env=env, preexec_fn=_limit_memory)
    lines = proc.stdout.strip().splitlines()
    result = json.loads(lines[-1]) if proc.returncode == 0 and lines else None
    # Both writers name their temporary files with a leading dot.
    leftovers = sorted(n for n in os.listdir(folder) if n.startswith(".") or n == case.leaves_nothing)
    return Outcome(proc.returncode, result, proc.stderr[-2000:], leftovers)


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Outcome]:
    root = tmp_path_factory.mktemp("bad_input")
    gtex = root / "sheet.gtex"
    gt.convert(wavy_sheet(8), max_resolution=16, charts=4).save(gtex)
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
        runs = {c.name: pool.submit(_run, c, root, gtex) for c in CASES}
        return {name: run.result() for name, run in runs.items()}


@pytest.mark.parametrize("case", [pytest.param(c, id=c.name) for c in CASES])
def test_case_in_its_own_process(case: Case, outcomes: dict[str, Outcome]) -> None:
    out = outcomes[case.name]
    assert out.returncode == 0, f"the child died (exit {out.returncode}):\n{out.stderr}"
    assert out.result is not None, out.stderr
    assert out.result["raised"] == case.raises, out.result["message"] or out.stderr
    if case.raises:
        assert re.search(case.match, out.result["message"]), out.result["message"]
    assert out.leftovers == [], f"left behind: {out.leftovers}"


def test_suite_is_large_enough() -> None:
    assert sum(c.raises is not None for c in CASES) >= 40 and sum(c.raises is None for c in CASES) >= 5
