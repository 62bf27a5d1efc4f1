"""The .gtex file: bit-exact round trips, atomic writes, and every corruption caught."""

from __future__ import annotations

import os

import numpy as np
import pytest

import geomtex as gt

from conftest import Converted, converted


@pytest.fixture(scope="module")
def sheet() -> Converted:
    return converted("open_sheet")


@pytest.mark.parametrize("bits", [16, 8])
def test_round_trip_is_bit_exact(sheet: Converted, tmp_path, bits: int) -> None:
    gts = sheet.gts if bits == 16 else gt.convert(sheet.mesh, height_bits=8, max_resolution=256)
    path = tmp_path / "sheet.gtex"
    gts.save(path)
    back = gt.load(path)
    assert len(back) == len(gts)
    assert back.texel_size == gts.texel_size
    assert back.stats == {**gts.stats, "seconds": {}}  # files hold no run's timings
    assert np.array_equal(back.world_from_patch, gts.world_from_patch)
    for i in range(len(back)):
        a, b = back.patch(i), gts.patch(i)
        assert a.keys() == b.keys()
        assert a["height_bits"] == bits and a["height"].dtype == (np.uint8 if bits == 8 else np.uint16)
        for key in a:
            x, y = np.asarray(a[key]), np.asarray(b[key])
            assert x.dtype == y.dtype and np.array_equal(x, y), (i, key)
    pts, nrm = back.to_points()
    assert np.array_equal(pts, gts.to_points()[0]) and np.array_equal(nrm, gts.to_points()[1])
    # Saving what was loaded writes the same bytes.
    back.save(tmp_path / "again.gtex")
    assert (tmp_path / "again.gtex").read_bytes() == path.read_bytes()
    if bits == 8:
        # One byte less per texel than the 16-bit file, in the maps and in stats["bytes"]: a
        # height, a 2-byte octahedral normal and an outline byte (the sheet has no colors).
        sheet.gts.save(tmp_path / "wide.gtex")
        texels = gts.stats["texels"]
        assert (tmp_path / "wide.gtex").stat().st_size - path.stat().st_size == pytest.approx(texels, abs=64)
        # Plus the error-bound map (one byte per 2 x 2 cells), the same for both.
        assert gts.stats["error_bound_bytes"] == sheet.gts.stats["error_bound_bytes"] > 0
        assert gts.stats["bytes"] - gts.stats["error_bound_bytes"] == 4 * texels
        assert sheet.gts.stats["bytes"] - sheet.gts.stats["error_bound_bytes"] == 5 * texels
        assert not any(gts.patch(i)["has_colors"] for i in range(len(gts)))


def test_every_corruption_is_a_format_error(sheet: Converted, tmp_path) -> None:
    path = tmp_path / "s.gtex"
    sheet.gts.save(path)
    data = path.read_bytes()
    cases = {
        "truncated": data[: len(data) // 3],
        "header only": data[:32],
        "tiny": data[:5],
        "flipped payload byte": data[:500] + bytes([data[500] ^ 1]) + data[501:],
        "bad magic": b"XTEX" + data[4:],
        "future version": data[:8] + (9).to_bytes(4, "little") + data[12:],
        "trailing garbage": data + b"\0" * 10,
    }
    messages = {
        "truncated": "truncated", "header only": "truncated", "tiny": "not a .gtex",
        "flipped payload byte": "checksum", "bad magic": "not a .gtex", "future version": "version 9",
        "trailing garbage": "padded",
    }
    for name, blob in cases.items():
        bad = tmp_path / f"{name.replace(' ', '_')}.gtex"
        bad.write_bytes(blob)
        with pytest.raises(gt.FormatError, match=messages[name]) as e:
            gt.load(bad)
        assert bad.name in str(e.value), name


def test_missing_file_is_a_file_error(tmp_path) -> None:
    with pytest.raises(gt.FileError, match="no such file"):
        gt.load(tmp_path / "nope.gtex")


def test_failed_save_leaves_nothing_behind(sheet: Converted, tmp_path) -> None:
    with pytest.raises(gt.FileError, match="missing_dir"):
        sheet.gts.save(tmp_path / "missing_dir" / "x.gtex")
    # A directory in the way: the rename fails, the old content and the folder stay clean.
    (tmp_path / "taken.gtex").mkdir()
    with pytest.raises(gt.FileError):
        sheet.gts.save(tmp_path / "taken.gtex")
    assert sorted(os.listdir(tmp_path)) == ["taken.gtex"]


def test_overwrite_replaces_atomically(sheet: Converted, tmp_path) -> None:
    path = tmp_path / "x.gtex"
    path.write_bytes(b"old")
    sheet.gts.save(path)
    assert gt.load(path).stats == {**sheet.gts.stats, "seconds": {}}
    assert sorted(os.listdir(tmp_path)) == ["x.gtex"]


def _first_patch_offset(data: bytes) -> int:
    """Offset of patch 0's origin in a version 3-5 .gtex file (layout: src/gtex/file.rs)."""
    at = 32 + 8
    for _ in range(2):  # stats, then stage seconds: count, then (name, f64)
        count = int.from_bytes(data[at:at + 4], "little")
        at += 4
        for _ in range(count):
            at += 2 + int.from_bytes(data[at:at + 2], "little") + 8
    count = int.from_bytes(data[at:at + 4], "little")  # per-patch stats: (name, n, f64[n])
    at += 4
    for _ in range(count):
        at += 2 + int.from_bytes(data[at:at + 2], "little")
        at += 4 + 8 * int.from_bytes(data[at:at + 4], "little")
    return at + 4  # past the patch count


def _resealed(data: bytes, at: int, value: bytes) -> bytes:
    """``value`` written at ``at``, with the header's checksum recomputed: only content checks
    can catch it."""
    import zlib

    body = bytearray(data)
    body[at:at + len(value)] = value
    payload = bytes(body[32:])
    return bytes(body[:24]) + zlib.crc32(payload).to_bytes(4, "little") + bytes(body[28:32]) + payload


def test_impossible_content_with_a_valid_checksum_is_a_format_error(sheet: Converted, tmp_path) -> None:
    path = tmp_path / "s.gtex"
    sheet.gts.save(path)
    data = path.read_bytes()
    p0 = _first_patch_offset(data)
    nan, zero3 = np.float64(np.nan).tobytes(), bytes(24)
    # width, height, height bits, color-map flag, face count, ring face count (u32 each)
    sizes = p0 + 15 * 8
    first_face = sizes + 6 * 4
    cases = {
        "NaN origin": (p0, nan, "patch 0: origin is not finite"),
        "zero axis": (p0 + 6 * 8, zero3, r"patch 0: axis 1 is not unit length \(\|a\| = 0\)"),
        "negative extent": (p0 + 12 * 8, np.float64(-1.0).tobytes(), "patch 0: extent 0 must be positive"),
        "zero width": (sizes, bytes(4), "patch 0: width is 0 texels"),
        "huge height": (sizes + 4, (1 << 31).to_bytes(4, "little"), "patch 0: height is 2147483648 texels"),
        "color-map flag": (sizes + 12, (2).to_bytes(4, "little"), "patch 0: the color-map flag must be 0 or 1"),
        "face past the mesh": (first_face, (10**9).to_bytes(4, "little"), "patch 0: face id 1000000000 is past"),
    }
    for name, (at, value, message) in cases.items():
        bad = tmp_path / f"{name.replace(' ', '_')}.gtex"
        bad.write_bytes(_resealed(data, at, value))
        with pytest.raises(gt.FormatError, match=message):
            gt.load(bad)


def test_version_4_files_still_read(tmp_path) -> None:
    """A file as version 4 wrote it (4-byte snorm8 normals, a color map always) loads: the same
    heights and outlines, its colors, and normals re-encoded as 2-byte octahedral codes, within
    the octahedral rounding of the old ones (measured max 0.64° over 200,000 random directions;
    here 0.5° on the fandisk's maps)."""
    from legacy_gtex import write_legacy

    colored = converted("fandisk").gts
    old = gt.load(write_legacy(colored, tmp_path / "v4.gtex", version=4))
    worst = 0.0
    for i in range(len(colored)):
        a, b = old.patch(i), colored.patch(i)
        assert np.array_equal(a["height"], b["height"]) and np.array_equal(a["outline"], b["outline"])
        assert a["has_colors"] and np.array_equal(a["color"], b["color"])
        na, nb = a["normal"][..., :3].astype(float), b["normal"][..., :3].astype(float)
        some = np.linalg.norm(nb, axis=-1) > 0
        assert np.array_equal(some, np.linalg.norm(na, axis=-1) > 0)
        cos = np.sum(na[some] * nb[some], -1) / np.linalg.norm(na[some], axis=-1) / np.linalg.norm(nb[some], axis=-1)
        worst = max(worst, float(np.degrees(np.arccos(np.clip(cos.min(), -1, 1)))))
    assert worst <= 1.5, worst
    # Saved again, it is a current (version-6) file with the same content and no error-bound
    # maps (version 4 had none; a load never invents them).
    old.save(tmp_path / "v6.gtex")
    assert int.from_bytes((tmp_path / "v6.gtex").read_bytes()[8:12], "little") == 6
    again = gt.load(tmp_path / "v6.gtex")
    assert again.stats["texels"] == colored.stats["texels"]
    assert again.stats.get("error_bound_bytes", 0) == 0


def test_maps_hold_only_what_the_mesh_has(sheet: Converted) -> None:
    """No color map for a mesh without colors (the dict still shows neutral colors), one for a
    mesh with them; stats["bytes"] counts 5 and 9 bytes per 16-bit texel, plus the error-bound
    map."""
    plain = sheet.gts
    colored = gt.convert(gt.Mesh(sheet.mesh.vertices, sheet.mesh.faces,
                                 vertex_colors=np.tile([[10, 200, 30]], (len(sheet.mesh.vertices), 1))),
                         hybrid=False)
    for gts, per_texel in ((plain, 5), (colored, 9)):
        assert gts.stats["bytes"] - gts.stats["error_bound_bytes"] == per_texel * gts.stats["texels"]
    p, q = plain.patch(0), colored.patch(0)
    assert not p["has_colors"] and (p["color"] == [200, 200, 200, 255]).all()
    assert q["has_colors"] and (q["color"][q["height"] > 0] == [10, 200, 30, 255]).all()
