"""One GPU context per process and outputs on request: every Renderer, size, ray query and
preview shares one device and its uploads; a frame reads back only the outputs asked for."""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys

import numpy as np
import pytest
import trimesh

import geomtex as gt

# A fresh process does what a notebook does: renders at two sizes, queries 1,000 rays, shows a
# preview and asks gt.info() (its self-check draws every kind at 64²) what it made.
_NOTEBOOK = """
import json, numpy as np, trimesh, geomtex as gt
from geomtex import _core
s = gt.convert(trimesh.creation.icosphere(3))
cam = gt.Camera.look_at((0, 0, 3), (0, 0, 0))
gt.Renderer(256, 256).render(s, cam)
gt.Renderer(1024, 1024).render(s, cam)
rng = np.random.default_rng(0)
origins = rng.normal(size=(1000, 3)) * 3
s.intersects_first(origins, -origins)
s._repr_png_()
before = _core.device_counts()
info = gt.info(check=False)
print(json.dumps({"before": before, "info": {k: info[k] for k in before}}))
"""


def test_a_notebook_makes_one_device_and_uploads_a_set_once() -> None:
    # The GPU backend's sharing is what is counted (a CPU adapter's `auto` draws sets on the CPU).
    env = {**os.environ, "GEOMTEX_DEVICE": "gpu"}
    out = subprocess.run([sys.executable, "-c", _NOTEBOOK], capture_output=True, text=True, timeout=300, env=env)
    assert out.returncode == 0, out.stderr
    counts = json.loads(out.stdout.strip().splitlines()[-1])
    # Measured: devices 1, uploads 1 (the set, drawn at 256² and 1024², traced and previewed),
    # target sets 3 (256², 1024², the preview's size). Four devices and four uploads before.
    assert counts["before"]["devices_made"] == 1
    assert counts["before"]["uploads"] == 1
    assert counts["before"]["target_sets_made"] == 3
    # Only the texture-set kind's pipelines were made: each kind is made on its first object
    # (all five were made with every renderer before; that took most of its 1.2 s on lavapipe).
    assert counts["before"]["kinds_made"] == 1
    assert counts["info"] == counts["before"], "gt.info reports the same counts"


@pytest.fixture(scope="module")
def sphere_set() -> gt.GeometryTextureSet:
    return gt.convert(trimesh.creation.icosphere(3), hybrid=False)  # height maps: the ray-cast kind


@pytest.fixture(scope="module")
def camera() -> gt.Camera:
    return gt.Camera.look_at((0.0, 0.0, 3.0), (0.0, 0.0, 0.0))


def test_a_depth_only_frame_holds_the_full_frames_depth(sphere_set: gt.GeometryTextureSet,
                                                         camera: gt.Camera) -> None:
    r = gt.Renderer(96, 64)
    full = r.render(sphere_set, camera)
    depth_only = r.render(sphere_set, camera, outputs=("depth",))
    assert full.outputs == ["color", "albedo", "depth", "normal", "patch_id", "error_bound"]
    assert depth_only.outputs == ["depth"]
    assert (depth_only.width, depth_only.height) == (96, 64)
    np.testing.assert_array_equal(depth_only.depth, full.depth)
    assert np.isfinite(full.depth).mean() > 0.2
    for name in ("color", "albedo", "normal", "patch_id", "error_bound"):
        with pytest.raises(gt.ParameterError, match=f"no {name}.*outputs="):
            getattr(depth_only, name)
    # Without the ids the per-pixel figures are unknown (None), not zero.
    assert depth_only.stats["covered_pixels"] is None and full.stats["covered_pixels"] > 0
    again = pickle.loads(pickle.dumps(depth_only))
    assert again.outputs == ["depth"] and (again.width, again.height) == (96, 64)
    np.testing.assert_array_equal(again.depth, full.depth)


def test_outputs_with_a_light_shadow_the_color_alone(sphere_set: gt.GeometryTextureSet, camera: gt.Camera) -> None:
    r = gt.Renderer(64, 64)
    light = gt.DirectionalLight((0.3, -1.0, -0.5))
    full = r.render(sphere_set, camera, light=light)
    color_only = r.render(sphere_set, camera, light=light, outputs="color")
    assert color_only.outputs == ["color"]
    np.testing.assert_array_equal(color_only.shadow, full.shadow)
    np.testing.assert_array_equal(color_only.color, full.color)
    assert full.shadow.sum() > 50


@pytest.mark.parametrize("outputs", [("colour",), (), "", ["depth", 3], 5])
def test_bad_outputs_are_refused(sphere_set: gt.GeometryTextureSet, camera: gt.Camera, outputs: object) -> None:
    with pytest.raises(gt.ParameterError, match="output"):
        gt.Renderer(16, 16).render(sphere_set, camera, outputs=outputs)


def test_resize_keeps_the_device_and_the_uploads(sphere_set: gt.GeometryTextureSet, camera: gt.Camera) -> None:
    from geomtex import _core

    r = gt.Renderer(32, 32)
    r.render(sphere_set, camera)
    before = _core.device_counts()
    r.resize(48, 40)
    frame = r.render(sphere_set, camera)
    after = _core.device_counts()
    assert (r.width, r.height) == (48, 40) and frame.depth.shape == (40, 48)
    assert after["devices_made"] == before["devices_made"] == 1
    assert after["uploads"] == before["uploads"]
    with pytest.raises(gt.ParameterError, match="width"):
        r.resize(0, 10)
    assert (r.width, r.height) == (48, 40), "a refused size changes nothing"
