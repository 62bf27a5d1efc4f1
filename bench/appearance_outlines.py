"""Exact outlines (issue 16): how closely rendered geometry textures end where the mesh ends.

Meshes: a flat gear with 40 teeth (``geomtex.testing.gear_plate``, one planar chart with an
intricate outline), pymeshlab's bundled bunny (open: holes in its base) and fandisk (CAD creases
and chart borders; skipped when ``../shared/meshes`` is absent). Each converted with the default
keywords and seen from five views at ``size``² (plus the gear from the front), rendered with the
default (balanced, linear + binary) search and the exact (max-pyramid) one, against trimesh's ray
cast of the mesh from the same camera:

- ``iou``: coverage IoU of the two hit masks (the issue's floor: >= 0.995 in every view);
- ``crack_px``: pixels the reference hits and we miss, inside its silhouette eroded by a pixel;
- ``only_ref_px`` / ``only_frame_px``: pixels hit by one side only.

"Before" is the same mesh converted by a checkout of a commit before outline maps
(``--before`` or the environment variable GEOMTEX_BEFORE_CHECKOUT, e.g. a worktree of 0f50b19
with its module built; without one the before column is skipped; the surface then ends at the
texel grid, half a texel diagonal past the outline) in a subprocess, saved as .gtex (its version
has no outline map, read here as everywhere inside) and rendered by this build: the renderer is
the same, only the maps differ. Its git commit is recorded.

Results: ``bench/results/appearance_outlines.json``. Run from the repository root::

    python bench/appearance_outlines.py            # 512², ~2 min on lavapipe
    python bench/appearance_outlines.py --size 256
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

import geomtex as gt
from geomtex import reference
from geomtex.testing import gear_plate, look_from

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "bench" / "results"
SHARED = REPO.parent / "shared" / "meshes"
DEFAULT_BEFORE = Path(os.environ.get("GEOMTEX_BEFORE_CHECKOUT", "/nonexistent"))

# Five directions that see each mesh's outline from the side it faces, none edge-on.
VIEWS = [(1.0, 0.3, 0.5), (-0.6, 1.0, 0.3), (0.2, -0.8, 0.6), (-1.0, -0.4, 0.7), (0.4, 0.5, -0.8)]
GEAR_VIEWS = [(0.0, 0.0, 1.0), (0.3, 0.2, 1.0), (1.0, 0.0, 0.6), (-0.5, 0.7, 0.5), (0.2, -1.0, 0.3),
              (-0.7, -0.6, 0.6)]


def meshes() -> dict[str, tuple[gt.Mesh, list[tuple[float, float, float]], float]]:
    """Name → (mesh, view directions, camera distance in diagonals)."""
    import pymeshlab

    bunny = Path(pymeshlab.__file__).parent / "tests" / "sample_meshes" / "bunny.obj"
    out = {"gear_plate": (gear_plate(), GEAR_VIEWS, 1.2), "open_bunny": (gt.load_mesh(bunny), VIEWS, 1.5)}
    fandisk = SHARED / "fandisk.obj"
    if fandisk.exists():
        out["fandisk"] = (gt.load_mesh(fandisk), VIEWS, 1.5)
    return out


_BEFORE_SCRIPT = """
import sys, numpy as np, geomtex as gt
data = np.load(sys.argv[1])
gt.convert(gt.Mesh(data["vertices"], data["faces"])).save(sys.argv[2])
"""


def before_set(mesh: gt.Mesh, before: Path) -> gt.GeometryTextureSet | None:
    """The mesh converted by the checkout at ``before`` (its own built module), or None."""
    package = before / "python"
    if not (package / "geomtex").is_dir() or not list((package / "geomtex").glob("_core*.so")):
        return None
    from geomtex.testing._arrays import arrays

    v, f = arrays(mesh)
    with tempfile.TemporaryDirectory() as tmp:
        np.savez(Path(tmp) / "mesh.npz", vertices=v, faces=f)
        env = dict(os.environ, PYTHONPATH=str(package))
        subprocess.run([sys.executable, "-c", _BEFORE_SCRIPT, str(Path(tmp) / "mesh.npz"), str(Path(tmp) / "set.gtex")],
                       check=True, env=env, cwd=tmp)
        return gt.load(Path(tmp) / "set.gtex")


def _figures(frame: Any, ref: dict[str, Any], diagonal: float) -> dict[str, Any]:
    m = reference.compare(frame, ref, diagonal)
    return {k: m[k] for k in ("iou", "crack_px", "only_ref_px", "only_frame_px")}


def measure(size: int = 512, before: Path = DEFAULT_BEFORE) -> dict[str, Any]:
    """Per mesh and view: IoU and crack pixels after (balanced and exact search) and before."""
    renderer = gt.Renderer(size, size)
    results: dict[str, Any] = {"size": size, "meshes": {}}
    commit = subprocess.run(["git", "-C", str(before), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip() if before.is_dir() else ""
    results["before"] = {"checkout": str(before), "commit": commit or None}
    for name, (mesh, views, distance) in meshes().items():
        after = gt.convert(mesh)
        old = before_set(mesh, before)
        caster = reference.RayCaster(mesh)
        diagonal = mesh.diagonal
        rows = []
        for direction in views:
            camera = look_from(mesh, direction, distance=distance)
            ref = caster.cast(camera, size, size)
            row: dict[str, Any] = {"view": list(direction)}
            row["after"] = _figures(renderer.render(after, camera), ref, diagonal)
            row["after_exact"] = _figures(renderer.render(after, camera, quality="exact"), ref, diagonal)
            row["before"] = None if old is None else _figures(renderer.render(old, camera), ref, diagonal)
            rows.append(row)
        results["meshes"][name] = {"faces": len(mesh.faces), "charts": len(after), "views": rows}
    every = [r[k]["iou"] for m in results["meshes"].values() for r in m["views"] for k in ("after", "after_exact")]
    results["min_iou_after"] = float(min(every))
    results["crack_px_after"] = int(sum(r[k]["crack_px"] for m in results["meshes"].values() for r in m["views"]
                                        for k in ("after", "after_exact")))
    return results


def _table(results: dict[str, Any]) -> str:
    def cell(figures: dict[str, Any] | None) -> str:
        return "      -       " if figures is None else f"{figures['iou']:.5f} {figures['crack_px']:>4d}"

    lines = [f"size {results['size']}²; before: {results['before']['checkout']} @ {results['before']['commit']}",
             f"{'mesh':<11} {'view':<20} {'before iou/crack':>17} {'after iou/crack':>17} {'exact iou/crack':>17}"]
    for name, m in results["meshes"].items():
        for r in m["views"]:
            view = "(" + ", ".join(f"{x:g}" for x in r["view"]) + ")"
            lines.append(f"{name:<11} {view:<20} {cell(r['before']):>17} {cell(r['after']):>17} "
                         f"{cell(r['after_exact']):>17}")
    lines.append(f"min IoU after: {results['min_iou_after']:.5f} (floor 0.995); crack pixels after: "
                 f"{results['crack_px_after']}")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--before", type=Path, default=DEFAULT_BEFORE)
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    results = measure(args.size, args.before)
    print(_table(results))
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / "appearance_outlines.json", results, indent=1)


if __name__ == "__main__":
    main()
