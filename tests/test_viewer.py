"""gt.show: the viewer's state follows its orbit and zoom callbacks (driven here as ipyevents
would drive them), the picture follows the state, and each selector changes what is drawn."""

from __future__ import annotations

import io

import numpy as np
import pytest
import trimesh
from PIL import Image

import geomtex as gt

pytest.importorskip("ipywidgets")


@pytest.fixture(scope="module")
def viewer(bunny):
    return gt.show(bunny.gts, mesh=bunny.mesh, width=128, height=96, compare="textures")


def picture(v) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(v.widget.children[0].value)).convert("RGB"))


def test_drag_orbits_and_wheel_zooms(viewer) -> None:
    before, state = picture(viewer), (viewer.state.azimuth_deg, viewer.state.elevation_deg)
    viewer.handle_event({"type": "mousedown", "relativeX": 60, "relativeY": 50, "buttons": 1})
    viewer.handle_event({"type": "mousemove", "relativeX": 100, "relativeY": 30, "buttons": 1})
    viewer.handle_event({"type": "mouseup", "relativeX": 100, "relativeY": 30})
    # 40 px right, 20 px up at 0.5 degree per pixel.
    assert (viewer.state.azimuth_deg, viewer.state.elevation_deg) == ((state[0] - 20) % 360, state[1] - 10)
    after = picture(viewer)
    assert np.mean(np.any(after != before, axis=-1)) > 0.05  # the bunny turned
    viewer.handle_event({"type": "mousemove", "relativeX": 0, "relativeY": 0, "buttons": 1})  # no button down
    assert viewer.state.azimuth_deg == (state[0] - 20) % 360
    distance = viewer.state.distance
    covered = np.mean(np.any(picture(viewer) != 255, axis=-1))
    viewer.handle_event({"type": "wheel", "deltaY": -200})
    assert viewer.state.distance == pytest.approx(distance / 1.15 ** 2)
    assert np.mean(np.any(picture(viewer) != 255, axis=-1)) > 1.2 * covered  # closer: the bunny grew


def test_selectors_change_the_picture(viewer) -> None:
    shaded = picture(viewer)
    viewer._widgets["shading"].value = "patches"
    assert viewer.state.shading == "patches" and not np.array_equal(picture(viewer), shaded)
    viewer._widgets["compare"].value = "beside"
    beside = picture(viewer)
    half = beside.shape[1] // 2
    assert np.any(beside[:, :half] != 255) and np.any(beside[:, half:] != 255)  # both halves drawn
    viewer._widgets["quality"].value = "exact"
    assert viewer.state.stats["method"] == "maxmip"
    viewer.set(compare="textures", shading="shaded", quality="balanced")


def test_bad_settings_are_refused(bunny) -> None:
    v = gt.show(trimesh.creation.box(), width=32, height=32)
    with pytest.raises(gt.ParameterError, match="mesh="):
        v.set(compare="beside")
    with pytest.raises(gt.ParameterError, match="shading"):
        v.set(shading="wireframe")
    with pytest.raises(gt.ParameterError, match="unknown"):
        v.set(roll=3)
    with pytest.raises(gt.ParameterError, match="positive"):
        v.zoom(0)
    with pytest.raises(gt.ParameterError, match="width"):
        gt.show(bunny.gts, width=4)
    assert v._repr_png_().startswith(b"\x89PNG")
