"""Why a displacement shell's normals miss its explicit mesh's (issue 18): a CPU model, no
renderer. The renderer draws the occupancy's trilinear 0.5 level set; ``Shell.to_mesh()`` maps
the tile's marching-cubes triangles, which are chords of that level set (their vertices lie on
cell edges, where the field is linear). For every triangle of a tile's marching-cubes surface,
this compares its normal with the normal the renderer would write at the level-set point beside
the triangle's centre (found by bisection along the triangle's normal), both taken through a
diagonal map from voxels to world units like a prism's over the bench's bases (the voxel's width
along the surface, its height thickness / nz): for central differences half and one voxel wide
and for the trilinear field's own gradient in the point's cell. The figure is the
area-weighted median angle, close to bench/gdm.py's pixel medians where the views see the
tile's facets evenly.

Results: ``bench/results/gdm_normals.json``. Run from the repository root::

    python bench/gdm_normals.py                      # seconds
"""

from __future__ import annotations

import datetime
import os
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

from geomtex import gdm

OUT = Path(__file__).resolve().parents[1] / "bench" / "results"
# Voxel width along the surface and shell thickness (world units) of bench/gdm.py's bases: the
# torus (12 tiles around a unit ring, 0.08 thick) and the bunny (10 tiles across its 0.624-wide
# box, 1.2% of its 1.0 diagonal).
BASES = {"torus": (2 * np.pi / 12 / 64, 0.08), "bunny": (0.624 / 10 / 64, 0.012)}
CORNERS = np.array([[k & 1, (k >> 1) & 1, (k >> 2) & 1] for k in range(8)])


def corner_values(occ: npt.NDArray[np.float64], t: npt.NDArray[np.float64]) -> tuple[Any, Any]:
    """The occupancy at the 8 voxel centres around each texture point (x, y wrapped, empty outside
    z) and the point's position within that cell."""
    nx, ny, nz = occ.shape
    s = t - 0.5
    base = np.floor(s).astype(int)
    values = np.zeros((len(t), 8))
    for k, o in enumerate(CORNERS):
        v = base + o
        ok = (v[:, 2] >= 0) & (v[:, 2] < nz)
        values[ok, k] = occ[v[ok, 0] % nx, v[ok, 1] % ny, v[ok, 2]]
    return values, s - base


def field(occ: npt.NDArray[np.float64], t: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    values, f = corner_values(occ, t)
    weights = np.prod(np.where(CORNERS[None] == 1, f[:, None], 1 - f[:, None]), axis=2)
    return (values * weights).sum(axis=1)


def gradient_in_cell(occ: npt.NDArray[np.float64], t: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    values, f = corner_values(occ, t)
    w = np.where(CORNERS[None] == 1, f[:, None], 1 - f[:, None])  # (n, 8, 3)
    sign = 2.0 * CORNERS - 1.0
    g = np.zeros_like(t)
    for a in range(3):
        b, c = [x for x in range(3) if x != a]
        g[:, a] = (values * sign[None, :, a] * w[:, :, b] * w[:, :, c]).sum(axis=1)
    return g


def central_differences(occ: npt.NDArray[np.float64], t: npt.NDArray[np.float64], e: float) -> npt.NDArray[np.float64]:
    return np.stack([field(occ, t + e * np.eye(3)[a]) - field(occ, t - e * np.eye(3)[a]) for a in range(3)], axis=1)


def on_level_set(occ: npt.NDArray[np.float64], c: npt.NDArray[np.float64], n: npt.NDArray[np.float64]) -> Any:
    """The field's 0.5 crossing within a voxel of each point along its unit direction."""
    lo, hi = c - n, c + n
    inside_lo = field(occ, lo) >= 0.5
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        same = (field(occ, mid) >= 0.5) == inside_lo
        lo = np.where(same[:, None], mid, lo)
        hi = np.where(same[:, None], hi, mid)
    return 0.5 * (lo + hi)


def weighted_median(x: npt.NDArray[np.float64], w: npt.NDArray[np.float64]) -> float:
    order = np.argsort(x)
    cum = np.cumsum(w[order])
    return float(x[order][np.searchsorted(cum, cum[-1] / 2)])


def case(pattern: str, nz: int, base: str) -> dict[str, Any]:
    vol = gdm.Volume.procedural(pattern, (64, 64, nz))  # type: ignore[arg-type]
    width, thickness = BASES[base]
    scale = np.array([width, width, thickness / nz])
    # The tile's surface as to_mesh() takes it (the shell's base and thickness do not enter it).
    v, f = gdm.tile_surface(vol)
    tri = v[f]
    n_tex = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = np.linalg.norm(np.cross((tri[:, 1] - tri[:, 0]) * scale, (tri[:, 2] - tri[:, 0]) * scale), axis=1)
    n_world = n_tex / scale  # normals map by the inverse transpose
    n_world /= np.linalg.norm(n_world, axis=1, keepdims=True)
    p = on_level_set(vol.occupancy.astype(float), tri.mean(axis=1), n_tex / np.linalg.norm(n_tex, axis=1, keepdims=True))
    occ = vol.occupancy.astype(float)
    out: dict[str, Any] = {"pattern": pattern, "nz": nz, "base": base, "voxel_aspect": float(scale[2] / scale[0])}
    for name, g in (("differences_half_voxel", central_differences(occ, p, 0.5)),
                    ("differences_one_voxel", central_differences(occ, p, 1.0)),
                    ("gradient_in_cell", gradient_in_cell(occ, p))):
        gw = g / scale
        gw /= np.linalg.norm(gw, axis=1, keepdims=True) + 1e-300
        angle = np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", gw, n_world)), 0, 1)))
        out[name] = {"median_deg": weighted_median(angle, area), "exact_share": float(area[angle < 0.5].sum() / area.sum())}
    return out


def main() -> None:
    results: dict[str, Any] = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(),
                               "load": os.getloadavg(), "cases": []}
    for base in BASES:
        for pattern in ("chain", "weave"):
            for nz in (16, 32):
                c = case(pattern, nz, base)
                results["cases"].append(c)
                print(f"{base:5} {pattern:5} nz={nz:2} aspect {c['voxel_aspect']:.2f}: " + ", ".join(
                    f"{k} {c[k]['median_deg']:.2f} deg ({c[k]['exact_share']:.0%} within 0.5)"
                    for k in ("differences_half_voxel", "differences_one_voxel", "gradient_in_cell")), flush=True)
    OUT.mkdir(parents=True, exist_ok=True)
    write_json(OUT / "gdm_normals.json", results, indent=1)


if __name__ == "__main__":
    main()
