"""Command line: convert a mesh file to geometry textures, write the .gtex, a PNG and a stats table.

    python -m geomtex                      # the bunny that ships inside geomtex (gt.data.bunny())
    python -m geomtex mesh.obj -o out/ --max-resolution 512
    python -m geomtex info                 # adapter, features, limits and a self-check per kind
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

import geomtex as gt
from geomtex._files import save_image
from geomtex._preview import overview


def default_mesh() -> tuple[Path, gt.Mesh]:
    """The 56,172-face watertight bunny bundled with geomtex (gt.data.bunny()) and the file it
    ships in, whose stem names the outputs: every install has a real mesh."""
    return Path(gt.data.__file__).with_name("bunny.npz"), gt.data.bunny()


def _charts_row(st: dict[str, Any]) -> str:
    partition = "cone partition" if st.get("cone_partition", 0) else "VSA"
    row = f"{st['charts']} ({partition} {st['vsa_charts']}, +{st['repair_splits']} by repair"
    return row + (f", {st['sheet_splits']} of them for two-sheet charts)" if st.get("sheet_splits") else ")")


def _texel_row(st: dict[str, Any]) -> str:
    row = f"{st['texel_size']:.4g} ({st['texel_size'] / st['diagonal']:.2e} of the diagonal)"
    if "max_error" not in st:
        return row + ", one for every patch"
    levels = len(set(np.round(np.log2(st["patch_texel"]), 6)))
    return row + f", the finest of {levels} texel sizes chosen per patch (error-driven)"


def _bound_row(st: dict[str, Any]) -> str:
    over = st["charts_over_max_error"]
    # Charts stay over the bound at the resolution cap, or, where the byte budget binds, at the
    # level the budget allowed; the stats do not say which held back which chart.
    held = "the byte budget or the resolution cap held them back" if st.get("max_bytes_binding") \
        else "at the resolution cap"
    row = f"{st['max_error'] / st['diagonal']:.2e} of the diagonal"
    row += f" ({over} charts over it: {held})" if over else ""
    if st.get("max_bytes_binding") and st["reconstruction_error_p99"] > st["max_error"]:
        row += f"; missed within the byte budget: p99 {st['reconstruction_error_p99'] / st['max_error']:.2f}x it"
    return row


def stats_table(gts: gt.GeometryTextureSet) -> str:
    """The conversion's figures as a two-column table; each row says only what the stats show."""
    st = gts.stats
    rows = [
        ("faces", f"{st['faces']:,} ({st['degenerate_faces']} degenerate)"),
        ("patches", _charts_row(st)),
        ("folding charts", f"{st['folding_charts']} (before repair: {st['folding_charts_before_repair']})"),
        ("inverted triangles", f"{st['inverted_triangles']} (before repair: {st['inverted_triangles_before_repair']})"),
        ("texels", f"{st['texels']:,} ({100 * st['empty_fraction']:.1f}% empty)"),
        ("texel size", _texel_row(st)),
        ("bytes", f"{st['bytes'] / 1e6:.2f} MB ({st['bytes'] / st['mesh_bytes']:.2f}x the mesh's)"
                  if "mesh_bytes" in st else f"{st['bytes'] / 1e6:.2f} MB of maps"),
        *([("kept as triangles", f"{st['triangle_faces']:,} faces in {st['triangle_clusters']} clusters "
                                 f"({st['triangle_bytes'] / 1e6:.2f} MB; maps {st['patch_bytes'] / 1e6:.2f} MB)")]
          if st.get("hybrid") else []),
        ("reconstruction error", f"p99 {st['reconstruction_error_p99'] / st['diagonal']:.2e}, "
                                 f"max {st['reconstruction_error_max'] / st['diagonal']:.2e} of the diagonal"),
        *([("error bound", _bound_row(st))] if "max_error" in st else []),
        ("mesh repairs", f"{st['duplicate_vertices']} duplicate vertices welded, {st['flipped_faces']} faces rewound"),
    ]
    rows += [(f"seconds: {k}", f"{v:.3f}") for k, v in st["seconds"].items()]
    width = max(len(r[0]) for r in rows)
    return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)


def info_main() -> int:
    """`python -m geomtex info`: what geomtex runs on and its self-check; exit status 1 when a
    kind fails it (a kind the CPU backend refuses, naming why, is no failure), 2 when there is
    no usable backend."""
    try:
        result = gt.info()
    except gt.DeviceError as e:
        print(f"geomtex: DeviceError: {e}", file=sys.stderr)
        return 2
    print(result)
    return 0 if all(r["passed"] is not False for r in result["self_check"].values()) else 1


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["info"]:
        return info_main()
    ap = argparse.ArgumentParser(prog="python -m geomtex", description=__doc__.splitlines()[0])
    ap.add_argument("mesh", nargs="?", help="mesh file (OBJ/PLY/STL/OFF); default: the bunny bundled with geomtex")
    ap.add_argument("-o", "--out", default="out", help="output folder (default: out/)")
    ap.add_argument("--version", action="version", version=f"geomtex {gt.__version__}")
    ap.add_argument("--max-resolution", type=int, default=None,
                    help="a fixed texel for the whole set that makes the largest patch this many texels on "
                         "its longest side (default: none; the conversion is error-driven within the mesh's "
                         "own bytes; with --max-error-rel a cap of 1024)")
    ap.add_argument("--max-error-rel", type=float, default=None,
                    help="error-driven: each chart's texel chosen for this p99 reconstruction error, "
                         "as a fraction of the diagonal")
    ap.add_argument("--charts", type=int, default=None, help="exact VSA chart count")
    ap.add_argument("--no-hybrid", action="store_true",
                    help="height maps everywhere (by default a chart stays the mesh's own triangles where "
                         "no height map within the bound takes fewer bytes)")
    ap.add_argument("--frame", choices=["min_area", "pca"], default="min_area")
    ap.add_argument("--quiet", action="store_true",
                    help="no progress (a bar on a terminal, a line per stage in a log otherwise)")
    args = ap.parse_args(argv)

    path, mesh = (Path(args.mesh), None) if args.mesh else default_mesh()
    try:
        mesh = gt.load_mesh(path) if mesh is None else mesh
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", gt.CapWarning)
            gts = gt.convert(mesh, max_resolution=args.max_resolution, charts=args.charts,
                             max_error_rel=args.max_error_rel, hybrid=False if args.no_hybrid else None,
                             frame=args.frame, progress=not args.quiet)
        # A cap the conversion hit (a bound missed within the byte budget, a chart cap) is said
        # as convert says it, on its own line, not as a Python warning's file and line.
        for w in caught:
            if issubclass(w.category, gt.CapWarning):
                print(f"geomtex: CapWarning: {w.message}", file=sys.stderr)
            else:
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        out = Path(args.out)
        os.makedirs(out, exist_ok=True)
        gtex, png = out / f"{path.stem}.gtex", out / f"{path.stem}.png"
        gts.save(gtex)
        save_image(overview(gts, 512, title=path.name), png)
    except gt.GeomtexError as e:
        print(f"geomtex: {type(e).__name__}: {e}", file=sys.stderr)
        return 2
    print(f"{path} -> {gtex} ({gtex.stat().st_size / 1e6:.1f} MB), {png}")
    print(stats_table(gts))
    return 0


if __name__ == "__main__":
    sys.exit(main())
