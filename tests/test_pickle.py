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


# ---------------------------------------------------------------------------------------------
# Every kind, alone and in a scene: tiny objects, each compared after the trip by what it is
# made of (bytes or arrays) and by a frame rendered from it.

SIZE = (48, 40)


@pytest.fixture(scope="module")
def small_renderer() -> gt.Renderer:
    return gt.Renderer(*SIZE)


def _sphere() -> gt.Mesh:
    return gt.Mesh.from_trimesh(trimesh.creation.icosphere(2))


def _gdm_shell(lookup: bool = False) -> gt.gdm.Shell:
    from geomtex import gdm

    volume = gdm.Volume.procedural("chain", (16, 16, 8))
    table = volume.distance_function((4, 8), lower_bound=True).compress(2) if lookup else None
    return gdm.Shell(trimesh.creation.icosphere(1), volume, thickness=0.15, tiles=(2, 2), lookup=table,
                     color=(90, 160, 220, 255), pieces=3)


def _igt() -> gt.igt.InverseGeometricTexture:
    mesh = textured_sphere(rings=8, segments=16, texture_size=16)
    return gt.igt.build(mesh, resolution=32, attributes=["normals", "uv", "ao"], ao_rays=8)


_MAKERS = {
    "set": lambda: gt.convert(_sphere(), max_resolution=24),
    "mesh": lambda: face_colored(_sphere()),
    "surfels": lambda: gt.convert(_sphere(), max_resolution=24).to_surfels(),
    "igt": _igt,
    "igt-mesh": lambda: gt.igt.simplify(_igt(), 60, samples=5, lod=2.5),
    "gdm-volume": lambda: gt.gdm.Volume(gt.gdm.Volume.procedural("weave", (16, 16, 8)).occupancy,
                                        np.full((16, 16, 8, 4), 40, np.uint8)),
    "gdm-shell": lambda: _gdm_shell(lookup=True),
    "directional-light": lambda: gt.DirectionalLight((0.3, -1.0, -0.4)),
    "point-light": lambda: gt.PointLight((1.5, 2.0, 2.5)),
    "camera": lambda: gt.Camera.look_at((0.4, 0.6, 3.2), (0, 0, 0), yfov_deg=37.0),
}
_made: dict[str, object] = {}


def made(kind: str):
    if kind not in _made:
        _made[kind] = _MAKERS[kind]()
    return _made[kind]


def _camera() -> gt.Camera:
    return gt.Camera.look_at((0.4, 0.6, 3.2), (0, 0, 0), yfov_deg=37.0)


def _same_frames(a: gt.Frame, b: gt.Frame) -> None:
    for name in ("depth", "normal", "color", "albedo", "patch_id", "shadow", "face_id", "barycentric"):
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None and y is None) or np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name


def _parts(obj) -> list:
    """What an object is made of, as bytes, arrays and numbers to compare exactly."""
    if isinstance(obj, (gt.GeometryTextureSet, gt.Surfels, gt.igt.InverseGeometricTexture)):
        return [obj.to_bytes()]
    if isinstance(obj, gt.Mesh):
        return [obj.vertices, obj.faces, obj.vertex_colors, obj.face_colors, obj.uv, obj.texture]
    if isinstance(obj, gt.igt.IgtMesh):
        return [obj.igt.to_bytes(), obj.vertices, obj.faces, obj.face_grid, obj.lookup, obj.samples, obj.lod,
                obj.face_window]
    if isinstance(obj, gt.gdm.Volume):
        return [obj.size, obj.occupancy, obj._core.colors]
    if isinstance(obj, gt.gdm.Shell):
        lookup = obj.lookup
        return [obj.vertices, obj.normals, obj.faces, obj.uv, obj.thickness, obj.tiles, obj.color, obj.pieces,
                obj.refine, *_parts(obj.volume),
                *([] if lookup is None else [lookup.weights, lookup.eigen, lookup.shape, lookup.conservative])]
    if isinstance(obj, gt.DirectionalLight):
        return [obj.direction]
    if isinstance(obj, gt.PointLight):
        return [obj.position]
    if isinstance(obj, gt.Camera):
        kind, pose, numbers, near = obj._state()
        return [kind, pose, numbers, near]
    raise AssertionError(type(obj))


def _assert_same_parts(a, b) -> None:
    assert type(b) is type(a)
    pa, pb = _parts(a), _parts(b)
    assert len(pa) == len(pb)
    for k, (x, y) in enumerate(zip(pa, pb)):
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y), k
        else:
            assert type(x) is type(y) and x == y, k


def _render(renderer: gt.Renderer, kind: str, obj) -> gt.Frame:
    """A frame that depends on `obj`: drawn itself, or what it makes (a volume's shell, a texture's
    simplified mesh), or lighting / viewing a sphere."""
    if kind in ("directional-light", "point-light"):
        scene = gt.Scene()
        scene.add(_sphere())
        scene.add(trimesh.creation.box(extents=(3, 0.1, 3)), np.array(
            [[1, 0, 0, 0], [0, 1, 0, -1.3], [0, 0, 1, 0], [0, 0, 0, 1.0]]))
        frame = renderer.render(scene, _camera(), light=obj)
        assert frame.shadow is not None and frame.shadow.any()
        return frame
    if kind == "camera":
        return renderer.render(_sphere(), obj)
    if kind == "igt":
        return renderer.render(gt.igt.attach(obj, *_sphere_like(obj)), _camera())
    if kind == "gdm-volume":
        return renderer.render(gt.gdm.Shell(trimesh.creation.icosphere(1), obj, thickness=0.15), _camera())
    return renderer.render(obj, _camera())


def _sphere_like(igt) -> tuple[np.ndarray, np.ndarray]:
    """The texture's own detailed mesh, to shade through it."""
    return igt.vertices, igt.faces


@pytest.mark.parametrize("kind", list(_MAKERS))
def test_every_kind_round_trips_alone(kind: str, small_renderer: gt.Renderer) -> None:
    obj = made(kind)
    back = trip(obj)
    _assert_same_parts(obj, back)
    frame = _render(small_renderer, kind, obj)
    assert np.isfinite(frame.depth).any(), "the frame shows nothing to compare"
    _same_frames(_render(small_renderer, kind, back), frame)


_IN_SCENES = ["set", "mesh", "surfels", "igt-mesh", "gdm-shell"]


@pytest.mark.parametrize("kind", _IN_SCENES)
def test_a_scene_holding_each_kind_round_trips(kind: str, small_renderer: gt.Renderer) -> None:
    obj = made(kind)
    pose = np.array([[0.8, 0, 0.6, 0.1], [0, 1, 0, -0.05], [-0.6, 0, 0.8, 0.02], [0, 0, 0, 1.0]])
    scene = gt.Scene()
    options = {"normals": "flat"} if kind == "mesh" else {}
    scene.add(obj, pose, **options)
    # A second object, so placements and ids are checked beside it.
    box = trimesh.creation.box(extents=(0.4, 0.4, 0.4))
    scene.add(box, trimesh.transformations.translation_matrix((0.9, 0.5, 0.3)))
    back = trip(scene)
    assert isinstance(back, gt.Scene) and len(back) == len(scene) == 2
    for (a, pa, na, ca), (b, pb, nb, cb) in zip(scene._objects(), back._objects()):
        _assert_same_parts(a, b)
        assert np.array_equal(pa, pb) and (na, ca) == (nb, cb)
    light = gt.DirectionalLight((0.3, -1.0, -0.4))
    frame = small_renderer.render(scene, _camera(), light=light)
    assert np.isfinite(frame.depth).sum() > 100
    _same_frames(small_renderer.render(back, _camera(), light=light), frame)
    _same_frames(trip(frame), frame)


def test_a_scene_gives_back_the_shell_it_was_given(small_renderer: gt.Renderer) -> None:
    """A scene keeps a gdm.Shell as the shell (not the extension's copy it draws), so the shell
    comes back from a pickled scene whole: its volume, lookup table and base mesh."""
    shell = made("gdm-shell")
    scene = gt.Scene()
    scene.add(shell)
    scene.add(shell, np.diag([0.5, 0.5, 0.5, 1.0]))
    back = trip(scene)
    first, second = back._objects()[0][0], back._objects()[1][0]
    assert type(first) is gt.gdm.Shell and first is second  # added twice, stored once
    _assert_same_parts(shell, first)
    assert repr(back) == repr(scene) == "<geomtex.Scene 2 GDM shells>"
    _same_frames(small_renderer.render(back, _camera()), small_renderer.render(scene, _camera()))
