"""The kinds table (geomtex._kinds): every kind a Scene draws pickles, reports stats, counts in a
scene's repr and renders through its row of the table; a toy kind registered here with one call
(analytic spheres, drawn by the extension as icosphere meshes) does all of that too."""

from __future__ import annotations

import pickle
from dataclasses import astuple, dataclass
from types import BuiltinFunctionType, FunctionType
from typing import Any, Callable

import numpy as np
import pytest
import trimesh

import geomtex as gt
from geomtex import _core
from geomtex._kinds import KINDS, kind_of, register
from geomtex.testing.shapes import face_colored

SIZE = 32


@dataclass
class Spheres:
    """A toy kind: analytic spheres, `centres` (N, 3) and `radii` (N,)."""

    centres: np.ndarray
    radii: np.ndarray

    def to_mesh(self) -> gt.Mesh:
        """What the extension draws: each sphere as an icosphere of 320 faces, placed."""
        ball = trimesh.creation.icosphere(2)
        vertices = np.concatenate([ball.vertices * r + c for c, r in zip(self.centres, self.radii)])
        faces = np.concatenate([ball.faces + k * len(ball.vertices) for k in range(len(self.radii))])
        return gt.Mesh(vertices, faces)

    def stats(self) -> dict[str, Any]:
        return {"spheres": len(self.radii), "largest_radius": float(self.radii.max())}


register("sphere group", Spheres, _core.Mesh, Spheres.to_mesh, reduce=astuple, restore=Spheres, stats=Spheres.stats)


def _sphere() -> gt.Mesh:
    return gt.Mesh.from_trimesh(trimesh.creation.icosphere(2))


def _shell() -> gt.gdm.Shell:
    volume = gt.gdm.Volume.procedural("lattice", (16, 16, 8))
    return gt.gdm.Shell(trimesh.creation.icosphere(1), volume, thickness=0.15, tiles=(2, 2))


def _igt_mesh() -> gt.igt.IgtMesh:
    texture = gt.igt.build(_sphere(), resolution=32)
    return gt.igt.attach(texture, texture.vertices, texture.faces, lookup="projection")


#: One small object per kind, made once; a kind registered without a sample fails the first test.
_SAMPLES: dict[str, Callable[[], Any]] = {
    "set": lambda: gt.convert(_sphere(), max_resolution=24),
    "mesh": lambda: face_colored(_sphere()),
    "surfels": lambda: gt.convert(_sphere(), max_resolution=24).to_surfels(),
    "igt_mesh": _igt_mesh,
    "gdm_shell": _shell,
    "sphere group": lambda: Spheres(np.array([[-0.45, 0.0, 0.0], [0.55, 0.2, 0.1]]), np.array([0.5, 0.35])),
}
_made: dict[str, Any] = {}


def sample(name: str) -> Any:
    if name not in _made:
        _made[name] = _SAMPLES[name]()
    return _made[name]


@pytest.fixture(scope="module")
def renderer() -> gt.Renderer:
    return gt.Renderer(SIZE, SIZE)


def _camera() -> gt.Camera:
    return gt.Camera.look_at((0.4, 0.6, 3.2), (0, 0, 0), yfov_deg=37.0)


def _same(a: Any, b: Any) -> None:
    """`a` and `b` are made of the same things: equal arrays (dtype, shape, values), bytes and
    numbers, the same functions and classes, other objects compared by what they pickle as."""
    assert type(a) is type(b), (type(a), type(b))
    if isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind in "fc")
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            _same(x, y)
    elif isinstance(a, dict):
        assert a.keys() == b.keys()
        for key in a:
            _same(a[key], b[key])
    elif isinstance(a, (type, FunctionType, BuiltinFunctionType)):
        assert a is b
    elif isinstance(a, (str, bytes, int, float, np.generic, type(None))):
        assert a == b or (a != a and b != b), (a, b)  # NaN equals NaN here
    else:
        _same(a.__reduce_ex__(pickle.HIGHEST_PROTOCOL), b.__reduce_ex__(pickle.HIGHEST_PROTOCOL))


def test_every_kind_has_a_sample() -> None:
    assert set(_SAMPLES) == set(KINDS)


@pytest.mark.parametrize("name", list(KINDS))
def test_every_kind_works_through_its_row(name: str, renderer: gt.Renderer) -> None:
    kind, obj = KINDS[name], sample(name)
    assert kind_of(obj) is kind and isinstance(kind.core_of(obj), kind.core)
    back = pickle.loads(pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL))
    assert type(back) is type(obj) and back is not obj
    _same(kind.reduce(back), kind.reduce(obj))
    stats = kind.stats(obj)
    assert isinstance(stats, dict) and stats
    lo, hi = kind.box(obj)
    assert lo.shape == hi.shape == (3,) and (hi > lo).all()
    scene = gt.Scene()
    scene.add(obj)
    assert repr(scene) == f"<geomtex.Scene 1 {kind.label[0]}>"
    frame = renderer.render(scene, _camera())
    assert (frame.patch_id != -1).sum() >= 10, "nothing drawn"
    again = renderer.render(pickle.loads(pickle.dumps(scene)), _camera())
    assert np.array_equal(again.depth, frame.depth) and np.array_equal(again.color, frame.color)
    assert np.array_equal(renderer.render(obj, _camera()).depth, frame.depth)  # alone, as in a scene


def test_a_scene_counts_each_kind_in_its_repr() -> None:
    scene = gt.Scene()
    assert repr(scene) == "<geomtex.Scene empty>"
    for name in ("set", "set", "mesh", "gdm_shell", "sphere group"):
        scene.add(sample(name))
    scene.add(trimesh.creation.box())  # read as a mesh
    assert repr(scene) == "<geomtex.Scene 2 texture sets, 2 meshes, 1 GDM shell, 1 sphere group>"
    assert repr(pickle.loads(pickle.dumps(scene))) == repr(scene)


def test_a_scene_refuses_what_is_no_kind() -> None:
    with pytest.raises(gt.MeshError, match="expected a geomtex.Mesh"):
        gt.Scene().add(42)
    with pytest.raises(gt.ParameterError, match="cannot hold a Scene"):
        gt.Scene().add(gt.Scene())
    with pytest.raises(gt.ParameterError, match="already the kind"):
        register("mesh again", gt.Mesh, _core.Mesh, reduce=astuple, restore=gt.Mesh, stats=lambda m: {})
