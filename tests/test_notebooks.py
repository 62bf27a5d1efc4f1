"""The example notebooks, executed top to bottom in a real Jupyter kernel (nbclient + ipykernel),
so they never rot: any cell that raises fails the test."""

from __future__ import annotations

from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.parametrize("name", ["quickstart", "batch"])
def test_notebook_runs_top_to_bottom(name: str, tmp_path) -> None:
    nb = nbformat.read(EXAMPLES / f"{name}.ipynb", as_version=4)
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = [o for cell in nb.cells if cell.cell_type == "code" for o in cell.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    # The pictures a reader expects are there: the set, the frame and the plots as PNGs.
    pngs = sum("image/png" in o.get("data", {}) for o in outputs)
    assert pngs >= (3 if name == "quickstart" else 1), pngs
