#!/usr/bin/env bash
# What a user gets from `pip install`: builds the abi3 wheel (maturin build --release), installs
# it with the notebook extra into a clean virtualenv in a temporary folder (nothing from this
# checkout on its path), and there
#   (a) runs README.md's quick start (the first ```python block under "## Quick start") in an
#       empty folder and checks it wrote bunny.png, and that the picture is not one flat color;
#   (b) prints gt.info() (the adapter and a self-check of every object kind), all passing;
#   (c) executes examples/quickstart.ipynb and examples/batch.ipynb top to bottom in a Jupyter
#       kernel of that venv (nbclient), failing on any cell's error.
# Called by .ci/run before scripts/test.sh (see there why before). Needs the network for pip.
# GEOMTEX_README=path checks another README's quick start (to try a draft).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
repo=$PWD
readme=$(realpath "${GEOMTEX_README:-README.md}")

# The Vulkan driver, .venv with maturin and the extension built by `maturin develop`, whose
# cargo build the wheel's reuses.
GEOMTEX_SETUP=demo . scripts/setup.sh --quiet

start=$(date +%s)
work=$(mktemp -d "${TMPDIR:-/tmp}/geomtex-install-check.XXXXXX")
trap 'rm -rf "$work"' EXIT
log="$work/log"
step() { echo "== install check: $*"; }
logged() {
  if ! "$@" >>"$log" 2>&1; then
    echo "install check: failed: $*; the end of its log:" >&2
    tail -n 60 "$log" >&2
    exit 1
  fi
}
seconds() { echo $(( $(date +%s) - $1 )); }

t=$(date +%s)
logged maturin build --release -o "$work/wheels"
wheel=$(ls "$work"/wheels/geomtex-*.whl)
case "$(basename "$wheel")" in
  *-cp311-abi3-*) ;;
  *) echo "install check: $(basename "$wheel") is not an abi3 wheel for CPython >= 3.11 (cp311-abi3)" >&2; exit 1 ;;
esac
step "built $(basename "$wheel") ($(du -k "$wheel" | cut -f1) KiB) in $(seconds "$t") s"

t=$(date +%s)
# The system's Python, not .venv's packages: a clean venv as a user makes one.
"${PYTHON:-python3}" -m venv "$work/venv"
venv_py="$work/venv/bin/python"
logged "$venv_py" -m pip install --disable-pip-version-check --upgrade pip
logged "$venv_py" -m pip install --disable-pip-version-check "$wheel[notebook]"
step "pip install '$(basename "$wheel")[notebook]' into a clean venv: $(seconds "$t") s"

# Nothing of this checkout is importable there: the commands run in empty folders, no PYTHONPATH.
run_clean() { (cd "$1" && shift && env -u PYTHONPATH -u VIRTUAL_ENV "$venv_py" "$@"); }

step "(a) README.md's quick start"
mkdir "$work/quickstart"
"$venv_py" - "$readme" "$work/quickstart/quickstart.py" <<'PY'
import re
import sys

text = open(sys.argv[1], encoding="utf-8").read()
section = re.search(r"^## Quick start\s*$(.*?)(?=^## |\Z)", text, re.M | re.S)
block = section and re.search(r"^```python\s*$(.*?)^```", section.group(1), re.M | re.S)
if not block:
    sys.exit(f"install check: {sys.argv[1]} has no ```python block under '## Quick start'")
open(sys.argv[2], "w", encoding="utf-8").write(block.group(1))
PY
t=$(date +%s)
run_clean "$work/quickstart" quickstart.py
run_clean "$work/quickstart" - <<'PY'
from pathlib import Path

import numpy as np
from PIL import Image

path = Path("bunny.png")
if not path.exists():
    raise SystemExit("install check: README's quick start wrote no bunny.png in its folder")
pixels = np.asarray(Image.open(path).convert("RGBA")).reshape(-1, 4)
colors = len(np.unique(pixels, axis=0))
if colors < 2:
    raise SystemExit(f"install check: bunny.png ({path.stat().st_size} bytes) is one flat color")
print(f"bunny.png: {Image.open(path).size[0]}x{Image.open(path).size[1]}, {colors} colors")
PY
step "(a) took $(seconds "$t") s"

step "(b) gt.info()"
# Every kind's self-check must pass with only what the wheel's dependencies brought.
run_clean "$work" -c 'import geomtex as gt
info = gt.info()
print(info)
failed = [k for k, r in info["self_check"].items() if not r["passed"]]
assert not failed, f"self-checks failed: {failed}"'

step "(c) the example notebooks"
# A kernel spec of this venv, so the notebooks cannot run in some other Python's kernel.
logged "$venv_py" -m ipykernel install --prefix "$work/venv" --name geomtex-install-check
t=$(date +%s)
run_clean "$work" - "$repo/examples" "$work/venv" <<'PY'
import sys
import tempfile
import time
from pathlib import Path

import nbclient
import nbformat

examples, venv = Path(sys.argv[1]), Path(sys.argv[2])
for name in ("quickstart", "batch"):
    nb = nbformat.read(examples / f"{name}.ipynb", as_version=4)
    # A first cell that says which Python runs the kernel: it must be the clean venv's.
    nb.cells.insert(0, nbformat.v4.new_code_cell("import sys; print(sys.prefix)"))
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as cwd:
        nbclient.NotebookClient(nb, timeout=600, kernel_name="geomtex-install-check",
                                resources={"metadata": {"path": cwd}}).execute()
    prefix = nb.cells[0].outputs[0]["text"].strip()
    if Path(prefix).resolve() != venv.resolve():
        raise SystemExit(f"install check: {name}.ipynb ran in {prefix}, not in the clean venv {venv}")
    outputs = [o for cell in nb.cells if cell.cell_type == "code" for o in cell.get("outputs", [])]
    errors = [o for o in outputs if o.get("output_type") == "error"]
    if errors:  # execute() raises on a failing cell; this catches errors a cell printed and allowed
        raise SystemExit(f"install check: {name}.ipynb: {errors[0].get('ename')}: {errors[0].get('evalue')}")
    pngs = sum("image/png" in o.get("data", {}) for o in outputs)
    if pngs < (3 if name == "quickstart" else 1):
        raise SystemExit(f"install check: {name}.ipynb drew {pngs} pictures")
    print(f"{name}.ipynb: {len(nb.cells) - 1} cells, {pngs} pictures, {time.perf_counter() - start:.1f} s")
PY
step "(c) took $(seconds "$t") s"
step "passed in $(seconds "$start") s (after the set-up)"
