"""Command line: convert a mesh file to geometry textures, write the .gtex, a PNG and a stats table.

    python -m geomtex                      # the bunny that ships inside pymeshlab
    python -m geomtex mesh.obj -o out/ --max-resolution 512
    python -m geomtex info                 # adapter, features, limits and a self-check per kind
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from pathlib import Path

import geomtex as gt
from geomtex._files import save_image
from geomtex._preview import overview


def default_mesh() -> tuple[Path, gt.Mesh]:
    """The 56,172-face watertight bunny bundled with geomtex (gt.data.bunny()) and the file it
    ships in, whose stem names the outputs: every install has a real mesh."""
    return Path(gt.data.__file__).with_name("bunny.npz"), gt.data.bunny()


def stats_table(gts: gt.GeometryTextureSet) -> str:
    st = gts.stats
    rows = [
        ("faces", f"{st['faces']:,} ({st['degenerate_faces']} degenerate)"),
        ("patches (charts)", f"{st['charts']} (partition {st['vsa_charts']}, +{st['repair_splits']} by repair, "
                             f"{st.get('sheet_splits', 0)} of them two-sheet charts)"),
        ("folding charts", f"{st['folding_charts']} (before repair: {st['folding_charts_before_repair']})"),
        ("inverted triangles", f"{st['inverted_triangles']} (before repair: {st['inverted_triangles_before_repair']})"),
        ("texels", f"{st['texels']:,} ({100 * st['empty_fraction']:.1f}% empty)"),
        ("texel size", f"{st['texel_size']:.4g} ({st['texel_size'] / st['diagonal']:.2e} of the diagonal)"
                       + (f"; finest of {len(set(st['patch_texel']))} (error-driven)" if "max_error" in st else "")),
        ("map bytes", f"{st['bytes'] / 1e6:.2f} MB"),
        ("reconstruction error", f"p99 {st['reconstruction_error_p99'] / st['diagonal']:.2e}, "
                                 f"max {st['reconstruction_error_max'] / st['diagonal']:.2e} of the diagonal"),
        *([("error bound", f"{st['max_error'] / st['diagonal']:.2e} of the diagonal "
                            f"({st['charts_over_max_error']} charts over it at the resolution cap; "
                            f"chart_error {st['chart_error']})"
                            + ("; missed within the byte budget: p99 "
                               f"{st['reconstruction_error_p99'] / st['max_error']:.2f}x it"
                               if st.get("max_bytes_binding") else ""))] if "max_error" in st else []),
        ("mesh repairs", f"{st['duplicate_vertices']} duplicate vertices welded, {st['flipped_faces']} faces rewound"),
    ]
    rows += [(f"seconds: {k}", f"{v:.3f}") for k, v in st["seconds"].items()]
    width = max(len(r[0]) for r in rows)
    return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)


def info_main() -> int:
    """`python -m geomtex info`: what geomtex runs on and its self-check; exit status 1 when a
    kind fails it, 2 when there is no usable adapter."""
    try:
        result = gt.info()
    except gt.DeviceError as e:
        print(f"geomtex: DeviceError: {e}", file=sys.stderr)
        return 2
    print(result)
    return 0 if all(r["passed"] for r in result["self_check"].values()) else 1


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["info"]:
        return info_main()
    ap = argparse.ArgumentParser(prog="python -m geomtex", description=__doc__.splitlines()[0])
    ap.add_argument("mesh", nargs="?", help="mesh file (OBJ/PLY/STL/OFF); default: pymeshlab's bunny")
    ap.add_argument("-o", "--out", default="out", help="output folder (default: out/)")
    ap.add_argument("--max-resolution", type=int, default=None,
                    help="longest patch side in texels (default 256; 1024 with --max-error-rel)")
    ap.add_argument("--max-error-rel", type=float, default=None,
                    help="error-driven: each chart's texel chosen for this p99 reconstruction error, "
                         "as a fraction of the diagonal")
    ap.add_argument("--charts", type=int, default=None, help="exact VSA chart count")
    ap.add_argument("--frame", choices=["min_area", "pca"], default="min_area")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    args = ap.parse_args(argv)

    path, mesh = (Path(args.mesh), None) if args.mesh else default_mesh()
    try:
        mesh = gt.load_mesh(path) if mesh is None else mesh
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", gt.CapWarning)
            gts = gt.convert(mesh, max_resolution=args.max_resolution, charts=args.charts,
                             max_error_rel=args.max_error_rel,
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
