"""One bridge style (geomtex._bridge): every public class is a Python class holding its extension
object, importing geomtex adds nothing to the extension (so `mypy.stubtest geomtex._core` checks
the extension alone), and what the extension returns comes back as the public classes."""

from __future__ import annotations

import inspect
import subprocess
import sys

import numpy as np
import trimesh

import geomtex as gt
from geomtex import _bridge, _core, gdm, igt
from geomtex._render import _RENDER_KEYWORDS, RenderOptions


def test_importing_geomtex_adds_nothing_to_the_extension() -> None:
    """In a fresh interpreter: the extension's module and classes, loaded without the package's
    __init__, are the same objects with the same attributes after ``import geomtex``."""
    script = """
import importlib.util, sys, types
spec = importlib.util.find_spec("geomtex")
bare = types.ModuleType("geomtex")
bare.__path__ = list(spec.submodule_search_locations)
sys.modules["geomtex"] = bare  # the package without its __init__: nothing patched yet
import geomtex._core as core

def names():
    return {name: sorted(vars(getattr(core, name))) if isinstance(getattr(core, name), type) else None
            for name in dir(core)}

before = names()
del sys.modules["geomtex"]
import geomtex
assert geomtex._core is core, "the package loaded another copy of the extension"
after = names()
changed = {name for name in before.keys() | after.keys() if before.get(name) != after.get(name)}
assert not changed, f"import geomtex changed geomtex._core: {sorted(changed)}"
"""
    subprocess.run([sys.executable, "-c", script], check=True, timeout=120)


def _public_classes() -> list[type]:
    modules = [gt, igt, gdm]
    return [obj for module in modules for obj in vars(module).values()
            if inspect.isclass(obj) and not issubclass(obj, BaseException) and obj.__module__.startswith("geomtex")]


def test_every_public_class_is_a_python_class() -> None:
    classes = _public_classes()
    assert {gt.GeometryTextureSet, gt.Mesh, gt.Scene, gt.Renderer, gt.Frame, gt.Camera, gt.Surfels,
            igt.InverseGeometricTexture, igt.IgtMesh, gdm.Volume, gdm.Shell} <= set(classes)
    for cls in classes:
        assert cls.__module__ != "geomtex._core", cls
        assert not any(base.__module__ == "geomtex._core" for base in cls.__mro__), cls  # no subclasses
    holders = [cls for cls in classes if issubclass(cls, _bridge.Wrapped)]
    assert {gt.GeometryTextureSet, gt.Scene, gt.Renderer, gt.Frame, gt.Camera, gdm.Volume} <= set(holders)


def test_the_extension_returns_public_objects() -> None:
    mesh = gt.Mesh.from_trimesh(trimesh.creation.icosphere(2))
    gts = gt.convert(mesh, max_resolution=16)
    surfels = gts.to_surfels()
    assert type(gts) is gt.GeometryTextureSet and type(gts.filtered("gaussian", 0.01)) is gt.GeometryTextureSet
    assert type(surfels) is gt.Surfels and type(surfels.source) is gt.GeometryTextureSet
    assert type(gt.GeometryTextureSet.from_bytes(gts.to_bytes())) is gt.GeometryTextureSet
    texture = igt.build(mesh, resolution=16)
    low = igt.attach(texture, texture.vertices, texture.faces)
    assert type(texture) is igt.InverseGeometricTexture and type(low) is igt.IgtMesh
    assert type(low.igt) is igt.InverseGeometricTexture
    camera = gt.Camera.look_at((0.0, 0.0, 3.0), (0.0, 0.0, 0.0))
    frame = gt.Renderer(8, 8).render(gts, camera)
    assert type(camera) is gt.Camera and type(frame) is gt.Frame
    assert isinstance(gt.gdm.Volume.procedural("chain", (16, 16, 8)), gt.gdm.Volume)
    assert _bridge.unwrap(gts) is gts._core and _bridge.unwrap(42) == 42
    assert type(_bridge.wrap(gts._core)) is gt.GeometryTextureSet and _bridge.wrap(np.ones(2)).shape == (2,)


def test_render_options_type_every_keyword_the_checks_know() -> None:
    assert set(RenderOptions.__annotations__) == set(_RENDER_KEYWORDS)
    assert set(RenderOptions.__annotations__) <= set(inspect.signature(_core.Renderer.render).parameters)
