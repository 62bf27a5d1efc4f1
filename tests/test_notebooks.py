"""The example notebooks, executed top to bottom in a real Jupyter kernel (nbclient + ipykernel),
so they never rot: any cell that raises fails the test. They are stored executed (the
documentation renders their stored outputs without running them), so the stored copies must
carry their outputs and pictures too."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
NOTEBOOKS = ["quickstart", "batch"]
#: The pictures a reader expects: quickstart's set, frame, plot and viewer; batch's grid of views.
MIN_PNGS = {"quickstart": 3, "batch": 1}
#: Stored notebooks stay small enough to review and to ship in the docs.
MAX_BYTES = 1_500_000


def _pngs(cells: list[dict]) -> int:
    outputs = [o for cell in cells if cell["cell_type"] == "code" for o in cell.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    return sum("image/png" in o.get("data", {}) for o in outputs)


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_stored_notebook_is_executed(name: str) -> None:
    path = EXAMPLES / f"{name}.ipynb"
    nb = json.loads(path.read_text())
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    # Run top to bottom in one kernel: every code cell has a count, 1, 2, 3, ... in order.
    assert [c.get("execution_count") for c in code] == list(range(1, len(code) + 1)), \
        f"{path} is not stored executed: run it with nbclient (see test_notebook_runs_top_to_bottom)"
    assert _pngs(nb["cells"]) >= MIN_PNGS[name]
    assert path.stat().st_size < MAX_BYTES


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_notebook_runs_top_to_bottom(name: str, tmp_path) -> None:
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    nb = nbformat.read(EXAMPLES / f"{name}.ipynb", as_version=4)
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    assert _pngs(nb.cells) >= MIN_PNGS[name]
