"""Benchmark of mesh -> geometry-texture conversion (``geomtex.convert``).

For every test mesh in ``../shared/meshes/*.obj`` (next to the repository) this measures:

* speed: best wall time of ``--repeats`` runs of ``convert(frame="min_area")`` with the
  per-stage seconds of that run, and one run with ``frame="pca"`` (the paper's frame);
* structure: faces, charts, folding charts before/after repair, inverted triangles,
  empty-texel fraction for both frames, and texture bytes;
* accuracy of the default conversion against independent references:
  texel points -> mesh distance (trimesh closest point, 20,000 seeded samples; RMS and
  max) and mesh -> texel points coverage (200,000 surface samples, nearest texel point via
  a k-d tree; 99th percentile and max), all divided by the bounding-box diagonal;
* xatlas (``Atlas.add_mesh`` + ``generate`` + ``get_mesh``, i.e. what
  ``xatlas.parametrize`` does) run once per mesh for its time and chart count.

Results go to ``bench/results/convert.json`` and ``bench/results/convert.png``; a table is
printed next to the paper's bunny figures.

Run from the repository root::

    python bench/convert.py                      # all meshes, with xatlas
    python bench/convert.py --meshes bunny spot --no-xatlas --repeats 1
"""

from __future__ import annotations

import argparse
import gc
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import scipy.spatial
import trimesh
from tqdm import tqdm

import geomtex as gt

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

from render import _version  # noqa: E402
from render import machine_info as common_machine_info  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
MESH_DIR = REPO.parent / "shared" / "meshes"
STAGES = ("geometry", "partition", "repair", "overlap", "frame", "raster", "dilate")
MAX_RESOLUTION = 256
N_POINT_SAMPLES = 20_000
N_SURFACE_SAMPLES = 200_000

# Figures reported by the paper for the Stanford bunny.
PAPER_BUNNY = {
    "faces": 69_451,
    "vsa_seconds": 184.0,
    "charts": 222,
    "folding_charts": 3,
    "empty_percent": 38.8,
}


# --------------------------------------------------------------------------- inputs


def find_meshes(names: list[str] | None) -> list[Path]:
    """The benchmark meshes, optionally filtered by (sub)strings of their names."""
    paths = sorted(MESH_DIR.glob("*.obj")) if MESH_DIR.is_dir() else []
    if not paths:
        import pymeshlab

        fallback = Path(pymeshlab.__file__).parent / "tests" / "sample_meshes" / "bunny.obj"
        print(f"No meshes in {MESH_DIR}; falling back to pymeshlab's {fallback}")
        paths = [fallback]
    if names:
        paths = [p for p in paths if any(n in p.stem for n in names)]
        if not paths:
            raise SystemExit(f"no mesh matches {names}")
    return paths


def machine_info() -> dict[str, Any]:
    """The machine and versions (shared with the other benchmarks), plus xatlas and our settings."""
    info = common_machine_info()
    info["versions"]["xatlas"] = _version("xatlas")
    info["max_resolution"] = MAX_RESOLUTION
    return info


# --------------------------------------------------------------------------- measurements


def timed_convert(mesh: gt.Mesh, frame: str, repeats: int) -> tuple[gt.GeometryTextureSet, dict]:
    """Converts ``repeats`` times and keeps the fastest run (by wall time)."""
    best, best_wall, walls = None, float("inf"), []
    for _ in range(repeats):
        t0 = time.perf_counter()
        gts = gt.convert(mesh, max_resolution=MAX_RESOLUTION, frame=frame)
        wall = time.perf_counter() - t0
        walls.append(wall)
        if wall < best_wall:
            best, best_wall = gts, wall
        del gts
        gc.collect()
    # Per-patch arrays (patch_error, patch_resolution) as lists, so the record is plain JSON.
    stats = {k: v.tolist() if hasattr(v, "tolist") else v for k, v in best.stats.items()}
    stats["seconds"] = dict(stats["seconds"])
    stats["wall_seconds"] = best_wall
    stats["wall_seconds_runs"] = walls
    return best, stats


def accuracy(mesh: gt.Mesh, points: np.ndarray, seed: int = 0) -> dict[str, float]:
    """Texel points vs. mesh surface distances, divided by the bounding-box diagonal.

    trimesh's closest-point test uses absolute tolerances, so mesh and points are scaled
    to a diagonal of 1000 first; the distances are divided by 1000 afterwards.
    """
    diag = float(mesh.diagonal)
    k = 1000.0 / diag
    tm = trimesh.Trimesh(np.asarray(mesh.vertices) * k, np.asarray(mesh.faces), process=False)
    rng = np.random.default_rng(seed)

    n = min(N_POINT_SAMPLES, len(points))
    sample = points[rng.choice(len(points), n, replace=False)] * k
    _, dist, _ = trimesh.proximity.closest_point(tm, sample)
    dist = dist / 1000.0

    surface, _ = trimesh.sample.sample_surface(tm, N_SURFACE_SAMPLES, seed=1)
    tree = scipy.spatial.cKDTree(points * k)
    cover, _ = tree.query(surface, workers=-1)
    cover = cover / 1000.0

    return {
        "points_to_mesh_rms": float(np.sqrt(np.mean(dist**2))),
        "points_to_mesh_max": float(dist.max()),
        "coverage_p99": float(np.percentile(cover, 99)),
        "coverage_max": float(cover.max()),
        "points_sampled": int(n),
        "points_total": int(len(points)),
    }


def run_xatlas(vertices: np.ndarray, faces: np.ndarray) -> dict[str, float | int]:
    """One xatlas run; the Atlas calls are those ``xatlas.parametrize`` makes."""
    import xatlas

    v = np.ascontiguousarray(vertices, dtype=np.float32)
    f = np.ascontiguousarray(faces, dtype=np.uint32)
    t0 = time.perf_counter()
    atlas = xatlas.Atlas()
    atlas.add_mesh(v, f)
    atlas.generate()
    atlas.get_mesh(0)
    seconds = time.perf_counter() - t0
    return {"seconds": seconds, "charts": int(atlas.chart_count), "utilization": float(atlas.utilization)}


def bench_mesh(path: Path, repeats: int, with_xatlas: bool) -> dict[str, Any]:
    mesh = gt.load_mesh(str(path))
    gts, default = timed_convert(mesh, "min_area", repeats)
    points, _ = gts.to_points()
    del gts
    acc = accuracy(mesh, points)
    del points
    gc.collect()
    _, pca = timed_convert(mesh, "pca", 1)
    gc.collect()

    record: dict[str, Any] = {
        "mesh": path.stem,
        "path": str(path),
        "faces": int(mesh.n_faces),
        "vertices": int(mesh.n_vertices),
        "diagonal": float(mesh.diagonal),
        "charts": default["charts"],
        "folding_charts_before_repair": default["folding_charts_before_repair"],
        "folding_charts": default["folding_charts"],
        "inverted_triangles_before_repair": default["inverted_triangles_before_repair"],
        "inverted_triangles": default["inverted_triangles"],
        "empty_fraction_min_area": default["empty_fraction"],
        "empty_fraction_pca": pca["empty_fraction"],
        "bytes": default["bytes"],
        "texel_size_over_diagonal": default["texel_size"] / float(mesh.diagonal),
        "seconds": default["wall_seconds"],
        "stage_seconds": {s: default["seconds"][s] for s in STAGES},
        "pca_seconds": pca["wall_seconds"],
        "accuracy": acc,
        "stats_min_area": default,
        "stats_pca": pca,
        "xatlas": None,
    }
    if with_xatlas:
        xa = run_xatlas(np.asarray(mesh.vertices), np.asarray(mesh.faces))
        xa["ratio"] = xa["seconds"] / record["seconds"]
        record["xatlas"] = xa
    return record


# --------------------------------------------------------------------------- reporting


def format_table(records: list[dict[str, Any]]) -> str:
    header = (
        "mesh", "faces", "charts", "folding", "empty % (min_area/pca)", "MB",
        "geomtex s", "xatlas s", "ratio", "pts->mesh RMS/diag", "coverage p99/diag", "texel/diag",
    )
    rows = []
    for r in records:
        xa = r["xatlas"]
        rows.append((
            r["mesh"],
            f"{r['faces']:,}",
            str(r["charts"]),
            f"{r['folding_charts_before_repair']}->{r['folding_charts']}",
            f"{100 * r['empty_fraction_min_area']:.1f} / {100 * r['empty_fraction_pca']:.1f}",
            f"{r['bytes'] / 1e6:.1f}",
            f"{r['seconds']:.2f}",
            f"{xa['seconds']:.2f}" if xa else "-",
            f"{xa['ratio']:.1f}x" if xa else "-",
            f"{r['accuracy']['points_to_mesh_rms']:.1e}",
            f"{r['accuracy']['coverage_p99']:.1e}",
            f"{r['texel_size_over_diagonal']:.1e}",
        ))
    widths = [max(len(h), *(len(row[i]) for row in rows)) for i, h in enumerate(header)]
    line = lambda cells: "  ".join(  # noqa: E731
        c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(cells, widths))
    )
    out = [line(header), line(["-" * w for w in widths])]
    out += [line(row) for row in rows]
    p = PAPER_BUNNY
    out.append("")
    out.append(
        f"paper (bunny): {p['faces']:,} faces, VSA {p['vsa_seconds']:.0f} s, {p['charts']} charts, "
        f"{p['folding_charts']} folding charts, {p['empty_percent']}% empty texels"
    )
    return "\n".join(out)


def plot(records: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [r["mesh"] for r in records]
    x = np.arange(len(records))
    fig, (ax_stage, ax_total, ax_empty) = plt.subplots(1, 3, figsize=(17, 5.2))

    # Per-stage seconds of the default conversion, stacked.
    bottom = np.zeros(len(records))
    colors = plt.get_cmap("tab10").colors
    for i, stage in enumerate(STAGES):
        vals = np.array([r["stage_seconds"][stage] for r in records])
        ax_stage.bar(x, vals, bottom=bottom, label=stage, color=colors[i])
        bottom += vals
    ax_stage.set_title(f"geomtex stages (min_area, res {MAX_RESOLUTION}, best of runs)")
    ax_stage.set_ylabel("seconds")
    ax_stage.legend(fontsize=8)

    # Total time: geomtex vs xatlas, log scale.
    width = 0.38
    ax_total.bar(x - width / 2, [r["seconds"] for r in records], width, label="geomtex", color="tab:blue")
    if any(r["xatlas"] for r in records):
        xa = [r["xatlas"]["seconds"] if r["xatlas"] else np.nan for r in records]
        ax_total.bar(x + width / 2, xa, width, label="xatlas", color="tab:gray")
        for xi, r in zip(x, records):
            if r["xatlas"]:
                ax_total.annotate(f"{r['xatlas']['ratio']:.1f}x", (xi + width / 2, r["xatlas"]["seconds"]),
                                  ha="center", va="bottom", fontsize=8)
    ax_total.set_yscale("log")
    ax_total.set_ylim(top=ax_total.get_ylim()[1] * 2)  # room for the ratio labels
    ax_total.set_title("total seconds (log scale)")
    ax_total.set_ylabel("seconds")
    ax_total.legend(fontsize=8)

    # Empty texels for both frames against the paper's bunny figure.
    ax_empty.bar(x - width / 2, [100 * r["empty_fraction_min_area"] for r in records], width,
                 label="min_area", color="tab:green")
    ax_empty.bar(x + width / 2, [100 * r["empty_fraction_pca"] for r in records], width,
                 label="pca", color="tab:olive")
    ax_empty.axhline(PAPER_BUNNY["empty_percent"], color="k", ls="--", lw=1,
                     label=f"paper bunny ({PAPER_BUNNY['empty_percent']}%)")
    ax_empty.set_ylim(0, max(52.0, ax_empty.get_ylim()[1] * 1.25))
    ax_empty.set_title("empty texels")
    ax_empty.set_ylabel("% of texels")
    ax_empty.legend(fontsize=8, loc="upper center", ncol=3)

    for ax in (ax_stage, ax_total, ax_empty):
        ax.set_xticks(x, names, rotation=25, ha="right")
        ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# --------------------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--meshes", nargs="+", metavar="NAME",
                        help="only meshes whose file name contains one of these")
    parser.add_argument("--no-xatlas", action="store_true", help="skip the xatlas comparison")
    parser.add_argument("--repeats", type=int, default=3, help="runs of the default conversion (best kept)")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results", help="output folder")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")

    paths = find_meshes(args.meshes)
    records = []
    for path in tqdm(paths, desc="meshes", unit="mesh"):
        records.append(bench_mesh(path, args.repeats, not args.no_xatlas))
        tqdm.write(f"{path.stem}: {records[-1]['seconds']:.2f} s")

    print()
    print(format_table(records))

    args.out.mkdir(parents=True, exist_ok=True)
    result = {
        "machine": machine_info(),
        "settings": {"repeats": args.repeats, "max_resolution": MAX_RESOLUTION,
                     "point_samples": N_POINT_SAMPLES, "surface_samples": N_SURFACE_SAMPLES,
                     "xatlas": not args.no_xatlas},
        "paper_bunny": PAPER_BUNNY,
        "meshes": records,
    }
    json_path = args.out / "convert.json"
    write_json(json_path, result, indent=2)
    png_path = args.out / "convert.png"
    plot(records, png_path)
    print(f"\nwrote {json_path} and {png_path}")


if __name__ == "__main__":
    main()
