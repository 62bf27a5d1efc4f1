"""What every benchmark result records about its run, under the JSON's ``"meta"`` key.

``write_json(path, data)`` is how the scripts in bench/ write ``bench/results/*.json``: it adds
``meta()`` (date, commit, CPU, cores, GPU adapter, Python and library versions) so that the
generated benchmark pages (docs/bench_pages.py) can say when, where and on what each table was
measured. Where a script updates part of an existing file (``--headline-only``, ``--parts``,
``--cases``), ``"meta"`` describes the run that wrote it last.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
LIBRARIES = ("numpy", "trimesh", "embreex", "pymeshlab", "matplotlib", "dask", "zarr", "xatlas")


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _version(name: str) -> str | None:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return None


def _adapter() -> dict[str, str] | None:
    """The adapter geomtex draws with (``gt.info(check=False)``: no self-check), or None."""
    try:
        import geomtex as gt

        info = gt.info(check=False)
    except Exception:  # noqa: BLE001 - a result without an adapter still records the rest
        return None
    return {k: str(info[k]) for k in ("name", "backend", "device_type", "driver", "driver_info") if k in info}


def meta(adapter: bool = True) -> dict[str, Any]:
    """Date (UTC), commit (and whether the tree had changes), CPU model, cores, platform, GPU
    adapter (``adapter=False`` skips asking for one), Python, geomtex and library versions."""
    status = _git("status", "--porcelain", "--untracked-files=no")
    try:
        import geomtex as gt

        geomtex_version: str | None = gt.__version__
    except ImportError:
        geomtex_version = None
    return {
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "commit": _git("rev-parse", "--short", "HEAD"),
        "commit_dirty": bool(status) if status is not None else None,
        "cpu": _cpu_model(),
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "adapter": _adapter() if adapter else None,
        "python": platform.python_version(),
        "geomtex": geomtex_version,
        "versions": {name: _version(name) for name in LIBRARIES},
    }


def write_json(path: str | os.PathLike[str], data: Any, indent: int = 1, default: Any = None,
               adapter: bool = True) -> Path:
    """Writes ``data`` (a dict) to ``path`` as JSON with ``meta()`` under ``"meta"``."""
    if not isinstance(data, dict):
        raise TypeError(f"a benchmark result is a dict, got {type(data).__name__}")
    data = {**data, "meta": meta(adapter=adapter)}
    path = Path(path)
    path.write_text(json.dumps(data, indent=indent, default=default) + "\n")
    return path
