//! The .gtigt file format of inverse geometric textures, version 2 (version 1 files, which
//! cannot hold ambient occlusion, are read too). Little-endian throughout.
//!
//! ```text
//! header (32 bytes): magic b"GTIGT\r\n\x1a" | version u32 | primary u32 (0 charts, 1 spherical,
//!                    2 cylindrical) | payload length u64 | CRC-32 of the payload u32 | reserved u32
//! payload: resolution u32 | faces u32 | flags u32 (1 colors, 2 texture coordinates, 4 image,
//!          8 ambient occlusion) |
//!          stats: count u32, then (name: len u16 + UTF-8, value f64) |
//!          grid count u32 | each grid: origin 3 f64 | axes 9 f64 | cell 2 f64 | width u32 |
//!          height u32 |
//!          cell offsets u32[cells + 1] (cells: the grids' width x height summed) |
//!          list payload: count u32, entry indices u32[] |
//!          entries: count u32, each face u32 | grid u32 | corners 6 f32 |
//!          face grid u32[faces] | vertex count u32 | positions f64[vertices * 3] |
//!          faces u32[faces * 3] | normals f32[faces * 9] | colors u8[faces * 12] (flag 1) |
//!          texture coordinates f32[faces * 6] (flag 2) | image width u32, height u32,
//!          RGBA8 pixels (flag 4) | ambient occlusion u8[faces * 3] (flag 8)
//! ```
//! A file whose bytes pass the checksum must still hold a possible texture: finite orthonormal
//! right-handed grids of 1 to MAX_RESOLUTION cells a side whose cells are positive where the
//! projection divides by them, offsets that rise to the payload's length, indices within their
//! tables, finite corners and attributes. The figures derived from the tables are recomputed on
//! load; stage seconds are kept.

use std::path::Path;
use std::sync::Arc;

use glam::{DVec2, DVec3};

use super::{Attributes, Entry, Grid, InverseGeometricTexture, Primary, MAX_RESOLUTION};
use crate::appearance::Image;
use crate::error::{GeomtexError, Result};
use crate::gtex::file::{put_f64s, put_named, write_atomically, Reader};

pub const MAGIC: &[u8; 8] = b"GTIGT\r\n\x1a";
pub const VERSION: u32 = 2;
const HEADER: usize = 32;

fn put_u32s(out: &mut Vec<u8>, v: impl IntoIterator<Item = u32>) {
    for x in v {
        out.extend_from_slice(&x.to_le_bytes());
    }
}

fn put_f32s(out: &mut Vec<u8>, v: impl IntoIterator<Item = f32>) {
    for x in v {
        out.extend_from_slice(&x.to_le_bytes());
    }
}

fn flags(a: &Attributes) -> u32 {
    a.colors.is_some() as u32
        | (a.uv.is_some() as u32) << 1
        | (a.image.is_some() as u32) << 2
        | (a.ao.is_some() as u32) << 3
}

fn encode_payload(igt: &InverseGeometricTexture) -> Vec<u8> {
    let a = &igt.attributes;
    let mut p = Vec::new();
    put_u32s(&mut p, [igt.resolution, igt.face_count() as u32, flags(a)]);
    put_named(&mut p, &igt.stats);
    put_u32s(&mut p, [igt.grids.len() as u32]);
    for g in &igt.grids {
        put_f64s(&mut p, &g.origin.to_array());
        for axis in &g.axes {
            put_f64s(&mut p, &axis.to_array());
        }
        put_f64s(&mut p, &g.cell.to_array());
        put_u32s(&mut p, [g.width, g.height]);
    }
    put_u32s(&mut p, igt.cell_start.iter().copied());
    put_u32s(&mut p, [igt.cell_entries.len() as u32]);
    put_u32s(&mut p, igt.cell_entries.iter().copied());
    put_u32s(&mut p, [igt.entries.len() as u32]);
    for e in &igt.entries {
        put_u32s(&mut p, [e.face, e.grid]);
        put_f32s(&mut p, e.corners.iter().flatten().copied());
    }
    put_u32s(&mut p, igt.face_grid.iter().copied());
    put_u32s(&mut p, [igt.positions.len() as u32]);
    for v in &igt.positions {
        put_f64s(&mut p, &v.to_array());
    }
    put_u32s(&mut p, igt.faces.iter().flatten().copied());
    put_f32s(&mut p, a.normals.iter().flatten().flatten().copied());
    if let Some(c) = &a.colors {
        p.extend(c.iter().flatten().flatten());
    }
    if let Some(uv) = &a.uv {
        put_f32s(&mut p, uv.iter().flatten().flatten().copied());
    }
    if let Some(image) = &a.image {
        put_u32s(&mut p, [image.width() as u32, image.height() as u32]);
        p.extend(image.pixels().iter().flatten());
    }
    if let Some(ao) = &a.ao {
        p.extend(ao.iter().flatten());
    }
    p
}

pub fn encode(igt: &InverseGeometricTexture) -> Vec<u8> {
    let payload = encode_payload(igt);
    let mut out = Vec::with_capacity(HEADER + payload.len());
    out.extend_from_slice(MAGIC);
    put_u32s(&mut out, [VERSION, igt.primary.code()]);
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    put_u32s(&mut out, [crc32fast::hash(&payload), 0]);
    out.extend_from_slice(&payload);
    out
}

type Text<T> = std::result::Result<T, String>;

fn u32s(r: &mut Reader, n: usize, what: &str) -> Text<Vec<u32>> {
    let b = r.take(n.saturating_mul(4), what)?;
    Ok(b.chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
        .collect())
}

fn f32s(r: &mut Reader, n: usize, what: &str) -> Text<Vec<f32>> {
    let b = r.take(n.saturating_mul(4), what)?;
    let v: Vec<f32> = b
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    match v.iter().position(|x| !x.is_finite()) {
        Some(k) => Err(format!("{what}: value {k} is not finite")),
        None => Ok(v),
    }
}

fn read_grid(r: &mut Reader, k: usize, first_cell: u64, primary: Primary) -> Text<Grid> {
    let what = format!("grid {k}");
    let origin = r.vec3(&what)?;
    let axes = [r.vec3(&what)?, r.vec3(&what)?, r.vec3(&what)?];
    let cell = DVec2::new(r.f64(&what)?, r.f64(&what)?);
    let (width, height) = (r.u32(&what)?, r.u32(&what)?);
    let finite = origin.is_finite() && axes.iter().all(|a| a.is_finite()) && cell.is_finite();
    let orthonormal = (0..3)
        .all(|i| (0..3).all(|j| (axes[i].dot(axes[j]) - f64::from(u8::from(i == j))).abs() < 1e-6));
    if !finite || !orthonormal || cell.min_element() < 0.0 {
        return Err(format!("{what}: not a finite orthonormal frame"));
    }
    if axes[0].cross(axes[1]).dot(axes[2]) < 0.0 {
        return Err(format!(
            "{what}: axes are left-handed (x × y points away from z)"
        ));
    }
    // The cell sizes the projection divides by (primary.rs): u and v for charts, v for a
    // cylinder; a sphere's cells are angles and its cell sizes unused.
    let used = match primary {
        Primary::Charts => cell.min_element(),
        Primary::Cylindrical => cell.y,
        Primary::Spherical => 1.0,
    };
    if used <= 0.0 {
        return Err(format!(
            "{what}: a cell of {} x {} world units for a {} primary (it must be positive)",
            cell.x,
            cell.y,
            primary.name()
        ));
    }
    for (side, n) in [("width", width), ("height", height)] {
        if !(1..=MAX_RESOLUTION).contains(&n) {
            return Err(format!(
                "{what}: {side} {n} is not 1 to {MAX_RESOLUTION} cells"
            ));
        }
    }
    if first_cell + width as u64 * height as u64 >= 1 << 31 {
        return Err(format!("{what}: more than 2^31 cells in all"));
    }
    Ok(Grid {
        origin,
        axes,
        cell,
        width,
        height,
        first_cell: first_cell as u32,
    })
}

fn read_entries(r: &mut Reader, faces: u32, grids: u32) -> Text<Vec<Entry>> {
    let n = r.u32("entry count")? as usize;
    let raw = r.take(n.saturating_mul(32), "entries")?;
    let mut entries = Vec::with_capacity(n);
    for (k, b) in raw.chunks_exact(32).enumerate() {
        let word = |i: usize| u32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap());
        let (face, grid) = (word(0), word(1));
        let f = |i: usize| f32::from_bits(word(2 + i));
        let corners = [[f(0), f(1)], [f(2), f(3)], [f(4), f(5)]];
        if face >= faces || grid >= grids || !corners.iter().flatten().all(|x| x.is_finite()) {
            return Err(format!(
                "entry {k}: face {face} of {faces}, grid {grid} of {grids}, or a non-finite corner"
            ));
        }
        entries.push(Entry {
            face,
            grid,
            corners,
        });
    }
    Ok(entries)
}

/// Cell offsets and list payload (entry indices are checked once the entries are read).
fn read_lists(r: &mut Reader, cells: usize) -> Text<(Vec<u32>, Vec<u32>)> {
    let start = u32s(r, cells + 1, "cell offsets")?;
    let n = r.u32("list payload count")? as usize;
    let payload = u32s(r, n, "list payload")?;
    if start[0] != 0 || start.windows(2).any(|w| w[0] > w[1]) || start[cells] as usize != n {
        return Err("cell offsets do not rise from 0 to the list payload's length".into());
    }
    Ok((start, payload))
}

fn read_attributes(r: &mut Reader, faces: usize, flags: u32) -> Text<Attributes> {
    let normals = f32s(r, faces * 9, "normals")?;
    let normals = normals
        .chunks_exact(9)
        .map(|c| std::array::from_fn(|k| [c[3 * k], c[3 * k + 1], c[3 * k + 2]]))
        .collect();
    let colors = if flags & 1 != 0 {
        let b = r.take(faces * 12, "colors")?;
        Some(
            b.chunks_exact(12)
                .map(|c| std::array::from_fn(|k| c[4 * k..4 * k + 4].try_into().unwrap()))
                .collect(),
        )
    } else {
        None
    };
    let uv = if flags & 2 != 0 {
        let v = f32s(r, faces * 6, "texture coordinates")?;
        Some(
            v.chunks_exact(6)
                .map(|c| std::array::from_fn(|k| [c[2 * k], c[2 * k + 1]]))
                .collect(),
        )
    } else {
        None
    };
    let image = if flags & 4 != 0 {
        let (w, h) = (r.u32("image size")? as usize, r.u32("image size")? as usize);
        let pixels = r.take(w.saturating_mul(h).saturating_mul(4), "image pixels")?;
        Some(Arc::new(
            Image::new(w, h, pixels).map_err(|e| e.to_string())?,
        ))
    } else {
        None
    };
    let ao = if flags & 8 != 0 {
        let b = r.take(faces * 3, "ambient occlusion")?;
        Some(b.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    } else {
        None
    };
    Ok(Attributes {
        normals,
        colors,
        uv,
        image,
        ao,
    })
}

/// The detailed mesh's positions and faces.
fn read_geometry(r: &mut Reader, faces: usize) -> Text<(Vec<DVec3>, Vec<[u32; 3]>)> {
    let n = r.u32("vertex count")? as usize;
    let b = r.take(n.saturating_mul(24), "positions")?;
    let positions: Vec<DVec3> = b
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect::<Vec<_>>()
        .chunks_exact(3)
        .map(DVec3::from_slice)
        .collect();
    if positions.iter().any(|p| !p.is_finite()) {
        return Err("a vertex position is not finite".into());
    }
    let idx = u32s(r, faces * 3, "faces")?;
    if let Some(k) = idx.iter().position(|&v| v as usize >= n) {
        return Err(format!("face {} names vertex {} of {n}", k / 3, idx[k]));
    }
    let tris = idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    Ok((positions, tris))
}

/// The texture a file's bytes hold, or what is wrong with them.
pub fn decode(bytes: &[u8]) -> Text<InverseGeometricTexture> {
    if bytes.len() < HEADER || &bytes[..8] != MAGIC {
        return Err("not a .gtigt file (bad magic number or shorter than its header)".into());
    }
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    if !(1..=VERSION).contains(&word(8)) {
        return Err(format!(
            "file format version {}; this geomtex reads versions 1 to {VERSION}",
            word(8)
        ));
    }
    let len = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
    let payload = &bytes[HEADER..];
    if payload.len() as u64 != len {
        return Err(format!(
            "truncated or padded: the header promises {len} payload bytes, the file has {}",
            payload.len()
        ));
    }
    if crc32fast::hash(payload) != word(24) {
        return Err("checksum mismatch: the file is corrupt".into());
    }
    let primary = Primary::from_code(word(12))
        .ok_or_else(|| format!("primary parameterization code {} is unknown", word(12)))?;
    let mut r = Reader {
        data: payload,
        pos: 0,
    };
    let (resolution, faces, flags) = (r.u32("resolution")?, r.u32("faces")?, r.u32("flags")?);
    // Version 1 knew flags 1, 2 and 4; 8 (ambient occlusion) came with version 2.
    let known = if word(8) == 1 { 7 } else { 15 };
    if flags & !known != 0 {
        return Err(format!(
            "attribute flags {flags:#x} name unknown attributes"
        ));
    }
    super::check_resolution(resolution as i64).map_err(|e| e.to_string())?;
    let stats = r.named("stats")?;
    let n_grids = r.u32("grid count")? as usize;
    let mut grids = Vec::with_capacity(n_grids.min(1 << 16));
    let mut cells = 0u64;
    for k in 0..n_grids {
        let g = read_grid(&mut r, k, cells, primary)?;
        cells += g.cells() as u64;
        grids.push(g);
    }
    if grids.is_empty() || (primary.wraps() && grids.len() != 1) {
        return Err(format!(
            "{} grids for a {} primary",
            grids.len(),
            primary.name()
        ));
    }
    let (cell_start, cell_entries) = read_lists(&mut r, cells as usize)?;
    let entries = read_entries(&mut r, faces, grids.len() as u32)?;
    if let Some(k) = cell_entries
        .iter()
        .position(|&e| e as usize >= entries.len())
    {
        return Err(format!(
            "list payload item {k} names entry {} of {}",
            cell_entries[k],
            entries.len()
        ));
    }
    let face_grid = u32s(&mut r, faces as usize, "face grids")?;
    if let Some(f) = face_grid
        .iter()
        .position(|&g| g != u32::MAX && g as usize >= grids.len())
    {
        return Err(format!("face {f} names grid {}", face_grid[f]));
    }
    let (positions, mesh_faces) = read_geometry(&mut r, faces as usize)?;
    let attributes = read_attributes(&mut r, faces as usize, flags)?;
    if r.pos != payload.len() {
        return Err(format!("{} bytes of trailing data", payload.len() - r.pos));
    }
    let mut igt = InverseGeometricTexture {
        primary,
        resolution,
        grids,
        cell_start,
        cell_entries,
        entries,
        face_grid,
        positions,
        faces: mesh_faces,
        attributes,
        stats,
        histogram: Vec::new(),
    };
    igt.figure();
    Ok(igt)
}

impl InverseGeometricTexture {
    /// Writes a .gtigt file atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        write_atomically(path, &encode(self))
    }

    pub fn load(path: &Path) -> Result<InverseGeometricTexture> {
        let bytes = std::fs::read(path)
            .map_err(|e| GeomtexError::io(format!("cannot read {}", path.display()), e))?;
        decode(&bytes).map_err(|e| GeomtexError::Format(format!("{}: {e}", path.display())))
    }
}
