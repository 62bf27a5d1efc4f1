"""The benchmark pages (docs/bench_pages.py): one per result JSON, each saying when, on what and
at which commit it was measured, never a machine the file does not record; generated the same
way every time; their prose from bench/README.md, which states no measured figure."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "docs"))
sys.path.insert(0, str(REPO / "bench"))
import bench_pages  # noqa: E402

FILES = bench_pages.result_files()


@pytest.fixture(scope="module")
def pages(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("benchmarks")
    bench_pages.generate(out, notebooks=False)
    return out


def _header(text: str) -> dict[str, str]:
    return dict(re.findall(r"(?m)^- \*\*(Date|Machine|Commit):\*\* (.+)$", text))


def test_results_exist() -> None:
    assert len(FILES) >= 30, FILES  # bench/results/*.json and the h200 run's
    assert any("h200" in p.parts for p in FILES)


@pytest.mark.parametrize("path", FILES, ids=lambda p: bench_pages.page_name(p))
def test_every_result_has_a_page_with_date_machine_and_commit(pages: Path, path: Path) -> None:
    text = (pages / f"{bench_pages.page_name(path)}.md").read_text()
    header = _header(text)
    assert set(header) == {"Date", "Machine", "Commit"}, header
    assert all(v.strip() for v in header.values())
    data = json.loads(path.read_text())
    # The machine comes from the file only: where it records none, the page says so.
    recorded = any(k in data for k in ("meta", "machine", "adapter", "cores"))
    assert (header["Machine"] == bench_pages.NOT_RECORDED) != recorded, (path, header)
    # Its README section, its plots and its tables are there.
    assert "## What it measures" in text and "## Figures" in text
    for png in bench_pages.plots(path, FILES):
        assert f"]({bench_pages._rel(png)})" in text
    assert "| --- |" not in text and "|---|" in text
    index = (pages / "index.md").read_text()
    assert f"\n{bench_pages.page_name(path)}\n" in index  # in the toctree


def test_every_plot_is_on_a_page() -> None:
    claimed = {png for path in FILES for png in bench_pages.plots(path, FILES)}
    assert claimed == set(bench_pages.RESULTS.rglob("*.png"))


def test_generation_is_deterministic(pages: Path, tmp_path: Path) -> None:
    bench_pages.generate(tmp_path, notebooks=False)
    first = {p.name: p.read_text() for p in pages.glob("*.md")}
    again = {p.name: p.read_text() for p in tmp_path.glob("*.md")}
    assert first == again
    assert len(first) == len(FILES) + 1


def test_meta_is_read_first(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A result written by bench/_meta.write_json gets its header from "meta", not git."""
    import _meta

    monkeypatch.setattr(_meta, "_adapter", lambda: {"name": "Test GPU", "backend": "Vulkan"})
    path = _meta.write_json(tmp_path / "x.json", {"rows": [{"a": 1.23456, "b": "x"}]})
    data = json.loads(path.read_text())
    assert set(data["meta"]) >= {"date", "commit", "cpu", "cores", "adapter", "python", "versions"}
    info = bench_pages.run_info(data, path)
    assert info["source"] == "meta"
    assert info["date"] == data["meta"]["date"][:10]
    assert "Test GPU" in info["machine"] and f"{data['meta']['cores']} cores" in info["machine"]
    assert "1.235" in "\n".join(bench_pages.tables(data))


def test_readme_prose_covers_every_result_and_states_no_figure() -> None:
    sections = bench_pages.readme_sections()
    for path in FILES:
        assert f"results/{path.relative_to(bench_pages.RESULTS).as_posix()}" in sections, path
    # Outside code blocks, no measured figure: times, ratios, percentages, sizes.
    figure = re.compile(r"\d[\d.,]*\s*(ms|µs|s|×|%|MB|GB|KB|bytes per face|B/face)(?![\w²])")
    for title, prose in set(sections.values()):
        text = re.sub(r"(?s)```.*?```", "", prose)
        assert not figure.search(text), (title, figure.search(text))
    assert len(bench_pages.README.read_text().splitlines()) <= 160
