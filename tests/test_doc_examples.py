"""Every ```python block of README.md and docs/**/*.md runs as written.

Each page is one test: its Python blocks run in order in one fresh namespace, in a temporary
working directory (so ``frame.save("bunny.png")`` writes there), and any exception fails the
test, naming the page, the block's first line in the file and the block's text.

Marking a block, with an HTML comment on the line right before its fence (MyST passes HTML
comments through to nothing):

- ``<!-- needs: dask, ipywidgets -->``: the block runs only where every module named imports;
  elsewhere it is skipped (and so, to keep a page's namespace whole, is every later block of the
  page that also names one of those modules). Name the import, e.g. ``skimage``, ``pymeshlab``.
- ``<!-- no-run -->``: a fragment that is not meant to run (sparingly; prefer a ```text block).

The bundled mesh ``gt.data.bunny()`` is pymeshlab's 56,172-face bunny shipped inside geomtex.
Where an older build lacks ``geomtex.data``, the test stands in for it with the same file from
the pymeshlab wheel (and skips when that is absent too). Nothing here reads ``../shared``.

Time: 33 blocks (2 marked no-run, 5 needing an extra) on 12 pages; the whole file took 65 s on
the 2-core development machine (lavapipe, every extra installed), most of it the guides'
conversions of the bunny; ``pytest --durations=0 tests/test_doc_examples.py`` lists each page's.
"""

from __future__ import annotations

import importlib.util
import re
import traceback
import types
import warnings
from pathlib import Path

import pytest

import geomtex as gt

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md"] + sorted(p for p in (ROOT / "docs").rglob("*.md") if "_build" not in p.parts)

FENCE = re.compile(r"^(?P<ticks>`{3,})(?P<info>[^\n`]*)$")
MARK = re.compile(r"^<!--\s*(?P<what>no-run|needs:\s*(?P<modules>[\w.,\s]+?))\s*-->\s*$")


def python_blocks(path: Path) -> list[tuple[int, str, set[str] | None]]:
    """(first line, code, needed modules or None for a no-run block) of every ```python block."""
    blocks: list[tuple[int, str, set[str] | None]] = []
    lines = path.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i].strip())
        if not m:
            i += 1
            continue
        ticks, info = m["ticks"], m["info"].strip()
        end = i + 1
        while end < len(lines) and lines[end].strip() != ticks:
            end += 1
        if info in ("python", "py", "python3"):
            needs: set[str] | None = set()
            prev = lines[i - 1].strip() if i > 0 else ""
            mark = MARK.match(prev)
            if mark and mark["what"] == "no-run":
                needs = None
            elif mark:
                needs = {name.strip() for name in mark["modules"].split(",") if name.strip()}
            blocks.append((i + 2, "\n".join(lines[i + 1:end]) + "\n", needs))
        i = end + 1
    return blocks


def _bundled_bunny() -> None:
    """Provides ``gt.data.bunny()`` where this build predates ``geomtex.data``."""
    if hasattr(gt, "data") and hasattr(gt.data, "bunny"):
        return
    spec = importlib.util.find_spec("pymeshlab")
    path = None if spec is None or spec.origin is None else (
        Path(spec.origin).parent / "tests" / "sample_meshes" / "bunny.obj")
    if path is None or not path.exists():
        pytest.skip("this build has no geomtex.data, and pymeshlab's bunny.obj is absent")
    gt.data = types.SimpleNamespace(bunny=lambda: gt.load_mesh(path))  # type: ignore[attr-defined]


def _missing(modules: set[str]) -> list[str]:
    return sorted(m for m in modules if importlib.util.find_spec(m) is None)


def test_pages_have_python_blocks() -> None:
    """The extraction finds the README's quick start (guards against a fence-format change)."""
    assert python_blocks(ROOT / "README.md"), "no ```python block found in README.md"


RUNNABLE = [p for p in PAGES if any(needs is not None for _, _, needs in python_blocks(p))]


@pytest.mark.parametrize("page", RUNNABLE, ids=lambda p: str(p.relative_to(ROOT)))
def test_page_examples_run(page: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _bundled_bunny()
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "__doc_example__"}
    skipped: set[str] = set()
    ran = 0
    for line, code, needs in python_blocks(page):
        if needs is None:
            continue
        missing = _missing(needs)
        if missing or needs & skipped:
            skipped |= needs
            continue
        try:
            with warnings.catch_warnings():
                # An example a reader copies must not print numpy's warnings (NaN or inf in
                # arithmetic): it would teach them to ignore warnings.
                warnings.simplefilter("error", RuntimeWarning)
                exec(compile(code, f"{page.relative_to(ROOT)}:{line}", "exec"), namespace)
        except Exception:
            pytest.fail(f"{page.relative_to(ROOT)}, the block at line {line} failed:\n{code}\n"
                        f"{traceback.format_exc()}", pytrace=False)
        ran += 1
    if ran == 0:
        pytest.skip(f"every block of {page.name} needs a module that is missing: {sorted(skipped)}")
