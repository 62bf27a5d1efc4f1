"""How faithfully conversion carries a mesh's colors: ``frame.albedo`` (the unshaded base color
of the rendered geometry textures) against trimesh ray casting of the original mesh with its
colors looked up independently in numpy (``reference.raycast_albedo``: the hit's texture
coordinate sampled bilinearly, or the face color).

Meshes: spot with its texture (``spot_texture.png``, 1024²) and the Stanford bunny with face
colors from a smooth function of position (``testing.shapes.face_colored``); five views each.
Figure: mean absolute RGB difference (0-255 units) on interior pixels (both hit, two pixels in
from any silhouette against the background), and its p99. Issue target: mean ≤ 3/255.

Results: ``bench/results/appearance_colors.json`` and, per mesh, a PNG pair (top row ours, bottom
row the reference; halved above 256²) ``bench/results/appearance_colors_<mesh>.png``.

Run from the repository root::

    python bench/appearance_colors.py            # 512²
    python bench/appearance_colors.py --size 256
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

import geomtex as gt
from geomtex import reference
from geomtex.testing.shapes import face_colored
from geomtex.testing.views import look_from

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "bench" / "results"
MESHES = Path("/work/shared/meshes")
# Both meshes stand with +y up; no view runs along y.
VIEWS = [(1.0, 0.3, 0.2), (-1.0, 0.2, 0.3), (0.3, 0.2, 1.0), (0.2, 0.4, -1.0), (0.4, -0.8, 0.5)]
DISTANCE = 1.1  # diagonals from the centre: the mesh fills most of the image
MAX_RESOLUTION = 256


def spot() -> gt.Mesh:
    """spot.obj with its texture: the OBJ names no material, so the image is attached here."""
    import trimesh
    from PIL import Image

    tm = trimesh.load(MESHES / "spot.obj", force="mesh", process=False)
    tm.visual = trimesh.visual.TextureVisuals(uv=tm.visual.uv, image=Image.open(MESHES / "spot_texture.png"))
    return gt.Mesh.from_trimesh(tm)


def bunny() -> gt.Mesh:
    return face_colored(gt.load_mesh(MESHES / "stanford-bunny.obj"))


def measure(size: int = 512, out: Path | None = OUT) -> dict[str, Any]:
    """Per mesh and view: the albedo difference against the reference (``mean``, ``p99``,
    ``interior_px``); PNG pairs written under ``out`` unless it is None."""
    renderer = gt.Renderer(size, size)
    results: dict[str, Any] = {"size": size, "max_resolution": MAX_RESOLUTION, "meshes": {}}
    for name, make in [("spot", spot), ("bunny_face_colors", bunny)]:
        mesh = make()
        gts = gt.convert(mesh, max_resolution=MAX_RESOLUTION)
        rows: list[dict[str, Any]] = []
        ours, theirs = [], []
        for view in VIEWS:
            camera = look_from(mesh, view, distance=DISTANCE, up=(0.0, 1.0, 0.0))
            frame = renderer.render(gts, camera)
            ref = reference.raycast_albedo(mesh, camera, size, size)
            rows.append({"view": list(view), **reference.albedo_difference(frame.albedo, ref, np.isfinite(frame.depth))})
            ours.append(frame.albedo)
            theirs.append(ref["albedo"])
        results["meshes"][name] = {"faces": mesh.n_faces, "charts": gts.stats["charts"], "views": rows,
                                   "mean": float(np.mean([r["mean"] for r in rows]))}
        if out is not None:
            save_pair(out / f"appearance_colors_{name}.png", ours, theirs)
    return results


def save_pair(path: Path, ours: list[Any], theirs: list[Any]) -> None:
    """Top row ours, bottom row the reference, on white."""
    from PIL import Image

    def row(images: list[Any]) -> Any:
        rgba = np.concatenate(images, axis=1).astype(np.float64)
        alpha = rgba[..., 3:] / 255.0
        return rgba[..., :3] * alpha + 255.0 * (1.0 - alpha)

    picture = Image.fromarray(np.round(np.concatenate([row(ours), row(theirs)], axis=0)).astype(np.uint8))
    if ours[0].shape[0] > 256:  # keeps the files small; the figures come from the full frames
        picture = picture.resize((picture.width // 2, picture.height // 2), Image.Resampling.BOX)
    path.parent.mkdir(parents=True, exist_ok=True)
    picture.save(path, optimize=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=512)
    args = ap.parse_args()
    results = measure(args.size)
    print(f"{'mesh':<20}{'view':<22}{'mean':>8}{'p99':>8}{'interior px':>13}")
    for name, m in results["meshes"].items():
        for r in m["views"]:
            view = ", ".join(f"{v:+.1f}" for v in r["view"])
            print(f"{name:<20}{view:<22}{r['mean']:>8.2f}{r['p99']:>8.1f}{r['interior_px']:>13}")
        print(f"{name:<20}{'all views':<22}{m['mean']:>8.2f}")
    path = OUT / "appearance_colors.json"
    write_json(path, results, indent=1)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
