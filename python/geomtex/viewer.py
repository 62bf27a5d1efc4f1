"""An interactive viewer for Jupyter: drag to orbit, scroll to zoom, a quality / LOD / shading
selector, and the original mesh beside the geometry textures or blended over them.

>>> gt.show(gts, mesh="bunny.obj")

Every image is rendered by this process's cached `Renderer` of the view's size (the GPU device
and uploads are made once), so a drag costs one frame. The camera orbits the object's bounding
box centre about world +Y (the pyrender/trimesh convention), at a distance in bounding-box
diagonals. Needs the optional dependencies ``pip install geomtex[notebook]`` (ipywidgets and
ipyevents; without ipyevents the buttons and sliders still orbit and zoom).
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np
import numpy.typing as npt
from PIL import Image

from . import _check, _optional
from ._bridge import UNCHANGED, keyword_parameters, spelled_out
from ._camera import Camera
from ._errors import ParameterError
from ._kinds import adopt
from ._preview import patch_tint
from ._scene import Scene
from ._set import GeometryTextureSet
from ._viewstate import SHOW_KEYWORDS, Compare, ViewState

__all__ = ["ViewState", "Viewer", "show"]

_SHADINGS = ("shaded", "patches", "normals", "depth")
_COMPARES = ("textures", "mesh", "beside", "overlay")
_QUALITIES = ("fast", "balanced", "exact")


def _box_corners(lo: npt.NDArray[np.float64], hi: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The 8 corners of a box, homogeneous (8, 4)."""
    return np.array([[(lo, hi)[i & 1][0], (lo, hi)[(i >> 1) & 1][1], (lo, hi)[(i >> 2) & 1][2], 1.0]
                     for i in range(8)])


def _bounds(obj: Any) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """World (lo, hi) of anything a Scene takes (each kind's box, from the kinds table), or of a
    scene (each object's box placed by its matrix)."""
    if not isinstance(obj, Scene):
        kind, item = adopt(obj)
        return kind.box(item)
    corners = []
    for item, world_from_object, _, _ in obj._objects():
        kind, _ = adopt(item)
        lo, hi = kind.box(item)
        corners.append((_box_corners(lo, hi) @ np.asarray(world_from_object).T)[:, :3])
    if not corners:
        raise ParameterError("the scene is empty: nothing to show")
    every = np.concatenate(corners)
    return every.min(axis=0), every.max(axis=0)


class Viewer:
    """The state, the rendering and the widgets of one view. `orbit`, `zoom` and `set` change the
    view and redraw; the widgets' callbacks call them, and so can code (or a test)."""

    #: Degrees of orbit per pixel dragged.
    DEGREES_PER_PIXEL = 0.5
    #: Distance factor per wheel notch (100 units of deltaY).
    ZOOM_PER_NOTCH = 1.15

    @spelled_out(*keyword_parameters(ViewState, drop=("stats",)))
    def __init__(self, obj: Any, *, mesh: Any = None, width: int = 512, height: int = 384,
                 compare: Compare | None = None, **state: Any) -> None:
        from ._mesh import as_mesh

        self.width, self.height = _check.image_size(width, height, 16, 4096)
        # What is drawn, read once (a trimesh or a path as the Mesh read from it).
        self.obj = obj if isinstance(obj, Scene) else adopt(obj)[1]
        lo, hi = _bounds(self.obj)
        self.mesh = None if mesh is None else as_mesh(mesh)
        self.centre = (lo + hi) / 2
        self.diagonal = float(np.linalg.norm(hi - lo)) or 1.0
        self.state = ViewState(compare="beside" if self.mesh is not None else "textures")
        self.set(redraw=False, **state, **({} if compare is None else {"compare": compare}))
        self._drag: tuple[float, float] | None = None
        self._widget: Any = None
        self.image = self.render()

    # -- the view -------------------------------------------------------------------------------

    def camera(self) -> Camera:
        """The camera of the current view: orbiting the box centre about world +Y at
        ``state.distance`` diagonals."""
        s = self.state
        az, el = np.radians(s.azimuth_deg), np.radians(s.elevation_deg)
        direction = np.array([np.cos(el) * np.sin(az), np.sin(el), np.cos(el) * np.cos(az)])
        eye = self.centre + direction * s.distance * self.diagonal
        return Camera.look_at(eye, self.centre, up=(0.0, 1.0, 0.0), yfov_deg=s.yfov_deg)

    @spelled_out(*keyword_parameters(ViewState, default=UNCHANGED, drop=("stats",)))
    def set(self, redraw: bool = True, **changes: Any) -> None:
        """Changes any ViewState fields and redraws. Every value is checked before any is set, so
        a bad one changes nothing."""
        s = self.state
        checked: dict[str, Any] = {}
        for name, value in changes.items():
            if name in ("azimuth_deg", "elevation_deg"):
                checked[name] = _check.real(name, value)
            elif name == "distance":
                checked[name] = _check.real(name, value, 0.0, lo_open=True)
            elif name == "yfov_deg":
                checked[name] = _check.real(name, value, 0.0, 180.0, lo_open=True, hi_open=True)
            elif name == "lod":
                checked[name] = _check.flag(name, value)
            elif name in ("quality", "shading", "compare"):
                choices = {"quality": _QUALITIES, "shading": _SHADINGS, "compare": _COMPARES}[name]
                checked[name] = _check.choice(name, value, choices)
            else:
                raise ParameterError(f"unknown view setting {name!r}")
        if checked.get("compare", "textures") != "textures" and self.mesh is None:
            raise ParameterError(f"compare={checked['compare']!r} needs the original mesh: show(obj, mesh=...)")
        for name, value in checked.items():
            setattr(s, name, value)
        s.elevation_deg = float(np.clip(s.elevation_deg, -89.0, 89.0))  # the pole has no 'up'
        s.azimuth_deg = float(s.azimuth_deg % 360.0)
        s.distance = float(np.clip(s.distance, 0.05, 50.0))
        if redraw:
            self.redraw()

    def orbit(self, d_azimuth_deg: float, d_elevation_deg: float) -> None:
        """Turns the camera by these many degrees of azimuth and elevation and redraws."""
        self.set(azimuth_deg=self.state.azimuth_deg + _check.real("d_azimuth_deg", d_azimuth_deg),
                 elevation_deg=self.state.elevation_deg + _check.real("d_elevation_deg", d_elevation_deg))

    def zoom(self, factor: float) -> None:
        """Moves the camera `factor` times closer (a factor below 1 backs away)."""
        self.set(distance=self.state.distance / _check.real("factor", factor, 0.0, lo_open=True))

    # -- rendering ------------------------------------------------------------------------------

    def _picture(self, obj: Any, width: int) -> npt.NDArray[np.uint8]:
        from ._render import shared_renderer

        s = self.state
        options: dict[str, Any] = {"background": (255, 255, 255, 255)}
        if isinstance(obj, (GeometryTextureSet, Scene)):
            options.update(quality=s.quality, lod=s.lod)
        frame = shared_renderer(width, self.height).render(obj, self.camera(), **options)
        if obj is self.obj:  # the status line and `stats` speak of the textures, not the mesh
            s.stats = dict(frame.stats)
        hit = frame.patch_id != -1
        if s.shading == "patches":
            return patch_tint(frame)
        if s.shading == "normals":
            rgb = np.where(hit[..., None], (frame.normal * 0.5 + 0.5) * 255.0, 255.0)
            return rgb.astype(np.uint8)
        if s.shading == "depth":
            d = frame.depth
            lo, hi = (d[hit].min(), d[hit].max()) if hit.any() else (0.0, 1.0)
            grey = 255.0 - 200.0 * (d - lo) / max(hi - lo, 1e-30)
            return np.where(hit, grey, 255.0).astype(np.uint8)[..., None].repeat(3, axis=2)
        return np.asarray(frame.color)[..., :3].copy()

    def render(self) -> npt.NDArray[np.uint8]:
        """The current view as (height, width, 3) uint8: the textures, the mesh, both side by
        side (each half the width) or the mesh blended half over the textures."""
        compare = self.state.compare
        if compare == "textures" or self.mesh is None:
            return self._picture(self.obj, self.width)
        if compare == "mesh":
            return self._picture(self.mesh, self.width)
        if compare == "beside":
            half = self.width // 2
            return np.hstack([self._picture(self.obj, half), self._picture(self.mesh, self.width - half)])
        ours, theirs = self._picture(self.obj, self.width), self._picture(self.mesh, self.width)
        return ((ours.astype(np.uint16) + theirs) // 2).astype(np.uint8)

    def png(self) -> bytes:
        """The current image as PNG bytes."""
        buf = io.BytesIO()
        Image.fromarray(self.image).save(buf, format="PNG")
        return buf.getvalue()

    def redraw(self) -> None:
        """Renders the view again and updates the widget, where one is shown."""
        self.image = self.render()
        if self._widget is not None:
            self._widgets["image"].value = self.png()
            self._widgets["status"].value = self._status()

    def _status(self) -> str:
        s = self.state
        ms = s.stats.get("cpu_ms")
        return (f"azimuth {s.azimuth_deg:.0f}°  elevation {s.elevation_deg:.0f}°  distance {s.distance:.2f} diag"
                + (f"  {ms:.0f} ms" if ms is not None else ""))

    # -- the widgets ----------------------------------------------------------------------------

    def handle_event(self, event: dict[str, Any]) -> None:
        """An ipyevents mouse event: drag with a button held orbits, the wheel zooms."""
        kind = event.get("type")
        if kind == "mousedown":
            self._drag = (float(event["relativeX"]), float(event["relativeY"]))
        elif kind in ("mouseup", "mouseleave"):
            self._drag = None
        elif kind == "mousemove" and self._drag is not None and event.get("buttons", 1):
            x, y = float(event["relativeX"]), float(event["relativeY"])
            dx, dy = x - self._drag[0], y - self._drag[1]
            self._drag = (x, y)
            self.orbit(-dx * self.DEGREES_PER_PIXEL, dy * self.DEGREES_PER_PIXEL)
        elif kind == "wheel":
            self.zoom(self.ZOOM_PER_NOTCH ** (-float(event.get("deltaY", 0.0)) / 100.0))

    @property
    def widget(self) -> Any:
        """The ipywidgets box (made on first use)."""
        if self._widget is None:
            self._widget = self._build_widgets()
        return self._widget

    def _build_widgets(self) -> Any:
        w = _optional.need("ipywidgets", "gt.show")
        s = self.state
        image = w.Image(value=self.png(), format="png", width=self.width, height=self.height)
        quality = w.Dropdown(options=_QUALITIES, value=s.quality, description="quality")
        lod = w.Checkbox(value=s.lod, description="LOD")
        shading = w.Dropdown(options=_SHADINGS, value=s.shading, description="shading")
        compare = w.Dropdown(options=_COMPARES if self.mesh is not None else ("textures",), value=s.compare,
                             description="show")
        for control, name in [(quality, "quality"), (lod, "lod"), (shading, "shading"), (compare, "compare")]:
            control.observe(lambda change, name=name: self.set(**{name: change["new"]}), names="value")
        buttons = []
        for label, action in [("◀", lambda: self.orbit(-15, 0)), ("▶", lambda: self.orbit(15, 0)),
                              ("▲", lambda: self.orbit(0, 10)), ("▼", lambda: self.orbit(0, -10)),
                              ("+", lambda: self.zoom(1.25)), ("−", lambda: self.zoom(0.8))]:
            b = w.Button(description=label, layout=w.Layout(width="2.5em"))
            b.on_click(lambda _, action=action: action())
            buttons.append(b)
        status = w.Label(self._status())
        self._widgets = {"image": image, "status": status, "quality": quality, "lod": lod, "shading": shading,
                         "compare": compare}
        try:
            from ipyevents import Event

            self._events = Event(source=image, watched_events=["mousedown", "mouseup", "mousemove", "mouseleave",
                                                               "wheel"], prevent_default_action=True)
            self._events.on_dom_event(self.handle_event)
        except ImportError:  # no drag or wheel, the buttons still work
            self._events = None
        return w.VBox([image, w.HBox([quality, lod, shading, compare]), w.HBox([*buttons, status])])

    def _repr_mimebundle_(self, **kwargs: Any) -> Any:
        try:
            return self.widget._repr_mimebundle_(**kwargs)
        except ParameterError:  # no ipywidgets: a still picture
            return {"image/png": self.png()}

    def _repr_png_(self) -> bytes:
        return self.png()


@spelled_out(*SHOW_KEYWORDS)
def show(obj: Any, *, mesh: Any = None, width: int = 512, height: int = 384, **view: Any) -> Viewer:
    """An interactive view of `obj` (anything a Scene takes: a set, Mesh, trimesh, surfels, an
    IgtMesh, a gdm.Shell, a Scene, or a mesh path) in Jupyter: drag to
    orbit, scroll to zoom; quality, LOD and shading ("shaded", "patches", "normals", "depth")
    selectors; with `mesh` (the original) also "mesh", "beside" and "overlay". `view` sets the
    starting ViewState (azimuth_deg, elevation_deg, distance, ...). Front ends without widgets
    show the PNG."""
    return Viewer(obj, mesh=mesh, width=width, height=height, **view)
