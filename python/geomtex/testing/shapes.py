"""Generated meshes and height grids: analytic height fields, horizons, and pymeshlab's generators
(``GENERATED`` by name), plus Loop subdivision to reach a face count."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Callable

import numpy as np
import numpy.typing as npt

from .._mesh import Mesh
from ._arrays import arrays


def height_field(x: npt.ArrayLike, y: npt.ArrayLike,
                 z: Callable[[npt.NDArray[np.float64], npt.NDArray[np.float64]], npt.ArrayLike]) -> Mesh:
    """The surface z(x, y) over the grid x × y (1-D coordinate arrays), two triangles per cell,
    wound so that the normals point up (+z)."""
    gx, gy = np.meshgrid(np.asarray(x, np.float64), np.asarray(y, np.float64))
    gz = np.broadcast_to(np.asarray(z(gx, gy), np.float64), gx.shape)
    nx, ny = gx.shape[1] - 1, gx.shape[0] - 1
    i = (np.arange(nx)[None, :] + (nx + 1) * np.arange(ny)[:, None]).ravel()
    quads = np.stack([i, i + 1, i + nx + 2, i + nx + 1], axis=-1)
    return Mesh(np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()]),
                np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]))


def grid_mesh(z: npt.ArrayLike, extent: Sequence[float]) -> Mesh:
    """A (rows, columns) height grid over ``extent = (x0, x1, y0, y1)`` as triangles, two per
    cell whose four corners are finite (NaN = no data), unused vertices dropped: the mesh a
    geologist's software would make of a horizon, for checking ``from_heightmaps`` against."""
    z = np.asarray(z, np.float64)
    rows, cols = z.shape
    x0, x1, y0, y1 = (float(v) for v in extent)
    mesh = height_field(np.linspace(x0, x1, cols), np.linspace(y0, y1, rows), lambda x, y: np.nan_to_num(z))
    v, f = arrays(mesh)
    # height_field lists every cell's first triangle, then every cell's second, cells row-major.
    full = np.isfinite(z)
    cell = (full[:-1, :-1] & full[:-1, 1:] & full[1:, :-1] & full[1:, 1:]).ravel()
    f = f[np.concatenate([cell, cell])]
    used, f = np.unique(f, return_inverse=True)
    return Mesh(v[used], f.reshape(-1, 3))


def horizon_stack(rows: int = 300, cols: int = 400) -> list[npt.NDArray[np.float64]]:
    """Three synthetic geological horizons as (rows, columns) height grids, 40 and 50 units
    apart, folded by two sine waves each, the middle one with a block of missing data (NaN) over
    2/15 of its rows and a fifth of its columns. Sample spacing 10 units suits them."""
    y, x = np.mgrid[0:rows, 0:cols].astype(np.float64)
    out = [depth + amp * np.sin(x / 37.0 + k) * np.cos(y / 23.0) + 0.3 * amp * np.sin(x / 9.0 + y / 13.0)
           for k, (depth, amp) in enumerate([(-100.0, 8.0), (-140.0, 10.0), (-190.0, 6.0)])]
    r0, c0 = rows // 3, cols * 3 // 8
    out[1][r0:r0 + rows * 2 // 15, c0:c0 + cols // 5] = np.nan
    return out


def flat_grid(n: int = 16) -> Mesh:
    """The unit square at z = 0 as an n x n grid of triangle pairs: a chart with no height range."""
    xs = np.linspace(0.0, 1.0, n + 1)
    return height_field(xs, xs, lambda x, y: 0.0)


def wavy_sheet(n: int = 60) -> Mesh:
    """An open height-field sheet z = 0.15 sin(3x) cos(2y) over [-1, 1]^2, n x n cells."""
    x = np.linspace(-1, 1, n + 1)
    return height_field(x, x, lambda u, v: 0.15 * np.sin(3 * u) * np.cos(2 * v))


def gear_plate(teeth: int = 40, inner: float = 0.78, outer: float = 1.0) -> Mesh:
    """A flat gear in the plane z = 0: ``teeth`` trapezoidal teeth between radii ``inner`` and
    ``outer``, triangulated as a fan from the centre (the outline is star-shaped about it). One
    planar chart whose outline is intricate: 4 * teeth corners, half of them concave."""
    step = 2 * np.pi / teeth
    # Per tooth: root, tip rising, tip falling, root again (angles as fractions of a step).
    fractions = np.array([0.0, 0.2, 0.45, 0.65])
    radii = np.array([inner, outer, outer, inner])
    angles = (np.arange(teeth)[:, None] + fractions[None, :]).ravel() * step
    r = np.tile(radii, teeth)
    rim = np.column_stack([r * np.cos(angles), r * np.sin(angles), np.zeros_like(r)])
    n = len(rim)
    vertices = np.vstack([[0.0, 0.0, 0.0], rim])
    k = np.arange(n)
    faces = np.column_stack([np.zeros(n, np.int64), 1 + k, 1 + (k + 1) % n])
    return Mesh(vertices, faces)


def _pymeshlab(make: Callable[[Any], None]) -> Mesh:
    import pymeshlab

    ms = pymeshlab.MeshSet()
    make(ms)
    m = ms.current_mesh()
    return Mesh(m.vertex_matrix(), m.face_matrix())


def chamfered_box(extents: Sequence[float] = (2.0, 1.4, 1.0), chamfer: float = 0.2) -> Mesh:
    """A CAD-like block: a box of these extents with every edge and corner cut by a flat
    chamfer ``chamfer`` wide (the convex hull of its 24 cut corners, no booleans): faces meeting
    at 45 and 90 degrees, sharp edges everywhere."""
    import itertools

    import trimesh

    half = np.asarray(extents, dtype=np.float64) / 2
    points = []
    for signs in itertools.product((-1.0, 1.0), repeat=3):
        for axis in range(3):
            p = np.asarray(signs) * (half - chamfer)
            p[axis] = signs[axis] * half[axis]
            points.append(p)
    hull = trimesh.convex.convex_hull(np.asarray(points))
    return Mesh(hull.vertices, hull.faces)


GENERATED: dict[str, Callable[[], Mesh]] = {
    "sphere": lambda: _pymeshlab(lambda ms: ms.create_sphere(subdiv=4)),
    "torus": lambda: _pymeshlab(lambda ms: ms.create_torus(hradius=1.0, vradius=0.3, hsubdiv=96, vsubdiv=32)),
    "fractal_terrain": lambda: _pymeshlab(lambda ms: ms.create_fractal_terrain(steps=7, maxheight=0.3, seed=3)),
    "single_triangle": lambda: Mesh([[0, 0, 0], [1, 0, 0], [0.2, 0.9, 0.1]], [[0, 1, 2]]),
    "open_sheet": wavy_sheet,
}
"""Generated meshes by name (pymeshlab's generators and analytic surfaces), built on call."""


def subdivided(mesh: Mesh, min_faces: int) -> Mesh:
    """Loop subdivision (pymeshlab) until the mesh has at least ``min_faces`` faces."""
    import pymeshlab

    v, f = arrays(mesh)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(v, f.astype(np.int32)))
    while ms.current_mesh().face_number() < min_faces:
        ms.meshing_surface_subdivision_loop(iterations=1, threshold=pymeshlab.PercentageValue(0))
    m = ms.current_mesh()
    return Mesh(m.vertex_matrix(), m.face_matrix())


def noisy_isosurface(resolution: int = 96) -> Mesh:
    """pymeshlab's noisy isosurface: a rough closed surface (188,788 faces at resolution 96, the
    economy issue's case; 57,838 at 64)."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.create_noisy_isosurface(resolution=resolution)
    m = ms.current_mesh()
    return Mesh(m.vertex_matrix(), m.face_matrix())


def textured_sphere(rings: int = 48, segments: int = 96, texture_size: int = 256) -> Mesh:
    """A unit UV sphere with latitude-longitude texture coordinates per vertex (the seam's
    vertices doubled, the poles one vertex per segment) and a generated texture: a smooth hue
    gradient under an 8 x 4 checker of darker squares (``texture_size`` x ``texture_size / 2``)."""
    theta = np.linspace(0.0, np.pi, rings + 1)  # from the north pole
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)  # the last column repeats the first
    t, p = np.meshgrid(theta, phi, indexing="ij")
    vertices = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)
    uv = np.stack([p / (2.0 * np.pi), 1.0 - t / np.pi], axis=-1).reshape(-1, 2)
    row = segments + 1
    faces = []
    for i in range(rings):
        for j in range(segments):
            a, b = i * row + j, i * row + j + 1
            c, d = a + row, b + row
            if i > 0:
                faces.append([a, c, b])
            if i < rings - 1:
                faces.append([b, c, d])
    w, h = texture_size, texture_size // 2
    y, x = np.mgrid[0:h, 0:w]
    image = np.empty((h, w, 4), np.uint8)
    image[..., 0] = 40 + 200 * x / w
    image[..., 1] = 40 + 200 * y / h
    image[..., 2] = 120
    image[..., 3] = 255
    dark = ((x * 8 // w) + (y * 4 // h)) % 2 == 1
    image[dark, :3] //= 2
    return Mesh(vertices, np.asarray(faces), uv=uv, texture=image)


def face_colored(mesh: Mesh) -> Mesh:
    """``mesh`` with face colors from its face centroids' position in the bounding box: about
    three cycles of a sine per channel across the box, so neighbouring faces differ a little."""
    v, f = arrays(mesh)
    lo, hi = (np.asarray(b) for b in mesh.bounds)
    c = (v[f].mean(axis=1) - lo) / np.maximum(hi - lo, 1e-300)
    rgb = 0.5 + 0.5 * np.sin(np.stack([17.0 * c[:, 0], 13.0 * c[:, 1] + 1.0, 11.0 * c[:, 2] + 2.0], axis=1))
    return Mesh(v, f, face_colors=np.round(rgb * 255).astype(np.uint8))
