"""Generalized displacement maps (Wang et al. 2004): non-height-field mesostructure (chain links,
weaves, lattices) tiled over a base mesh.

>>> import geomtex as gt
>>> vol = gt.gdm.Volume.procedural("chain", size=(64, 64, 16))
>>> gdm = vol.distance_function(directions=(16, 32))   # d(x, y, z, theta, phi), in voxels
>>> packed = gdm.compress(k=8); packed.error             # SVD: rms / max / relative error
>>> shell = gt.gdm.Shell(base_mesh, vol, thickness=0.02, tiles=(8, 8))
>>> reference = shell.to_mesh()                          # trimesh: the tile's surface per prism

Spaces: texture space is in voxel units of the tile: voxel (i, j, k) is the cube [i, i+1) x
[j, j+1) x [k, k+1); x and y repeat (the tile is periodic), z = 0 lies on the base surface and
z = nz on the shell's top. Directions: theta the polar angle from +z (the outward normal), at the
centres of equal steps of [0, pi]; phi the azimuth from +x, at equal steps from 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Literal

import numpy as np
import numpy.typing as npt

from . import _check, _core, _optional
from ._bridge import Wrapped
from ._errors import MeshError, ParameterError

__all__ = [
    "CompressedGDM",
    "DistanceFunction",
    "Shell",
    "Volume",
    "box_uv",
    "direction_vectors",
    "seam_fins",
    "tile_surface",
    "uv_torus",
]

Pattern = Literal["chain", "weave", "lattice"]
DEFAULT_DIRECTIONS = (16, 32)
DEFAULT_SIZE = (64, 64, 16)
#: Voxels a side of a volume (the extension's limits), and direction counts (theta, phi).
MAX_SIDE = 512
MAX_DIRECTIONS = (64, 128)


def _size(size: Any, what: str = "size") -> tuple[int, int, int]:
    return _check.counts(what, size, 2, (MAX_SIDE,) * 3,  # type: ignore[return-value]
                         f"three voxel counts (nx, ny, nz), 2 to {MAX_SIDE} voxels along each axis")


def _occupancy(grid: Any) -> npt.NDArray[np.uint8]:
    a = _check.array("occupancy", grid, "biuf")
    if a.ndim != 3:
        raise ParameterError(f"occupancy must be an (nx, ny, nz) array of bools or numbers, got shape "
                             f"{a.shape} dtype {a.dtype}")
    if not all(2 <= n <= MAX_SIDE for n in a.shape):  # before anything the size of the grid is made
        raise ParameterError(f"occupancy must have 2 to {MAX_SIDE} voxels along each axis, got shape {a.shape}")
    if a.dtype.kind == "f":
        if not np.isfinite(a).all():
            bad = np.argwhere(~np.isfinite(a))[0]
            raise ParameterError(f"occupancy holds NaN or inf (first at voxel {tuple(int(b) for b in bad)})")
        return np.ascontiguousarray(a >= 0.5, dtype=np.uint8)
    return np.ascontiguousarray(a != 0, dtype=np.uint8)


class Volume(Wrapped, core=_core.GdmVolume):
    """A mesostructure tile: an occupancy grid indexed [x, y, z], periodic in x and y.

    ``occupancy``: bools, integers (non-zero = solid) or floats (>= 0.5 = solid), shape (nx, ny,
    nz), 2..512 voxels a side. ``colors``: optional (nx, ny, nz, 4) uint8 RGBA. A grid that does
    not tile (more than half the solid voxels on its x or y faces have no solid neighbour across
    the seam), an empty or a full grid raises ParameterError; ``check_seams=False`` accepts a
    grid that does not tile.
    """

    _core: _core.GdmVolume

    def __init__(self, occupancy: Any, colors: Any = None, *, check_seams: bool = True) -> None:
        grid = _occupancy(occupancy)
        seams = _check.flag("check_seams", check_seams)
        rgba = None
        if colors is not None:
            rgba = _check.array("colors", colors, "iu")
            if rgba.shape != grid.shape + (4,):
                raise ParameterError(f"colors must be {grid.shape + (4,)} uint8, got shape {rgba.shape} "
                                     f"dtype {rgba.dtype}")
            if rgba.size and (rgba.min() < 0 or rgba.max() > 255):
                raise ParameterError(f"colors must be in [0, 255], got values from {rgba.min()} to {rgba.max()}")
            rgba = np.ascontiguousarray(rgba, dtype=np.uint8)
        self._core = _core.GdmVolume(grid, rgba, seams)

    def __repr__(self) -> str:
        colored = ", colored" if self._core.colors is not None else ""
        return f"<geomtex.gdm.Volume {'x'.join(map(str, self.size))}, {self.occupancy.mean():.1%} solid{colored}>"

    def __reduce__(self) -> tuple[Any, ...]:
        # As its grid and colors; the extension's copy is made anew from them, identical.
        colors = self._core.colors
        return (_volume_from_arrays, (self.occupancy, None if colors is None else colors.reshape(self.size + (4,))))

    @classmethod
    def procedural(cls, pattern: Pattern, size: Any = DEFAULT_SIZE) -> Volume:
        """A built-in tile: ``"chain"`` (interlocking links, flat and upright), ``"weave"`` (threads
        over and under) or ``"lattice"`` (rods on two levels joined by posts)."""
        return cls._wrap(_core.GdmVolume.procedural(pattern, _size(size)))

    @classmethod
    def from_mesh(cls, mesh: Any, size: Any = DEFAULT_SIZE, *, check_seams: bool = True) -> Volume:
        """A watertight mesh voxelized into one tile: its bounding box's x and y span the tile, its
        z span the tile's height (a voxel is solid when its centre is inside)."""
        from ._mesh import as_mesh

        n = np.array(_size(size))
        _check.flag("check_seams", check_seams)
        tm: Any = _core_to_trimesh(as_mesh(mesh))
        tm.merge_vertices()
        if not tm.is_watertight:
            raise MeshError("Volume.from_mesh needs a watertight mesh (inside must be defined)")
        lo, hi = tm.bounds
        axes = [lo[a] + (np.arange(n[a]) + 0.5) / n[a] * (hi[a] - lo[a]) for a in range(3)]
        centres = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        inside = tm.contains(centres).reshape(tuple(n))
        return cls(inside, check_seams=check_seams)

    @property
    def size(self) -> tuple[int, int, int]:
        """Voxels along x, y and z."""
        return self._core.size

    @property
    def occupancy(self) -> npt.NDArray[np.bool_]:
        """(nx, ny, nz) bool: the solid voxels."""
        return self._core.occupancy

    @property
    def nbytes(self) -> int:
        """Bytes of the exact representation the tracer walks: one occupancy bit and one byte of
        empty-space radius per voxel."""
        n = int(np.prod(self.size))
        return n // 8 + n

    def empty_radius(self) -> npt.NDArray[np.uint8]:
        """(nx, ny, nz) Chebyshev distance in voxels to the nearest solid voxel (0 on solid)."""
        return self._core.empty_radius()

    def march(self, origins: Any, directions: Any,
              max_t: float | None = None) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
        """Exact first solid voxel along (N, 3) texture-space rays (directions normalized here; one
        ray may be given as two 3-vectors): (t in voxels, hit); a miss ends where the ray leaves
        the slab 0 <= z <= nz, or at ``max_t`` (voxels, positive)."""
        o, d = (_check.vector(name, v).reshape(1, 3) if _check.array(name, v).ndim == 1 else _check.rows(name, v)
                for name, v in (("origins", origins), ("directions", directions)))
        if o.shape != d.shape:
            raise ParameterError(f"origins and directions must both be (N, 3), got {o.shape} and {d.shape}")
        norm = np.linalg.norm(d, axis=1, keepdims=True)
        if not (norm > 0).all():
            raise ParameterError(f"directions must be non-zero: row {int(np.flatnonzero(norm[:, 0] == 0)[0])} is "
                                 "(0, 0, 0)")
        t = None if max_t is None else _check.real("max_t", max_t, 0.0, lo_open=True)
        return self._core.march(o, np.ascontiguousarray(d / norm), t)

    def distance_function(self, directions: Any = DEFAULT_DIRECTIONS,
                          progress: Callable[[str, float], Any] | None = None, *,
                          lower_bound: bool = False) -> DistanceFunction:
        """The 5D function d(x, y, z, theta, phi) from every voxel centre along (theta, phi)
        direction counts (default the paper's 16 x 32); in parallel, GIL released, cancellable
        (``progress(stage, fraction)`` returning False stops it with CancelledError).

        With ``lower_bound=True`` each entry is instead a lower bound of the distance to the
        rendered surface over every point and direction the lookup interpolates it into (a voxel
        around its centre, the direction cell between its neighbouring samples), misses bounded
        by the distance to leave the slab: interpolated anywhere, it never passes a surface. Its
        ``compress()`` keeps that (the SVD's overshoot subtracted), and a Shell given it steps by
        the table and finishes with the exact march."""
        lower_bound = _check.flag("lower_bound", lower_bound)
        counts = _check.counts("directions", directions, 2, MAX_DIRECTIONS,
                               f"(theta, phi) counts, theta 2 to {MAX_DIRECTIONS[0]} and phi 2 to {MAX_DIRECTIONS[1]}")
        _check.callback("progress", progress)
        d, hit = self._core.distance_function(counts, progress, lower_bound)  # type: ignore[arg-type]
        return DistanceFunction(self, d, hit, lower_bound=lower_bound)


def _volume_from_arrays(occupancy: npt.NDArray[np.bool_], colors: npt.NDArray[np.uint8] | None) -> Volume:
    """Unpickles a Volume (its seams were checked when it was first made)."""
    return Volume(occupancy, colors, check_seams=False)


def _core_to_trimesh(mesh: Any) -> Any:
    import trimesh

    return trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), process=False)


def direction_vectors(directions: Any = DEFAULT_DIRECTIONS) -> npt.NDArray[np.float64]:
    """(theta, phi, 3) unit vectors of the sampled directions, as the core samples them."""
    nt, nphi = directions
    theta = (np.arange(nt) + 0.5) * np.pi / nt
    phi = np.arange(nphi) * 2 * np.pi / nphi
    t, p = np.meshgrid(theta, phi, indexing="ij")
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)


@dataclass
class DistanceFunction:
    """d(x, y, z, theta, phi) in voxels, shape (nx, ny, nz, theta, phi), misses replaced by the
    distance to the slab's top or bottom (``hit`` False there); with ``lower_bound``, the
    conservative table of ``Volume.distance_function(lower_bound=True)``."""

    #: The volume it was computed from.
    volume: Volume
    #: (nx, ny, nz, theta, phi) float32 distances in voxels.
    distance: npt.NDArray[np.float32]
    #: (nx, ny, nz, theta, phi) bool: whether the ray from each voxel in each direction hits
    #: solid (False where ``distance`` is the distance to the slab's top or bottom instead).
    hit: npt.NDArray[np.bool_]
    #: Whether the table is the conservative one (``distance_function(lower_bound=True)``).
    lower_bound: bool = False
    _svd: Any = field(default=None, repr=False)

    def __getstate__(self) -> dict[str, Any]:
        # Without the SVD cache: its U alone is rows x columns float64, far more than the table.
        return {**self.__dict__, "_svd": None}

    @property
    def directions(self) -> tuple[int, int]:
        """The direction counts (theta, phi) the table samples."""
        return self.distance.shape[3], self.distance.shape[4]

    @property
    def nbytes(self) -> int:
        """Bytes of the uncompressed table as float32."""
        return int(self.distance.size * 4)

    def matrix(self) -> npt.NDArray[np.float32]:
        """The table as the paper factors it: rows (x, y, phi), columns (theta, z)."""
        nx, ny, nz, nt, nphi = self.distance.shape
        return self.distance.transpose(0, 1, 4, 3, 2).reshape(nx * ny * nphi, nt * nz)

    def compress(self, k: int = 8) -> CompressedGDM:
        """The k-term SVD: weight maps W_i(x, y, phi) and eigen-maps E_i(theta, z), with the
        reconstruction error (voxels) over the whole table."""
        nx, ny, nz, nt, nphi = self.distance.shape
        most = min(nx * ny * nphi, nt * nz)
        k = _check.integer("k", k, 1, most)  # the table's rank bound
        if self._svd is None:
            u, s, vt = np.linalg.svd(self.matrix().astype(np.float64), full_matrices=False)
            self._svd = (u, s, vt)
        u, s, vt = self._svd
        weights = (u[:, :k] * s[:k]).astype(np.float32)
        eigen = vt[:k].astype(np.float32)
        packed = CompressedGDM(weights.reshape(nx, ny, nphi, k), eigen.reshape(k, nt, nz), self.distance.shape)
        if self.lower_bound:
            packed = _conservative(packed, self.distance)
        residual = packed.reconstruct() - self.distance
        packed.error = {
            "rms": float(np.sqrt(np.mean(residual.astype(np.float64) ** 2))),
            "max": float(np.abs(residual).max()),
            "p99": float(np.quantile(np.abs(residual), 0.99)),
            # An all-zero table (a lower bound over a tile too thin to skip anything): no spectrum.
            "relative": float(np.linalg.norm(s[k:]) / max(float(np.linalg.norm(s)), 1e-300)),
        }
        return packed


# Slack (voxels, plus a fraction of the entry) for the renderer's float32 sums of the terms.
_FLOAT_SLACK = (1e-3, 1e-5)


def _conservative(packed: CompressedGDM, bound: npt.NDArray[np.float32]) -> CompressedGDM:
    """The SVD of a lower-bound table kept a lower bound.

    Per row (x, y, phi), the largest amount by which the k terms overshoot the table over that
    row's (theta, z) is stored as one more term with a constant eigen-map of -1. Interpolation is
    linear, so subtracting the interpolated margin keeps every interpolated value at or below the
    interpolated bound. (One global margin instead costs far more skip: a few rows overshoot by
    much more than most.)"""
    terms = np.einsum("xypk,ktz->xyztp", packed.weights.astype(np.float64), packed.eigen.astype(np.float64))
    margin = np.maximum((terms - bound).max(axis=(2, 3)), 0.0)  # (x, y, phi)
    margin += _FLOAT_SLACK[0] + _FLOAT_SLACK[1] * float(np.abs(bound).max())
    # Rounded up to float32, so the stored margin is never smaller than the one computed.
    m32 = margin.astype(np.float32)
    m32 = np.where(m32 < margin, np.nextafter(m32, np.float32(np.inf)), m32)
    nx, ny, nz, nt, nphi = bound.shape
    weights = np.concatenate([packed.weights, m32[..., None]], axis=3)
    eigen = np.concatenate([packed.eigen, -np.ones((1, nt, nz), np.float32)], axis=0)
    return CompressedGDM(weights, eigen, packed.shape, conservative=True)


@dataclass
class CompressedGDM:
    """A distance function as k SVD terms: d ~ sum_i W_i(x, y, phi) E_i(theta, z). A
    ``conservative`` one (from a lower-bound table) holds one more term: its per-row margin
    (weights) times -1 (eigen-map), so the sum stays at or below the bound."""

    #: (nx, ny, phi, k [+ 1]) float32 weight maps W_i.
    weights: npt.NDArray[np.float32]
    #: (k [+ 1], theta, nz) float32 eigen-maps E_i.
    eigen: npt.NDArray[np.float32]
    #: The full table's shape (nx, ny, nz, theta, phi).
    shape: tuple[int, ...]
    #: Reconstruction error in voxels over the whole table: rms, max, p99, and relative (the
    #: dropped singular values' share of the spectrum's norm).
    error: dict[str, float] = field(default_factory=dict)
    #: Whether the last term is a lower bound's margin (see the class).
    conservative: bool = False

    @property
    def k(self) -> int:
        """SVD terms (without a conservative table's margin term)."""
        return int(self.eigen.shape[0]) - int(self.conservative)

    @property
    def nbytes(self) -> int:
        """Bytes of the weight maps and eigen-maps."""
        return int(self.weights.nbytes + self.eigen.nbytes)

    def reconstruct(self) -> npt.NDArray[np.float32]:
        """The full (nx, ny, nz, theta, phi) table from the k terms."""
        return np.einsum("xypk,ktz->xyztp", self.weights, self.eigen)


def _position_groups(vertices: npt.NDArray[np.float64]) -> npt.NDArray[np.int64]:
    """One id per distinct position: copies of a vertex split at a texture seam share it."""
    _, group = np.unique(np.round(vertices, 12), axis=0, return_inverse=True)
    return group.reshape(-1)


def _welded_normals(vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64], thickness: float,
                    rounds: int = 32) -> tuple[npt.NDArray[np.float64], int]:
    """Area-weighted vertex normals summed over every vertex at the same position, so copies of a
    vertex split at a texture seam extrude alike (no cracks between their prisms), then untangled
    (``_untangle``, at most ``rounds`` rounds) for this thickness: (normals, how many positions the
    untangling moved)."""
    group = _position_groups(vertices)
    tri = vertices[faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # length = 2 x area
    summed = np.zeros((group.max() + 1, 3))
    for c in range(3):
        np.add.at(summed, group[faces[:, c]], face_n)
    length = np.linalg.norm(summed, axis=1, keepdims=True)
    if (length < 1e-300).any():
        raise MeshError("Shell: a vertex has no normal (its faces cancel or are degenerate)")
    positions = np.zeros_like(summed)
    positions[group] = vertices
    normals, moved = _untangle(positions, group[faces], summed / length, thickness, rounds)
    return normals[group], moved


def _inverted_prisms(positions: npt.NDArray[np.float64], faces: npt.NDArray[np.int64],
                     normals: npt.NDArray[np.float64], thickness: float) -> npt.NDArray[np.bool_]:
    """Per face, whether its prism's cross-section turns over anywhere up to the top (checked at
    four heights: the cross-section's normal along the base's is quadratic in the height)."""
    p = positions[faces]
    step = thickness * normals[faces]
    base = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    bad = np.zeros(len(faces), bool)
    for h in (0.25, 0.5, 0.75, 1.0):
        m = p + h * step
        bad |= np.einsum("ij,ij->i", base, np.cross(m[:, 1] - m[:, 0], m[:, 2] - m[:, 0])) <= 0
    # A degenerate base triangle has no side to turn over to (and no face normal to push toward).
    return bad & (np.linalg.norm(base, axis=1) > 0)


def _untangle(positions: npt.NDArray[np.float64], faces: npt.NDArray[np.int64], normals: npt.NDArray[np.float64],
              thickness: float, rounds: int = 32) -> tuple[npt.NDArray[np.float64], int]:
    """Vertex normals bent so no prism turns inside out: where neighbouring normals converge over
    a triangle narrower than about the thickness (creases of a decimated mesh, concave side), its
    top turns over and the prism's map folds (88 of the 3,000-face bunny's prisms at 1.2% of its
    diagonal). Each round moves the normals at the corners of every inverted prism halfway toward
    the mean of those prisms' face normals (a triangle whose corners share its face normal
    extrudes without turning); the bunny needs three rounds and moves 136 of 1,502 normals. Not
    a cure everywhere: pushes from neighbouring inverted prisms can cancel (at 1.2% of the
    diagonal fandisk keeps 8 of 22, rocker-arm 67 of 396), so the round with the fewest
    inverted prisms is kept and none is made worse. Returns (normals, how many moved)."""
    out = normals.copy()
    best, fewest = out.copy(), len(faces) + 1
    for k in range(rounds + 1):
        bad = _inverted_prisms(positions, faces, out, thickness)
        if bad.sum() < fewest:
            best, fewest = out.copy(), int(bad.sum())
        if not bad.any() or k == rounds:
            break
        tri = positions[faces[bad]]
        face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        face_n /= np.linalg.norm(face_n, axis=1, keepdims=True)
        push = np.zeros_like(out)
        for c in range(3):
            np.add.at(push, faces[bad, c], face_n)
        touched = np.linalg.norm(push, axis=1) > 0
        push[touched] /= np.linalg.norm(push[touched], axis=1, keepdims=True)
        bent = out[touched] + 0.5 * (push[touched] - out[touched])
        out[touched] = bent / np.linalg.norm(bent, axis=1, keepdims=True)
    return best, int((best != normals).any(axis=1).sum())


def seam_fins(vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64],
              uv: npt.NDArray[np.float64]) -> npt.NDArray[np.uint8]:
    """Per face, bit e set when its fin from corner e to e + 1 is a seam: the tile does not
    continue across it, because the edge is open (one face), non-manifold (three or more), or
    its two faces give its ends texture coordinates (in tiles) that differ by other than one
    whole-tile shift. ``uv`` is (F, 3, 2); vertices at one position count as one."""
    group = _position_groups(vertices)
    g = group[faces]
    nf = len(faces)
    a, b = g, np.roll(g, -1, axis=1)  # fin e runs from corner e to corner e + 1
    ua, ub = uv, np.roll(uv, -1, axis=1)
    key = np.sort(np.stack([a, b], axis=-1), axis=-1).reshape(-1, 2)
    # Texture coordinates of each fin's ends in key order (smaller group first).
    swap = (a > b).reshape(-1)
    lo = np.where(swap[:, None], ub.reshape(-1, 2), ua.reshape(-1, 2))
    hi = np.where(swap[:, None], ua.reshape(-1, 2), ub.reshape(-1, 2))
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    seam = counts[inverse] != 2
    order = np.argsort(inverse, kind="stable")
    pairs = order[np.isin(inverse[order], np.flatnonzero(counts == 2))].reshape(-1, 2)
    shift_lo = lo[pairs[:, 0]] - lo[pairs[:, 1]]
    shift_hi = hi[pairs[:, 0]] - hi[pairs[:, 1]]
    whole = np.abs(shift_lo - np.round(shift_lo)).max(axis=1) < 1e-6
    cut = ~(whole & (np.abs(shift_lo - shift_hi).max(axis=1) < 1e-6))
    seam[pairs[cut].ravel()] = True
    bits = seam.reshape(nf, 3).astype(np.uint8) << np.arange(3, dtype=np.uint8)
    return np.ascontiguousarray(bits.sum(axis=1).astype(np.uint8))


def box_uv(vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
    """Generated texture coordinates, per corner (F, 3, 2): each face projected on the bounding
    box's side its normal faces most (axes ordered to keep its winding), in units of the box's
    largest side. Seams where the side changes cut the mesostructure."""
    tri = vertices[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    axis = np.abs(n).argmax(axis=1)
    sign = np.sign(n[np.arange(len(n)), axis])
    lo = vertices.min(axis=0)
    scale = float((vertices.max(axis=0) - lo).max())
    local = (tri - lo) / scale
    # (u, v) axes per dominant axis with u x v = +axis; a negative side mirrors u.
    uv_axes = np.array([[1, 2], [2, 0], [0, 1]])
    uv = np.take_along_axis(local, uv_axes[axis][:, None, :].repeat(3, axis=1), axis=2)
    uv[:, :, 0] *= sign[:, None]
    return uv


def tile_surface(volume: Volume) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """A volume's surface over one period (marching cubes at 0.5 of the occupancy sampled at voxel
    centres, x and y wrapped, empty below and above): vertices in voxel units with x, y in
    [0.5, n + 0.5] and z in [0, nz], faces wound outward."""
    measure = _optional.need("skimage.measure", "geomtex.gdm (the tile's surface by marching cubes)")

    occ = volume.occupancy.astype(np.float32)
    nx, ny, nz = occ.shape
    grid = np.zeros((nx + 1, ny + 1, nz + 2), np.float32)
    grid[:, :, 1:-1] = np.pad(occ, ((0, 1), (0, 1), (0, 0)), mode="wrap")
    verts, faces, normals, _ = measure.marching_cubes(grid, level=0.5, allow_degenerate=False)
    verts = verts.astype(np.float64) + np.array([0.5, 0.5, -0.5])
    # Outward winding: the returned normals point down the field's gradient, out of the solid.
    tri = verts[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    if np.einsum("ij,ij->", cross, normals[faces].sum(axis=1)) < 0:
        faces = faces[:, ::-1]
    return verts, np.ascontiguousarray(faces, dtype=np.int64)


#: Thickest shell, in diagonals of its base mesh; most tiles (uv magnitude) across it.
_MAX_THICKNESS = 100.0
_MAX_TILES = 1e6


class Shell:
    """A volume tiled over a base mesh: every triangle extruded along its vertices' shared normals
    by ``thickness`` (object units) into a prism.

    Rendered by ``Renderer.render(shell, camera)`` or ``Scene.add(shell)``: per pixel, the ray
    through each prism is cut into ``pieces`` straight texture-space pieces (their ends mapped
    exactly) and the tile is marched for the first surface; with ``lookup`` (a CompressedGDM of
    this volume) each piece instead takes the paper's one lookup in the SVD-compressed distance
    function (interpolated in position and direction, as the paper's textures are), kept where
    the field confirms it; ``refine`` > 0 (voxels) searches exactly for the first surface within
    that distance of the looked-up one instead. A conservative ``lookup`` (compressed from
    ``distance_function(lower_bound=True)``) steps each piece by the looked-up lower bound and
    finishes with the exact march: the march's image, the table deciding only what is skipped.
    ``count_steps=True`` (diagnostics) writes (lookups, march steps, field samples) of the
    fragment that drew each pixel into the frame's normal instead. Drawn in ``color`` (RGBA).
    Ray queries (``Scene.intersects_*``, ``Renderer.intersect``) and shadow rays
    (``render(..., light=...)``) trace shells by the same march through a hierarchy over the
    prisms: a shell casts shadows on itself and on other objects.

    Texture coordinates (in tiles: 1.0 = one tile): ``uv`` as (V, 2) per vertex or (F, 3, 2) per
    corner; else the base mesh's own UVs times ``tiles``; else generated by ``box_uv`` times
    ``tiles`` (default (8, 8): eight tiles across the bounding box's largest side).

    Vertex normals are shared by every copy of a position, and bent where a prism would turn
    inside out at this thickness (``untangled``: how many positions were bent).
    """

    def __init__(self, base_mesh: Any, volume: Volume, thickness: float, *,
                 tiles: Any = (8, 8), uv: Any = None, color: Any = (200, 170, 110, 255),
                 pieces: int = 4, lookup: CompressedGDM | None = None, refine: float = 0.0,
                 count_steps: bool = False) -> None:
        from ._mesh import as_mesh

        mesh = as_mesh(base_mesh)
        if not isinstance(volume, Volume):
            raise ParameterError(f"volume must be a geomtex.gdm.Volume, got {type(volume).__name__}")
        # A shell far thicker than its base is no displacement (and overflows the prism maps).
        most = _MAX_THICKNESS * max(float(mesh.diagonal), 1e-300)
        try:
            t = _check.real("thickness", thickness, 0.0, most, lo_open=True)
        except ParameterError:
            raise _check.fail("thickness", f"a positive number of object units, at most {most:.6g} "
                              f"({_MAX_THICKNESS:g} x the base mesh's diagonal)", thickness) from None
        scale = _check.vector("tiles", tiles, 2) if _check.array("tiles", tiles).shape == (2,) else None
        if scale is None or (scale <= 0).any() or (scale > _MAX_TILES).any():
            raise _check.fail("tiles", f"two positive numbers (u, v), at most {_MAX_TILES:g}", tiles)
        self.vertices = np.asarray(mesh.vertices, dtype=np.float64)
        self.faces = np.asarray(mesh.faces, dtype=np.int64)
        self.volume, self.thickness, self.tiles = volume, t, tuple(scale)
        self.normals, self.untangled = _welded_normals(self.vertices, self.faces, t)
        self.uv, self.uv_source = self._texture_coordinates(mesh, uv, scale)
        self.color: tuple[int, int, int, int] = _check.rgba("color", color)
        self.pieces = _check.integer("pieces", pieces, 1, 64)
        if lookup is not None and (not isinstance(lookup, CompressedGDM) or lookup.shape[:3] != volume.size):
            raise ParameterError("lookup must be a CompressedGDM of this shell's volume (DistanceFunction.compress)")
        self.lookup = lookup
        r = _check.real("refine", refine, 0.0, 64.0)
        if r > 0 and lookup is not None and lookup.conservative:
            raise ParameterError("refine applies to the paper's lookup; a conservative table is followed by "
                                 "the exact march (leave refine at 0)")
        self.refine = r
        self.count_steps = _check.flag("count_steps", count_steps)
        self._drawn: Any = None

    def __getstate__(self) -> dict[str, Any]:
        # Without the extension's copy (made again on the first draw after unpickling).
        return {**self.__dict__, "_drawn": None}

    @classmethod
    def _from_state(cls, state: dict[str, Any]) -> Shell:
        """The shell `__getstate__` described (how pickling makes it again)."""
        shell = cls.__new__(cls)
        shell.__dict__.update(state)
        return shell

    def _texture_coordinates(self, mesh: Any, uv: Any, scale: npt.NDArray[np.float64]) -> tuple[Any, str]:
        nv, nf = len(self.vertices), len(self.faces)
        if uv is not None:
            a = np.asarray(_check.array("uv", uv), dtype=np.float64)
            if a.shape == (nv, 2):
                a = a[self.faces]
            if a.shape != (nf, 3, 2) or not np.isfinite(a).all() or np.abs(a).max(initial=0.0) > _MAX_TILES:
                raise ParameterError(f"uv must be finite (V, 2) = ({nv}, 2) or (F, 3, 2) = ({nf}, 3, 2), "
                                     f"at most {_MAX_TILES:g} tiles from 0, got shape {a.shape}")
            return np.ascontiguousarray(a), "given"
        if mesh.uv is not None:
            return np.ascontiguousarray(np.asarray(mesh.uv, dtype=np.float64)[self.faces] * scale), "mesh"
        return np.ascontiguousarray(box_uv(self.vertices, self.faces) * scale), "box"

    def _to_core(self) -> _core.GdmShell:
        """The extension's copy the renderer draws (made once; the kinds table's ``to_core``)."""
        if getattr(self, "_drawn", None) is None:
            self._drawn = _core.GdmShell(
                self.vertices, self.normals, np.ascontiguousarray(self.faces, dtype=np.uint32), self.uv,
                self.thickness, self.volume._core, self.color, self.pieces,
                None if self.lookup is None else (np.ascontiguousarray(self.lookup.weights),
                                                  np.ascontiguousarray(self.lookup.eigen), self.refine,
                                                  self.lookup.conservative),
                getattr(self, "count_steps", False))
        return self._drawn

    @property
    def bounds(self) -> npt.NDArray[np.float64]:
        """(2, 3) object-space box of the prisms: the base and its extrusion by ``thickness``."""
        corners = np.concatenate([self.vertices, self.vertices + self.normals * self.thickness])
        return np.stack([corners.min(axis=0), corners.max(axis=0)])

    def tile_surface(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
        """The tile's surface over one period (``tile_surface`` of this shell's volume)."""
        return tile_surface(self.volume)

    def to_mesh(self) -> Any:
        """The explicit reference: the tile's surface clipped to every prism's texture triangle and
        mapped through the prism's map, as a trimesh.Trimesh (welded); where a texture seam
        (``seam_fins``) cuts the solid, a cap on the fin closes it, as the renderer sees it."""
        import trimesh

        tv, tf = self.tile_surface()
        v, f = _core.gdm_explicit_mesh(
            self.vertices, self.normals, np.ascontiguousarray(self.faces, dtype=np.uint32), self.uv,
            self.thickness, self.volume._core, tv, np.ascontiguousarray(tf, dtype=np.uint32),
            seam_fins(self.vertices, self.faces, self.uv))
        mesh = trimesh.Trimesh(v, f.astype(np.int64), process=True)
        # Clipping near a prism's corners leaves slivers that welding folds onto their neighbours.
        mesh.update_faces(mesh.nondegenerate_faces(height=1e-12))
        mesh.update_faces(mesh.unique_faces())
        mesh.remove_unreferenced_vertices()
        return mesh


def uv_torus(major: float = 1.0, minor: float = 0.35, sections: tuple[int, int] = (48, 24)) -> tuple[Any, Any]:
    """A torus base mesh with continuous texture coordinates: (trimesh.Trimesh, (V, 2) uv in
    [0, 1] around the ring and the tube). Vertices repeat along the two seams so uv can run from
    0 to 1; with whole tile counts the mesostructure continues across them. ``major`` > 0,
    0 < ``minor`` < ``major`` (the tube's radius, so the ring does not cross itself) and
    ``sections`` two integers (around the ring, around the tube), each 3 to 4096."""
    import trimesh

    major = _check.real("major", major, 0.0, lo_open=True)
    minor = _check.real("minor", minor, 0.0, major, lo_open=True, hi_open=True)
    nu, nv = _check.counts("sections", sections, 3, (4096, 4096), "two integers (ring, tube), each 3 to 4096")
    u, v = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1), indexing="ij")
    a, b = 2 * np.pi * u, 2 * np.pi * v
    ring = major + minor * np.cos(b)
    pts = np.stack([ring * np.cos(a), ring * np.sin(a), minor * np.sin(b)], axis=-1).reshape(-1, 3)
    idx = np.arange((nu + 1) * (nv + 1)).reshape(nu + 1, nv + 1)
    q = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]], axis=-1).reshape(-1, 4)
    faces = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    return trimesh.Trimesh(pts, faces, process=False), np.stack([u, v], axis=-1).reshape(-1, 2)
