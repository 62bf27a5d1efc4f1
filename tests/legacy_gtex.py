""".gtex files as versions 3 and 4 wrote them (the layout in src/gtex/file.rs's header comment),
written here from a set's public arrays, not by geomtex: every patch with a color map, normals as
(x, y, z, 0) / 127 signed bytes; version 3 without outline maps."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

import geomtex as gt


def _name(name: str) -> bytes:
    b = name.encode()
    return struct.pack("<H", len(b)) + b


def legacy_bytes(gts: gt.GeometryTextureSet, version: int = 4,
                 normal_maps: list[np.ndarray] | None = None) -> bytes:
    """The bytes of a version-``version`` (3 or 4) file holding ``gts``, with each patch's normal
    map replaced by ``normal_maps[i]`` ((H, W, 4) int8, x, y, z, 0 / 127) if given."""
    assert version in (3, 4)
    stats = {k: v for k, v in gts.stats.items() if isinstance(v, (int, float)) and not isinstance(v, bool)}
    per_patch = {k: np.asarray(v, np.float64) for k, v in gts.stats.items() if isinstance(v, np.ndarray)}
    out = struct.pack("<d", gts.texel_size) + struct.pack("<I", len(stats))
    out += b"".join(_name(k) + struct.pack("<d", float(v)) for k, v in stats.items())
    out += struct.pack("<I", 0) + struct.pack("<I", len(per_patch))
    out += b"".join(_name(k) + struct.pack("<I", len(v)) + v.astype("<f8").tobytes() for k, v in per_patch.items())
    out += struct.pack("<I", len(gts))
    for i in range(len(gts)):
        p = gts.patch(i)
        h, w = p["height"].shape
        out += np.asarray(p["origin"], "<f8").tobytes() + np.asarray(p["axes"], "<f8").tobytes()
        out += np.asarray(p["extent"], "<f8").tobytes()
        out += struct.pack("<5I", w, h, p["height_bits"], len(p["faces"]), len(p["ring_faces"]))
        out += np.asarray(p["faces"], "<u4").tobytes() + np.asarray(p["ring_faces"], "<u4").tobytes()
        out += p["height"].astype("<u2" if p["height_bits"] == 16 else np.uint8).tobytes()
        normal = p["normal"] if normal_maps is None else normal_maps[i]
        out += normal.astype(np.int8).tobytes() + p["color"].astype(np.uint8).tobytes()
        if version >= 4:
            out += p["outline"].astype(np.int8).tobytes()
    header = b"GTEX\r\n\x1a\n" + struct.pack("<IIQII", version, 0, len(out), zlib.crc32(out), 0)
    return header + out


def write_legacy(gts: gt.GeometryTextureSet, path: Path, version: int = 4) -> Path:
    path.write_bytes(legacy_bytes(gts, version))
    return path
