"""Generates the documentation's benchmark pages from ``bench/results/**/*.json``.

One page per result file (``docs/benchmarks/<name>.md``; a run kept in a subfolder, such as
``results/h200/run1/render.json``, becomes ``h200-run1-render.md``) and an index with a toctree.
Each page opens with the run's date, machine (CPU and cores, GPU adapter) and commit, read from
the JSON: its ``"meta"`` entry (bench/_meta.py, written by every script since it was added), else
the older ``"machine"`` entry or top-level ``date`` / ``machine`` / ``adapter`` / ``cores``
fields. What the JSON does not record is said so: the date and commit then come from the last
commit that changed the file (``git log -1 -- FILE``), marked as such, and a missing machine reads
"machine not recorded". Then the section of bench/README.md whose ``Results:`` line names the
file (what the script measures and how to run it), the file's PNG plots, and its figures as
tables generated from the JSON. No figure on a page is typed by hand.

The pages are build products, not committed (docs/.gitignore): the docs build runs
``generate()`` from conf.py, and ``python docs/bench_pages.py`` writes them for a look. The same
call copies the example notebooks into docs/examples/ for myst-nb to render.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent
RESULTS = REPO / "bench" / "results"
README = REPO / "bench" / "README.md"
PAGES = DOCS / "benchmarks"
EXAMPLES_SRC = REPO / "examples"
EXAMPLES_DST = DOCS / "examples"
NOTEBOOKS = ("quickstart", "batch")

#: Limits that keep a page readable; the JSON (linked from each page) holds everything.
MAX_ROWS = 40
MAX_COLUMNS = 14
MAX_TABLES = 60
MAX_DEPTH = 3  # heading levels below the page title (##, ###, ####)
#: Keys shown in the page's header (or not at all), not as tables.
HEADER_KEYS = {"meta", "machine"}
#: PNGs whose names do not start with their JSON's name.
EXTRA_PLOTS = {"appearance_filters": ["appearance_filter_ears_"]}
NOT_RECORDED = "machine not recorded"


# --------------------------------------------------------------------------- git


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 and out.stdout.strip() else None


def _last_commit(path: Path) -> tuple[str, str] | None:
    """(date, short hash) of the last commit that changed ``path``; None outside a full clone
    (a shallow clone's history cannot say which commit last changed a file)."""
    if _git("rev-parse", "--is-shallow-repository") != "false":
        return None
    out = _git("log", "-1", "--format=%cs/%h", "--", str(path.relative_to(REPO)))
    if not out or "/" not in out:
        return None
    date, commit = out.split("/", 1)
    return date, commit


# --------------------------------------------------------------------------- run metadata


def _adapter_text(adapter: Any) -> str | None:
    if isinstance(adapter, dict) and adapter.get("name"):
        extra = ", ".join(str(adapter[k]) for k in ("backend", "driver_info") if adapter.get(k))
        return f"{adapter['name']} ({extra})" if extra else str(adapter["name"])
    if isinstance(adapter, str) and adapter:
        return adapter
    return None


def _date_text(value: Any) -> str | None:
    return str(value)[:10] if isinstance(value, str) and re.match(r"\d{4}-\d\d-\d\d", value) else None


def run_info(data: dict[str, Any], path: Path) -> dict[str, str]:
    """The page header's date, machine and commit lines for one result file, and where each came
    from (``source``: "meta", "machine", "fields" or "git")."""
    meta = data.get("meta") if isinstance(data.get("meta"), dict) else None
    machine = data.get("machine") if isinstance(data.get("machine"), dict) else None
    rec = meta or machine or {}
    source = "meta" if meta else "machine" if machine else "fields"

    date = _date_text(rec.get("date")) or _date_text(data.get("date"))
    commit = rec.get("commit") or rec.get("git")
    dirty = rec.get("commit_dirty", rec.get("git_dirty"))
    cpu, cores = rec.get("cpu"), rec.get("cores", rec.get("cpu_count", data.get("cores")))
    platform = rec.get("platform") or (data["machine"] if isinstance(data.get("machine"), str) else None)
    adapter = _adapter_text(rec.get("adapter")) or _adapter_text(data.get("adapter"))

    fallback = None if (date and commit) else _last_commit(path)
    if date:
        date_line = date
    elif fallback:
        date_line = f"{fallback[0]} (not recorded in the file: the date of the last commit that changed it)"
        source = "git"
    else:
        date_line = "not recorded"
    if commit:
        commit_line = f"`{commit}`" + (" with uncommitted changes" if dirty else "")
    elif fallback:
        commit_line = f"`{fallback[1]}` (not recorded in the file: the last commit that changed it)"
        source = "git"
    else:
        commit_line = "not recorded"

    parts = []
    if cpu or cores:
        parts.append(f"{cpu or 'CPU model not recorded'}, {cores} cores" if cores else f"{cpu}, cores not recorded")
    if adapter:
        parts.append(f"adapter {adapter}")
    if platform:
        parts.append(f"platform `{platform}`")
    if parts and not (cpu or cores):
        parts.append("CPU not recorded")
    if parts and not adapter:
        parts.append("adapter not recorded")
    machine_line = "; ".join(parts) if parts else NOT_RECORDED
    adapter_name = (rec.get("adapter") or data.get("adapter") or {})
    adapter_name = adapter_name.get("name") if isinstance(adapter_name, dict) else adapter_name
    short = [(f"{cpu}, {cores} cores" if cpu else f"{cores} cores") if cores else cpu] + [adapter_name]
    short_line = "; ".join(str(x) for x in short if x) or ("platform only" if platform else NOT_RECORDED)
    return {"date": date_line, "machine": machine_line, "commit": commit_line, "source": source,
            "machine_short": short_line, "date_from_git": "yes" if fallback and not date else ""}


def _sub_runs(data: Any, prefix: str = "", depth: int = 0) -> list[tuple[str, dict[str, str]]]:
    """Parts of a file measured in runs of their own (a nested ``machine`` or ``meta`` entry, or
    a dict with its own ``date``): (key path, date / commit / machine)."""
    found: list[tuple[str, dict[str, str]]] = []
    if not isinstance(data, dict) or depth > 3:
        return found
    for key, value in data.items():
        if not isinstance(value, dict) or key in HEADER_KEYS:
            continue
        path = f"{prefix}.{key}" if prefix else key
        rec = value.get("meta") or value.get("machine")
        if isinstance(rec, dict) or _date_text(value.get("date")):
            rec = rec if isinstance(rec, dict) else value
            cpu, cores = rec.get("cpu"), rec.get("cores", rec.get("cpu_count"))
            info = {"date": _date_text(rec.get("date")) or _date_text(value.get("date")) or "not recorded",
                    "commit": f"`{rec.get('commit') or rec.get('git')}`" if rec.get("commit") or rec.get("git")
                    else "not recorded",
                    "machine": f"{cpu}, {cores} cores" if cpu and cores
                    else f"platform `{value['machine']}`" if isinstance(value.get("machine"), str) else NOT_RECORDED}
            found.append((path, info))
        found += _sub_runs(value, path, depth + 1)
    return found


# --------------------------------------------------------------------------- values and tables


def _escape(text: str) -> str:
    text = text.replace("\\", "\\\\").replace("|", "\\|").replace("\n", " ")
    for ch in "*_`[]<>#$":
        text = text.replace(ch, "\\" + ch)
    return text


def _scalar(v: Any) -> bool:
    return v is None or isinstance(v, (bool, int, float, str))


def _short_list(v: Any) -> bool:
    return isinstance(v, list) and len(v) <= 6 and all(_scalar(x) and not isinstance(x, str) or
                                                       isinstance(x, str) and len(x) < 20 for x in v)


def cell(v: Any) -> str:
    """One value as table text: floats to four significant digits, long lists summarised."""
    if v is None:
        return ""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "NaN"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        if v == 0:
            return "0"
        return f"{v:.4g}"
    if isinstance(v, str):
        return _escape(v if len(v) <= 80 else v[:77] + "...")
    if _short_list(v):
        return ", ".join(cell(x) for x in v)
    if isinstance(v, list):
        return f"({len(v)} values)"
    if isinstance(v, dict):
        return f"({len(v)} entries)"
    return _escape(str(v))


def _flatten(d: dict[str, Any], prefix: str = "", depth: int = 0) -> dict[str, Any]:
    """A dict's scalars (and short lists), nested dicts flattened to ``a.b`` keys (two levels)."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if _scalar(v) or _short_list(v):
            out[key] = v
        elif isinstance(v, dict) and depth < 2:
            out.update(_flatten(v, key + ".", depth + 1))
    return out


def _table(rows: list[dict[str, Any]], first: str | None = None) -> list[str]:
    """A markdown table of flattened rows: columns in order of first appearance, capped."""
    flat = [_flatten(r) for r in rows]
    columns: list[str] = []
    for r in flat:
        columns += [k for k in r if k not in columns]
    if not columns:
        return []
    notes = []
    if len(columns) > MAX_COLUMNS:
        notes.append(f"{len(columns) - MAX_COLUMNS} more columns")
        columns = columns[:MAX_COLUMNS]
    if len(flat) > MAX_ROWS:
        notes.append(f"{len(flat) - MAX_ROWS} more rows")
        flat, rows = flat[:MAX_ROWS], rows[:MAX_ROWS]
    head = ([first] if first else []) + columns
    lines = ["| " + " | ".join(_escape(h) for h in head) + " |",
             "|" + "|".join("---" for _ in head) + "|"]
    for r, names in zip(flat, rows):
        row = ([_escape(str(names.get("__name__", "")))] if first else []) + [cell(r.get(c)) for c in columns]
        lines.append("| " + " | ".join(row) + " |")
    if notes:
        lines += ["", f"({', '.join(notes)} in the JSON.)"]
    return lines


def _records(v: Any) -> bool:
    """A list of dicts, or a dict whose values are mostly dicts of scalars: a table's rows."""
    if isinstance(v, list):
        return bool(v) and all(isinstance(x, dict) for x in v)
    if isinstance(v, dict) and len(v) >= 2:
        dicts = [x for x in v.values() if isinstance(x, dict)]
        if len(dicts) != len(v):
            return False
        scalars = sum(sum(_scalar(y) or _short_list(y) for y in x.values()) for x in dicts)
        nested = sum(sum(not (_scalar(y) or _short_list(y)) for y in x.values()) for x in dicts)
        return scalars > 0 and scalars >= nested
    return False


class _Body:
    def __init__(self) -> None:
        self.lines: list[str] = []
        self.tables = 0
        self.omitted: list[str] = []

    def add_table(self, lines: list[str]) -> None:
        if lines:
            self.lines += lines + [""]
            self.tables += 1

    def node(self, title: str, value: Any, level: int, path: str) -> None:
        if self.tables >= MAX_TABLES:
            self.omitted.append(path)
            return
        self.lines += [f"{'#' * (level + 1)} {_escape(title)}", ""]
        if _scalar(value) or _short_list(value):
            self.lines += [cell(value), ""]
        elif _records(value):
            rows = value if isinstance(value, list) else [{"__name__": k, **x} for k, x in value.items()]
            self.add_table(_table(rows, None if isinstance(value, list) else "name"))
        elif isinstance(value, list):
            self.lines += [f"A list of {len(value)} values (in the JSON).", ""]
        elif isinstance(value, dict):
            self.mapping(value, level, path)

    def mapping(self, d: dict[str, Any], level: int, path: str) -> None:
        simple = {k: v for k, v in d.items() if (_scalar(v) or _short_list(v)) and k not in HEADER_KEYS}
        if simple:
            self.add_table(["| key | value |", "|---|---|"] +
                           [f"| {_escape(k)} | {cell(v)} |" for k, v in simple.items()])
        for k, v in d.items():
            if k in simple or k in HEADER_KEYS:
                continue
            sub = f"{path}.{k}" if path else k
            if level + 1 > MAX_DEPTH:
                if isinstance(v, dict) and not _records(v):
                    flat = _flatten(v)
                    if flat and self.tables < MAX_TABLES:
                        self.lines += [f"**{_escape(sub)}**", ""]
                        self.add_table(["| key | value |", "|---|---|"] +
                                       [f"| {_escape(a)} | {cell(b)} |" for a, b in list(flat.items())[:MAX_ROWS]])
                    elif not flat:
                        self.omitted.append(sub)
                    continue
                if self.tables < MAX_TABLES and _records(v):
                    self.lines += [f"**{_escape(sub)}**", ""]
                    rows = v if isinstance(v, list) else [{"__name__": a, **b} for a, b in v.items()]
                    self.add_table(_table(rows, None if isinstance(v, list) else "name"))
                else:
                    self.omitted.append(sub)
                continue
            self.node(k, v, level + 1, sub)


def tables(data: dict[str, Any]) -> list[str]:
    """The file's figures as markdown: top-level scalars, then a section per entry."""
    body = _Body()
    body.mapping(data, 0, "")
    if body.omitted:
        body.lines += ["Not shown here (see the JSON): " + ", ".join(f"`{p}`" for p in body.omitted[:40]) +
                       (f" and {len(body.omitted) - 40} more" if len(body.omitted) > 40 else "") + ".", ""]
    return body.lines


# --------------------------------------------------------------------------- README sections


def readme_sections() -> dict[str, tuple[str, str]]:
    """``results/...`` path named on a section's ``Results:`` line -> (title, prose): the
    section's text without its heading and ``Results:`` line."""
    text = README.read_text()
    found: dict[str, tuple[str, str]] = {}
    for block in re.split(r"(?m)^(?=#{2,3} )", text):
        if not block.startswith("#"):
            continue
        heading, _, rest = block.partition("\n")
        title = heading.lstrip("#").strip()
        lines = rest.splitlines()
        results = [ln for ln in lines if ln.startswith("Results:")]
        prose = "\n".join(ln for ln in lines if not ln.startswith("Results:")).strip()
        for line in results:
            for name in re.findall(r"`(results/[^`]+)`", line):
                found[name] = (title, prose)
    return found


def _shift_headings(prose: str) -> str:
    """The README's own ### headings (none in section bodies today) kept below the page's ##."""
    return re.sub(r"(?m)^(#{1,5}) ", lambda m: "#" * min(len(m.group(1)) + 2, 6) + " ", prose)


# --------------------------------------------------------------------------- pages


def result_files() -> list[Path]:
    return sorted(RESULTS.rglob("*.json"), key=lambda p: (len(p.relative_to(RESULTS).parts), str(p)))


def page_name(path: Path) -> str:
    return "-".join(path.relative_to(RESULTS).with_suffix("").parts)


def plots(path: Path, siblings: list[Path]) -> list[Path]:
    """The PNGs beside ``path`` whose names start with its name (the longest such JSON name
    claims each), plus EXTRA_PLOTS."""
    stem = path.stem
    mine = []
    for png in sorted(path.parent.glob("*.png")):
        owners = [j.stem for j in siblings if j.parent == path.parent and png.stem.startswith(j.stem)]
        extra = [j for j, prefixes in EXTRA_PLOTS.items() if any(png.stem.startswith(p) for p in prefixes)]
        owner = extra[0] if extra else max(owners, key=len) if owners else None
        if owner == stem:
            mine.append(png)
    return mine


def _rel(target: Path) -> str:
    """``target`` relative to the pages' folder (the pages always live in docs/benchmarks)."""
    return Path(os.path.relpath(target, PAGES)).as_posix()


def page(path: Path, siblings: list[Path], sections: dict[str, tuple[str, str]]) -> tuple[str, dict[str, str]]:
    data = json.loads(path.read_text())
    if not isinstance(data, dict):
        data = {"values": data}
    rel = path.relative_to(RESULTS)
    info = run_info(data, path)
    title, prose = sections.get(f"results/{rel.as_posix()}", (None, ""))
    name = page_name(path)
    lines = [f"# {name}", ""]
    if title:
        lines += [f"From bench/README.md, *{_escape(title)}*.", ""]
    lines += [f"- **Date:** {info['date']}",
              f"- **Machine:** {info['machine']}",
              f"- **Commit:** {info['commit']}",
              f"- **Data:** {{download}}`{rel.as_posix()} <{_rel(path)}>`",
              ""]
    runs = _sub_runs(data)
    if runs:
        lines += ["Parts of this file measured in runs of their own:", ""]
        lines += [f"- `{p}`: date {r['date']}, commit {r['commit']}, {r['machine']}" for p, r in runs[:12]]
        if len(runs) > 12:
            lines += [f"- and {len(runs) - 12} more (see the JSON)"]
        lines += [""]
    if prose:
        lines += ["## What it measures", "", _shift_headings(prose), ""]
    for png in plots(path, siblings):
        lines += [f"![{png.stem}]({_rel(png)})", ""]
    lines += ["## Figures", "",
              "Generated from the JSON: floats to four significant digits, long lists and deep "
              "entries left to the file.", ""]
    lines += _shift_down(tables(data))
    return "\n".join(lines).rstrip() + "\n", info


def _shift_down(lines: list[str]) -> list[str]:
    """Tables' headings start at ## in tables(); below the page's ## Figures they become ###."""
    return [("#" + ln) if re.match(r"#{2,5} ", ln) else ln for ln in lines]


def index(names: list[tuple[str, Path, dict[str, str]]]) -> str:
    lines = ["# Benchmarks", "",
             "Generated from `bench/results/*.json` by `docs/bench_pages.py` when the documentation is "
             "built: one page per result file, with the date, machine and commit of its run, what the "
             "script measures and how to run it (from bench/README.md), its plots and its figures. "
             "How the results developed is in the changelog's benchmark history.", "",
             "| page | date | machine | commit |", "|---|---|---|---|"]
    for name, _, info in names:
        date = info["date"].split(" ")[0] + (" (†)" if info["date_from_git"] else "")
        commit = info["commit"].split(" ")[0] + (" (†)" if "last commit" in info["commit"] else "")
        lines.append(f"| [{name}]({name}.md) | {date} | {info['machine_short']} | {commit} |")
    lines += ["", "(†) Not recorded in the file: the last commit that changed it, and its date. Files "
              "written since bench/_meta.py record their run's own.", ""]
    lines += ["```{toctree}", ":hidden:", ":maxdepth: 1", ""] + [n for n, _, _ in names] + ["```", ""]
    return "\n".join(lines)


def _write(path: Path, text: str) -> None:
    """Writes only when the text changed, so that Sphinx rereads only changed pages."""
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


def copy_notebooks(dst: Path = EXAMPLES_DST) -> list[Path]:
    """The stored (executed) example notebooks, copied for myst-nb to render."""
    out = []
    for name in NOTEBOOKS:
        src, target = EXAMPLES_SRC / f"{name}.ipynb", dst / f"{name}.ipynb"
        if not target.exists() or target.read_bytes() != src.read_bytes():
            shutil.copyfile(src, target)
        out.append(target)
    return out


def generate(out: Path = PAGES, notebooks: bool = True) -> dict[str, dict[str, str]]:
    """Writes every page and the index into ``out`` (removing pages of results that are gone);
    returns page name -> run info."""
    out.mkdir(parents=True, exist_ok=True)
    files = result_files()
    sections = readme_sections()
    made: list[tuple[str, Path, dict[str, str]]] = []
    for path in files:
        text, info = page(path, files, sections)
        name = page_name(path)
        _write(out / f"{name}.md", text)
        made.append((name, path, info))
    keep = {f"{n}.md" for n, _, _ in made} | {"index.md"}
    for stale in out.glob("*.md"):
        if stale.name not in keep:
            stale.unlink()
    _write(out / "index.md", index(made))
    if notebooks:
        copy_notebooks()
    return {n: info for n, _, info in made}


if __name__ == "__main__":
    made = generate()
    by = {}
    for info in made.values():
        by[info["source"]] = by.get(info["source"], 0) + 1
    print(f"wrote {len(made)} pages into {PAGES} (run info from: {by})")
