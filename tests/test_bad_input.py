"""Bad input gets a clear GeomtexError subclass naming what and where, and loses nothing."""

from __future__ import annotations

import numpy as np
import pytest

import geomtex as gt

V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.5]], dtype=np.float64)
F = np.array([[0, 1, 2], [1, 3, 2]])


def test_errors_form_one_tree() -> None:
    for cls in (gt.MeshError, gt.ParameterError, gt.FormatError, gt.FileError, gt.CancelledError, gt.DeviceError):
        assert issubclass(cls, gt.GeomtexError)
    assert issubclass(gt.MeshError, ValueError) and issubclass(gt.FileError, OSError)


@pytest.mark.parametrize(
    "vertices, faces, match",
    [
        (np.where(np.arange(12).reshape(4, 3) == 7, np.nan, V), F, r"vertex 2 has a non-finite y"),
        (np.where(np.arange(12).reshape(4, 3) == 3, np.inf, V), F, r"vertex 1 has a non-finite x"),
        (V, np.array([[0, 1, 2], [1, 3, 4]]), r"face 1 references vertex 4 but the mesh has 4 vertices"),
        (V, np.array([[0, 1, 2], [-1, 3, 2]]), r"face 1 has a negative vertex index \(-1\)"),
        (np.zeros((0, 3)), np.zeros((0, 3), int), r"no vertices"),
        (V, np.zeros((0, 3), int), r"no faces"),
        (V[:, :2], F, r"vertices must have shape \(N, 3\); got \(4, 2\)"),
        (V, F[:, :2], r"faces must have shape \(N, 3\)"),
        (V.ravel(), F, r"vertices must have shape"),
        (V.astype(np.complex128), F, r"real numbers; got dtype complex128"),
        (V.astype(str), F, r"real numbers"),
        (V, F + 0.5, r"integer indices; face 0"),
        ([[0, 0, 0], [1, 0]], F, r"could not be read as an array|must have shape"),
        (V, np.array([[0, 1, 2], [1, 2**63 + 5, 2]], dtype=np.uint64), r"face 1 references vertex"),
    ],
)
def test_bad_meshes_raise_mesh_error(vertices: object, faces: object, match: str) -> None:
    with pytest.raises(gt.MeshError, match=match):
        gt.Mesh(vertices, faces)


def test_vertex_colors_are_checked() -> None:
    with pytest.raises(gt.MeshError, match="3 rows but the mesh has 4"):
        gt.Mesh(V, F, np.zeros((3, 4), np.uint8))
    with pytest.raises(gt.MeshError, match=r"\[0, 255\]"):
        gt.Mesh(V, F, np.full((4, 3), 300))
    with pytest.raises(gt.MeshError, match="NaN"):
        gt.Mesh(V, F, np.full((4, 3), np.nan))
    rgb_float = gt.Mesh(V, F, np.full((4, 3), 0.5))
    assert np.array_equal(rgb_float.vertex_colors[0], [128, 128, 128, 255])


def test_accepted_dtypes_are_converted_without_loss() -> None:
    m = gt.Mesh(V.astype(np.float32), F.astype(np.uint16))
    assert m.vertices.dtype == np.float64 and m.faces.dtype == np.uint32
    assert np.array_equal(m.vertices, V) and np.array_equal(m.faces, F)
    # Non-contiguous views are fine too.
    big = np.zeros((4, 6))
    big[:, ::2] = V
    assert np.array_equal(gt.Mesh(big[:, ::2], F).vertices, V)


def test_degenerate_faces_are_reported_not_fatal() -> None:
    faces = np.vstack([F, [[0, 0, 1], [0, 1, 1]], [[0, 1, 2]]])  # 2 repeated-index faces + a duplicate
    v = np.vstack([V, [[2, 0, 0]]])
    faces = np.vstack([faces, [[0, 1, 4]]])  # collinear: zero area
    gts = gt.convert(gt.Mesh(v, faces))
    assert gts.stats["degenerate_faces"] == 3
    fp = gts.face_patch()
    # Degenerate faces are left out (-1); the others are in a patch or kept as triangles (-2).
    assert list(fp[[2, 3, 5]]) == [-1, -1, -1] and np.all((fp[[0, 1, 4]] >= 0) | (fp[[0, 1, 4]] == -2))


def test_all_degenerate_mesh_is_an_error() -> None:
    with pytest.raises(gt.MeshError, match="all 2 faces are degenerate"):
        gt.convert(gt.Mesh(V, [[0, 0, 1], [0, 1, 0]]))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(max_resolution=1), r"max_resolution must be in \[2, 4096\], got 1"),
        (dict(max_resolution=-5), r"max_resolution"),
        (dict(max_resolution=10**6), r"max_resolution"),
        (dict(max_resolution=2.5), r"max_resolution must be an integer"),
        (dict(max_resolution=True), r"max_resolution must be an integer"),
        (dict(texel_size=-1.0), r"texel_size must be a positive finite number"),
        (dict(texel_size=float("nan")), r"texel_size"),
        (dict(charts=0), r"charts must be at least 1"),
        (dict(charts=-3), r"charts must be >= 0"),
        (dict(chart_error=float("nan")), r"chart_error"),
        (dict(compactness=-1.0), r"compactness"),
        (dict(overlap_rings=-1), r"overlap_rings must be >= 0"),
        (dict(overlap_rings=99), r"overlap_rings must be at most 16"),
        (dict(dilation=1000), r"dilation must be at most 64"),
        (dict(frame="diagonal"), r"frame must be 'min_area' or 'pca'"),
        (dict(normals="bumpy"), r"normals must be 'crease', 'smooth' or 'flat'"),
        (dict(height_bits=12), r"height_bits must be 8 or 16, got 12"),
        (dict(height_bits=8.0), r"height_bits must be an integer"),
        (dict(progress="yes"), r"progress must be"),
    ],
)
def test_impossible_parameters_raise_parameter_error(kwargs: dict, match: str) -> None:
    with pytest.raises(gt.ParameterError, match=match):
        gt.convert(gt.Mesh(V, F), **kwargs)


def test_convert_rejects_what_is_not_a_mesh() -> None:
    with pytest.raises(gt.MeshError, match="expected a geomtex.Mesh"):
        gt.convert(42)


def test_broken_mesh_files(tmp_path) -> None:
    with pytest.raises(gt.FileError, match="no such mesh file"):
        gt.load_mesh(tmp_path / "missing.obj")
    (tmp_path / "empty.obj").write_text("")
    with pytest.raises(gt.FormatError, match="holds no triangles"):
        gt.load_mesh(tmp_path / "empty.obj")
    (tmp_path / "garbage.obj").write_bytes(bytes(range(256)) * 20)
    with pytest.raises(gt.FormatError):
        gt.load_mesh(tmp_path / "garbage.obj")
    (tmp_path / "badidx.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    with pytest.raises(gt.FormatError, match="badidx.obj"):
        gt.load_mesh(tmp_path / "badidx.obj")
    (tmp_path / "nan.obj").write_text("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(gt.MeshError, match=r"nan.obj: vertex 0 has a non-finite z"):
        gt.load_mesh(tmp_path / "nan.obj")


def test_truncated_binary_ply_is_a_format_error(tmp_path) -> None:
    import trimesh

    tm = trimesh.creation.icosphere(subdivisions=3)
    tm.export(tmp_path / "s.ply")
    data = (tmp_path / "s.ply").read_bytes()
    (tmp_path / "t.ply").write_bytes(data[: len(data) // 2])
    with pytest.raises(gt.FormatError, match="t.ply"):
        gt.load_mesh(tmp_path / "t.ply")
