"""Pickling of every public object: exact round trips (a set's .gtex bytes, a mesh's arrays, a
camera's numbers, a frame's arrays), scenes that render the same after the trip, a renderer
made anew, and damaged pickles refused with a GeomtexError."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import trimesh

import geomtex as gt
from geomtex.testing import look_from
from geomtex.testing.shapes import face_colored, textured_sphere


def trip(obj):
    return pickle.loads(pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL))


def test_sets_travel_as_their_gtex_bytes(bunny) -> None:
    data = pickle.dumps(bunny.gts)
    back = pickle.loads(data)
    assert back.to_bytes() == bunny.gts.to_bytes()
    assert len(data) < len(bunny.gts.to_bytes()) + 200  # the file's bytes and a few of pickle's
    assert np.array_equal(back.world_from_patch, bunny.gts.world_from_patch)
    points, normals = back.to_points()
    assert np.array_equal(points, bunny.points) and np.array_equal(normals, bunny.normals)
    assert back.stats.keys() == bunny.gts.stats.keys() and back.stats["seconds"] == {}
    for name, value in bunny.gts.stats.items():
        if name != "seconds":
            assert np.array_equal(back.stats[name], value, equal_nan=isinstance(value, float)), name


def test_files_are_a_function_of_mesh_and_options() -> None:
    mesh = trimesh.creation.icosphere(3)
    assert gt.convert(mesh, max_resolution=32).to_bytes() == gt.convert(mesh, max_resolution=32).to_bytes()


@pytest.mark.parametrize("make", [lambda: gt.Mesh.from_trimesh(trimesh.creation.icosphere(2)),
                                  lambda: face_colored(gt.Mesh.from_trimesh(trimesh.creation.box())),
                                  lambda: textured_sphere(rings=8, segments=16, texture_size=32)],
                         ids=["plain", "face-colors", "textured"])
def test_meshes_travel_as_their_arrays(make) -> None:
    mesh = make()
    back = trip(mesh)
    assert type(back) is gt.Mesh
    for name in ("vertices", "faces", "vertex_colors", "face_colors", "uv", "texture"):
        a, b = getattr(mesh, name), getattr(back, name)
        assert (a is None and b is None) or (a.dtype == b.dtype and np.array_equal(a, b)), name


def test_cameras_travel_exactly() -> None:
    cameras = [gt.Camera.look_at((0.3, 0.2, 3.0), (0, 0, 0), yfov_deg=33.3),
               gt.Camera.look_at((1e6, 2, 3), (1e6, 0, 0), near=0.01),
               gt.Camera.from_intrinsics([[20.5, 0, 8.25], [0, 19.0, 5.5], [0, 0, 1]], np.eye(4), 16, 12),
               gt.Camera.orthographic(np.eye(4), 1.25)]
    for camera in cameras:
        back = trip(camera)
        assert back.kind == camera.kind
        assert np.array_equal(back.world_from_camera, camera.world_from_camera)
        assert back._state()[2:] == camera._state()[2:]
        o1, d1 = camera.rays(16, 12)
        o2, d2 = back.rays(16, 12)
        assert np.array_equal(o1, o2) and np.array_equal(d1, d2)


def test_scenes_frames_and_renderers_render_the_same_after_the_trip(bunny) -> None:
    scene = gt.Scene()
    scene.add(bunny.gts)
    scene.add(bunny.gts, np.diag([0.5, 0.5, 0.5, 1.0]))
    scene.add(trimesh.creation.box(extents=(0.05, 0.05, 0.05)), normals="flat")
    data = pickle.dumps(scene)
    assert len(data) < 1.2 * len(bunny.gts.to_bytes())  # the set added twice is stored once
    camera = look_from(bunny.mesh, (0.3, 0.5, 1.0))
    renderer = gt.Renderer(96, 72)
    frame = renderer.render(scene, camera, light=gt.DirectionalLight((0.2, -1.0, -0.3)))
    again = trip(renderer).render(trip(scene), trip(camera), light=gt.DirectionalLight((0.2, -1.0, -0.3)))
    for name in ("depth", "normal", "color", "albedo", "patch_id", "shadow"):
        assert np.array_equal(getattr(again, name), getattr(frame, name)), name
    back = trip(frame)
    for name in ("depth", "normal", "color", "albedo", "patch_id", "shadow"):
        assert np.array_equal(getattr(back, name), getattr(frame, name)), name
    assert back.stats.keys() == frame.stats.keys()
    assert (back.depth.dtype, back.patch_id.dtype, back.color.dtype) == (np.float32, np.int32, np.uint8)


def test_damaged_pickles_are_refused() -> None:
    with pytest.raises(gt.FormatError, match="from_bytes"):
        gt.GeometryTextureSet.from_bytes(b"GTEX\r\n\x1a\n" + b"\0" * 40)
    with pytest.raises(gt.ParameterError, match="rigid"):
        gt.Camera._from_state("perspective", np.diag([2.0, 1, 1, 1]), [0.7], None)
    with pytest.raises(gt.ParameterError, match="projection"):
        gt.Camera._from_state("perspective", np.eye(4), [4.0], None)
    with pytest.raises(gt.ParameterError, match="camera state"):
        gt.Camera._from_state("fisheye", np.eye(4), [1.0], None)
    with pytest.raises(gt.ParameterError, match="near"):
        gt.Camera._from_state("orthographic", np.eye(4), [1.0], -1.0)
    z = np.zeros
    with pytest.raises(gt.ParameterError, match="4x3 frame"):
        gt.Frame._from_arrays(z((3, 4, 4), np.uint8), z((3, 4, 4), np.uint8), z((3, 4), np.float32),
                              z((3, 4, 3), np.float32), z((3, 5), np.int32), None, {})
