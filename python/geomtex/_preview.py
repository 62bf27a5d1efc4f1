"""Pictures for notebooks and the command line, drawn with numpy + Pillow (no GPU needed):
a point-splat view of every texel, colored by patch and shaded by its normal, beside a mosaic of
the largest height maps.

Image space: row 0 at the top; the view looks at the model's centre from azimuth/elevation,
about +Y, or about +Z for a height grid (every patch's height axis along Z: terrain seen from
above rather than as a wall).
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np
import numpy.typing as npt
from PIL import Image, ImageDraw

_PALETTE = np.array(
    [[31, 119, 180], [255, 127, 14], [44, 160, 44], [214, 39, 40], [148, 103, 189], [140, 86, 75],
     [227, 119, 194], [127, 127, 127], [188, 189, 34], [23, 190, 207], [174, 199, 232], [255, 187, 120],
     [152, 223, 138], [255, 152, 150], [197, 176, 213], [196, 156, 148]], dtype=np.float64)


# (up, the horizontal axis seen at azimuth 0) for models standing on Y and for Z-up grids.
_FRAMES = {"y": (np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0])),
           "z": (np.array([0.0, 0.0, 1.0]), np.array([0.0, -1.0, 0.0]))}


def _view_axes(azimuth_deg: float, elevation_deg: float, up_axis: str = "y") -> tuple[npt.NDArray[np.float64], ...]:
    world_up, front = _FRAMES[up_axis]
    side = np.cross(world_up, front)
    az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
    eye_dir = np.cos(el) * (np.sin(az) * side + np.cos(az) * front) + np.sin(el) * world_up
    forward = -eye_dir  # towards the model
    right = np.cross(forward, world_up)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    return right, up, forward


def _up_axis(gts: Any) -> str:
    """"z" when every patch's height axis lies along Z (a height grid), else "y"."""
    heights = np.asarray(gts.world_from_patch)[:, :3, 2]
    if len(heights) == 0:
        return "y"
    cosines = np.abs(heights[:, 2]) / np.maximum(np.linalg.norm(heights, axis=1), 1e-300)
    return "z" if bool(np.all(cosines > 0.99)) else "y"


def _view(gts: Any) -> tuple[float, float, str]:
    """Azimuth, elevation and up axis that show the set: terrain from well above."""
    up_axis = _up_axis(gts)
    return (30.0, 55.0, up_axis) if up_axis == "z" else (30.0, 20.0, up_axis)


def splat(gts: Any, size: int = 512, azimuth_deg: float = 30.0, elevation_deg: float = 20.0,
          max_points: int = 3_000_000, up_axis: str = "y") -> Image.Image:
    """Orthographic point-splat image of the texel points (nearest point wins per pixel)."""
    points, normals = gts.to_points()
    counts = [int((gts.patch(i)["height"] > 0).sum()) for i in range(len(gts))]
    # A hybrid set's triangle points come after the texels': tinted as a mesh (-1).
    patch = np.repeat(np.arange(len(counts)), counts)
    patch = np.concatenate([patch, np.full(len(points) - len(patch), -1)])
    if len(points) > max_points:
        pick = np.random.default_rng(0).choice(len(points), max_points, replace=False)
        points, normals, patch = points[pick], normals[pick], patch[pick]
    img = np.full((size, size, 3), 255, np.uint8)
    if len(points) == 0:
        return Image.fromarray(img)
    right, up, forward = _view_axes(azimuth_deg, elevation_deg, up_axis)
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    rel = points - centre
    x, y, depth = rel @ right, rel @ up, rel @ forward
    half = 0.52 * max(np.ptp(x), np.ptp(y), 1e-300)
    col = np.clip(((x / half) * 0.5 + 0.5) * size, 0, size - 1).astype(np.int64)
    row = np.clip((0.5 - (y / half) * 0.5) * size, 0, size - 1).astype(np.int64)
    order = np.argsort(-depth)  # far first, so the nearest point is written last and wins
    shade = np.clip(-(normals.astype(np.float64) @ forward), 0.0, 1.0) * 0.75 + 0.25
    rgb = _PALETTE[patch % len(_PALETTE)] * shade[:, None]
    img[row[order], col[order]] = rgb[order].astype(np.uint8)
    return Image.fromarray(img)


def height_mosaic(gts: Any, size: int = 512, tiles: int = 36) -> Image.Image:
    """The largest height maps in a grid, empty texels black, heights in grey."""
    n = min(tiles, len(gts))
    grid = max(1, int(np.ceil(np.sqrt(n))))
    cell = size // grid
    out = Image.new("L", (size, size), 0)
    for k in range(n):
        h = gts.patch(k)["height"].astype(np.float64)
        filled = h > 0
        g = np.zeros_like(h)
        if filled.any():
            lo, hi = h[filled].min(), h[filled].max()
            g[filled] = 70 + 185 * (h[filled] - lo) / max(hi - lo, 1.0)
        tile = Image.fromarray(g[::-1].astype(np.uint8))  # v up
        scale = (cell - 4) / max(tile.size)
        scaled = (max(1, int(tile.size[0] * scale)), max(1, int(tile.size[1] * scale)))
        tile = tile.resize(scaled, Image.Resampling.NEAREST)
        out.paste(tile, ((k % grid) * cell + 2, (k // grid) * cell + 2))
    return out.convert("RGB")


def box_bounds(gts: Any) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(lo, hi) corners of the box around every patch box of a set and its triangles."""
    corners = np.array([[i & 1, (i >> 1) & 1, (i >> 2) & 1, 1] for i in range(8)], dtype=np.float64)
    world = np.einsum("pij,cj->pci", gts.world_from_patch, corners)[..., :3].reshape(-1, 3)
    if gts.triangles is not None:
        world = np.vstack([world, gts.triangles["vertices"]])
    return world.min(axis=0), world.max(axis=0)


def patch_tint(frame: Any) -> npt.NDArray[np.uint8]:
    """The frame's shading tinted by patch (meshes, with negative ids, in the palette too),
    white where nothing was hit."""
    hit = frame.patch_id != -1
    shade = frame.color[..., :3].astype(np.float64) / 255.0
    tint = 0.55 * _PALETTE[np.where(hit, frame.patch_id, 0) % len(_PALETTE)] + 0.45 * 230.0
    return np.where(hit[..., None], tint * shade, 255.0).astype(np.uint8)


def ray_cast_view(gts: Any, size: int = 512, azimuth_deg: float = 30.0, elevation_deg: float = 20.0,
                  up_axis: str = "y") -> tuple[Image.Image, Any] | None:
    """The set ray cast on the GPU (this process's renderer of that size), tinted by patch; None
    when no GPU adapter (not even lavapipe) is available."""
    from ._camera import Camera
    from ._errors import DeviceError
    from ._render import shared_renderer

    try:
        renderer = shared_renderer(size, size)
    except DeviceError:
        return None
    lo, hi = box_bounds(gts)
    centre, diag = (lo + hi) / 2, float(np.linalg.norm(hi - lo))
    right, up, forward = _view_axes(azimuth_deg, elevation_deg, up_axis)
    # 1.2 diagonals frame a compact model; a terrain's diagonal lies across the view, so the
    # whole bounding sphere must fit (radius diag / 2 in a 40 degree cone: 1.46 diagonals).
    distance = 1.5 * diag if up_axis == "z" else 1.2 * diag
    camera = Camera.look_at(centre - forward * distance, centre, up=tuple(up), yfov_deg=40.0)
    frame = renderer.render(gts, camera)
    return Image.fromarray(patch_tint(frame)), frame


def _summary(gts: Any) -> str:
    """Patches, texels, empty share and bytes, counted from the maps themselves: sets built from
    grids, filtered or reloaded carry different stats than a conversion's."""
    texels = empty = size = 0
    for i in range(len(gts)):
        p = gts.patch(i)
        n = p["height"].size
        texels, empty = texels + n, empty + int((p["height"] == 0).sum())
        # height + octahedral normal (2) + outline (1) + color (4, only with a color map) bytes
        size += n * (p["height_bits"] // 8 + 3 + (4 if p["has_colors"] else 0))
    triangles = gts.triangles
    kept = "" if triangles is None else f"  {len(triangles['faces']):,} triangles ({triangles['bytes'] / 1e6:.1f} MB)"
    return (f"{len(gts)} patches  {texels:,} texels  {100 * empty / max(texels, 1):.1f}% empty  "
            f"{size / 1e6:.1f} MB{kept}")


def overview(gts: Any, size: int = 512, title: str | None = None) -> Image.Image:
    """Left: the set ray cast on the GPU, tinted by patch (texel points splatted on the CPU if
    there is no GPU adapter). Right: the largest height maps."""
    caption = (title or "") + "  " + _summary(gts)
    canvas = Image.new("RGB", (2 * size, size + 24), (255, 255, 255))
    azimuth, elevation, up_axis = _view(gts)
    view = ray_cast_view(gts, size, azimuth, elevation, up_axis)
    if view is None:
        canvas.paste(splat(gts, size, azimuth, elevation, up_axis=up_axis), (0, 24))
        caption += "  (no GPU adapter: texel points splatted)"
    else:
        canvas.paste(view[0], (0, 24))
        caption += f"  ray cast in {view[1].stats['cpu_ms']:.0f} ms"
    canvas.paste(height_mosaic(gts, size), (size, 24))
    ImageDraw.Draw(canvas).text((8, 6), caption.strip(), fill=(0, 0, 0))
    return canvas


def set_png(gts: Any) -> bytes:
    """GeometryTextureSet._repr_png_: PNG bytes of `overview`, for Jupyter."""
    buf = io.BytesIO()
    overview(gts, 384).save(buf, format="PNG")
    return buf.getvalue()


def frame_image(frame: Any) -> Image.Image:
    """The frame's color over white (its alpha is 0 where nothing was hit)."""
    rgba = np.asarray(frame.color)
    white = Image.new("RGBA", (rgba.shape[1], rgba.shape[0]), (255, 255, 255, 255))
    return Image.alpha_composite(white, Image.fromarray(rgba, "RGBA")).convert("RGB")


def frame_png(frame: Any) -> bytes:
    """Frame._repr_png_: the color image over white as PNG bytes, for Jupyter."""
    buf = io.BytesIO()
    frame_image(frame).save(buf, format="PNG")
    return buf.getvalue()


def save_frame(frame: Any, path: Any) -> None:
    """Frame.save: writes the color image over white (what ``_repr_png_`` shows) in the format
    the extension names (.png, .jpg, ...), atomically: no half file is ever left behind."""
    from ._files import save_image

    save_image(frame_image(frame), path)
