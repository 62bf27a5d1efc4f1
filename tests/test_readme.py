"""README.md stays a page a newcomer reads in five minutes: short, install and a runnable example
near the top, no measurement diary (commit hashes, load averages), and no dead relative links.
Figures and history live in docs/benchmarks/ and CHANGELOG.md."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
LINES = README.read_text(encoding="utf-8").splitlines()


def _line_of(pattern: str) -> int:
    """1-based number of the first line matching `pattern`."""
    for number, line in enumerate(LINES, 1):
        if re.search(pattern, line):
            return number
    raise AssertionError(f"README.md has no line matching {pattern!r}")


def test_readme_is_short() -> None:
    assert len(LINES) <= 200, f"README.md has {len(LINES)} lines; keep it at most 200 (move detail to docs/)"


def test_install_and_first_example_come_early() -> None:
    assert _line_of(r"^#+\s+Install") <= 60
    assert _line_of(r"^```python") <= 60, "the first ```python block must start within the first 60 lines"
    assert _line_of(r"^## Quick start$") <= 60


def test_no_commit_hashes_or_load_averages() -> None:
    text = "\n".join(LINES)
    assert "load average" not in text.lower()
    # A commit hash: 7 to 40 hex digits with at least one letter and one digit, standing alone.
    hashes = [m for m in re.findall(r"(?<![\w/.-])[0-9a-f]{7,40}(?![\w/.-])", text)
              if re.search(r"[a-f]", m) and re.search(r"[0-9]", m)]
    assert not hashes, f"README.md names commit hashes {hashes}: history belongs in CHANGELOG.md"


def test_relative_links_exist() -> None:
    text = "\n".join(LINES)
    targets = re.findall(r"\]\(([^)\s]+)\)", text) + re.findall(r'(?:src|href)="([^"]+)"', text)
    missing = []
    for target in targets:
        if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
            continue  # https:, mailto:, an anchor on this page
        path = (ROOT / target.split("#", 1)[0]).resolve()
        if not path.exists():
            missing.append(target)
    assert not missing, f"README.md links to files that do not exist: {missing}"
