"""Optional dependencies, imported where a feature first needs them (``import geomtex`` needs
none of them; scipy is a runtime dependency, so it is imported plainly). A missing one is an
ImportError that names the feature, the package and the pip command that brings it, never a
bare "No module named …" from deep inside a call."""

from __future__ import annotations

import importlib
from types import ModuleType

#: module -> (the package pip installs, the geomtex extra that brings it, if one does)
PACKAGES: dict[str, tuple[str, str | None]] = {
    "dask.distributed": ("dask[distributed]", "distributed"),
    "zarr": ("zarr", "distributed"),
    "skimage": ("scikit-image", "gdm"),
    "ipywidgets": ("ipywidgets", "notebook"),
    "pymeshlab": ("pymeshlab", "igt"),
    "rtree": ("rtree", None),
    "embreex": ("embreex", "notebook"),
    "matplotlib": ("matplotlib", "notebook"),
}


def need(module: str, feature: str) -> ModuleType:
    """`module` imported, or an ImportError saying that `feature` needs it and how to install it."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        known = [m for m in PACKAGES if module == m or module.startswith(m + ".")]
        package, extra = PACKAGES[known[0]] if known else (module.split(".")[0], None)
        hint = f"pip install '{package}'" + (f" (or pip install 'geomtex[{extra}]' from a clone)" if extra else "")
        raise ImportError(f"{feature} needs {package}, which is not installed: {hint}",
                          name=module) from e
