"""One bounds object for every render-accuracy test.

A frame is compared with trimesh's ray casting of the original mesh (``reference.compare`` /
``reference.agreement``): coverage IoU, |Δdepth| / bounding-box diagonal (median and p99, raw or
with a one-pixel tolerance at silhouettes), median normal angle, NaN pixels. Each test states its
bounds as a ``RenderBounds`` with the measured value written beside each bound (at most ~3× above
it, so a regression fails; the renderer issue's floor — IoU >= 0.99, median <= 0.1% and p99 <=
1% of the diagonal — is far looser); ``check`` asserts them all and says which failed.

With ``GEOMTEX_RECORD_BOUNDS=path.json`` every checked measurement is written to that file at the
end of the session (test id, bounds, figures), which is how the bounds here were measured.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass
from typing import Any

_RECORDED: list[dict[str, Any]] = []


@dataclass(frozen=True)
class RenderBounds:
    """Bounds on one frame's agreement with the reference; None leaves a figure unchecked."""

    iou: float | None = None  # coverage IoU, at least
    depth_median: float | None = None  # median |Δdepth| / diagonal, at most
    depth_p99: float | None = None  # 99th percentile |Δdepth| / diagonal, at most
    depth_p99_1px: float | None = None  # the same with a one-pixel silhouette tolerance
    normal_deg_median: float | None = None  # median angle between normals, degrees
    normal_deg_p99: float | None = None  # 99th percentile angle between normals, degrees
    normal_deg_p99_1px: float | None = None  # the same with a one-pixel tolerance (reference.compare)
    mask_far_px: int | None = None  # pixels hit by one side only, more than a pixel from the other
    nan: int | None = 0  # NaN pixels in depth or normal

    def violations(self, m: dict[str, Any]) -> list[str]:
        """What the measurement `m` breaks, as readable lines."""
        out = []
        for name, bound in asdict(self).items():
            if bound is None:
                continue
            value = m["nan_depth"] + m["nan_normal"] if name == "nan" else m[name]
            ok = value >= bound if name == "iou" else value <= bound
            if not ok:
                out.append(f"{name} = {value:.4g} {'<' if name == 'iou' else '>'} {bound:.4g}")
        return out

    def check(self, m: dict[str, Any], *context: Any) -> None:
        """Asserts every bound; the message names the failed ones, the context and all figures."""
        _RECORDED.append({"test": os.environ.get("PYTEST_CURRENT_TEST", "?").split(" ")[0],
                          "context": [str(c) for c in context], "bounds": asdict(self),
                          "measured": {k: float(v) for k, v in m.items() if isinstance(v, (int, float))}})
        bad = self.violations(m)
        assert not bad, f"{context}: {'; '.join(bad)}; measured {m}"


def write_recorded() -> None:
    """Writes the session's measurements where GEOMTEX_RECORD_BOUNDS says (if it does)."""
    path = os.environ.get("GEOMTEX_RECORD_BOUNDS")
    if path and _RECORDED:
        with open(path, "w") as f:
            json.dump(_RECORDED, f, indent=1)
