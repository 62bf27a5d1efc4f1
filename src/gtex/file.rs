//! The .gtex file format, versions 6 to 8 (versions 1 to 5 are still read). Little-endian
//! throughout. A set with a bound map of an exponent byte (every map conversion makes now) is
//! written as version 8; any other as version 7 with triangles (a hybrid conversion), else 6, so
//! earlier geomtex releases still read every set they can draw.
//!
//! ```text
//! header (32 bytes): magic b"GTEX\r\n\x1a\n" | version u32 | reserved u32 | payload length u64 |
//!                    CRC-32 of the payload u32 | reserved u32
//! payload: texel_size f64 | stats: count u32, then (name: len u16 + UTF-8, value f64) |
//!          stage seconds: same (written empty) | per-patch stats: count u32, then (name: len u16 + UTF-8, n u32,
//!          f64[n]) | patch count u32 | each patch:
//!          origin 3 f64 | axes 9 f64 | extent 3 f64 | width u32 | height u32 |
//!          height bits u32 (8 or 16) | color map u32 (0 or 1) | faces u32 | ring faces u32 |
//!          face ids u32[] | ring face ids u32[] | heights u8[w*h] or u16[w*h] |
//!          normals i8[w*h*2] (octahedral, `gtex::encode_normal`) |
//!          colors u8[w*h*4] (only with a color map) | outline i8[w*h] |
//!          error-bound map u32 (0 none; 1: scale f32 | codes u8[bw*bh], one per block of
//!          2 x 2 cells, bw = ceil((w + 1) / 2); 2, version 8 only: exponent i8 (scale 2^e,
//!          -128 for 0) | codes u8[bw*bh] in blocks of `gtex::bound::block_side(w, h, maps'
//!          bytes)` cells, left out after -128: every code 0)
//!          ... then, versions 7 and 8: triangles u32 (0 or 1), then with them:
//!          centre 3 f64 | normal rule u32 (0 crease, 1 smooth, 2 flat) | crease angle f64 |
//!          vertices u32 | faces u32 | clusters u32 | colors u32 (0 or 1) |
//!          positions f32[3*vertices] (offsets from the centre) | faces u32[3*faces] |
//!          cluster starts u32[clusters + 1] | source face ids u32[faces] |
//!          reasons u8[clusters] (`KeptBecause`) |
//!          colors u8[4*vertices] (only with colors)
//! ```
//! Version 5 has no error-bound field: its patches have no bound (NaN in frames).
//! A file whose bytes pass the checksum must still hold a possible set
//! (`GeometryTextureSet::validate`: finite orthonormal frames, positive extents, 1 to 4096 texels a
//! side, codes within their bits, face ids within the "faces" stat, per-patch stats per patch).
//! Version 4 has no color-map field: every patch has colors, and normals are i8[w*h*4]
//! (x, y, z, 0) / 127, re-encoded as octahedral codes when read.
//! Version 3 is as version 4 without the outline map (read as wholly inside: the surface ends at the
//! texel grid, as it did); version 2 also lacks the per-patch stats; version 1 also lacks the height-bits field
//! (every patch has 16-bit heights).
//! Written by hand (not serde/bincode) so the layout is fixed, documented and readable from any
//! language; the magic catches text-mode mangling the way PNG's does.

use std::io::Write;
use std::path::Path;

use glam::DVec3;

use super::bound::ScaleStorage;
use super::{GeometryTextureSet, KeptBecause, Patch, SetTriangles, Stats};
use crate::error::GeomtexError;
use crate::mesh::{Mesh, NormalRule, NormalSource};

pub const MAGIC: &[u8; 8] = b"GTEX\r\n\x1a\n";
pub const VERSION: u32 = 8;
/// The version a set with triangles and bound maps of f32 scales (or none) is written as.
const TRIANGLES_VERSION: u32 = 7;
/// The version a set without triangles and with bound maps of f32 scales (or none) is written as.
const PATCHES_ONLY_VERSION: u32 = 6;
const HEADER: usize = 32;

pub(crate) fn put_f64s(out: &mut Vec<u8>, v: &[f64]) {
    for x in v {
        out.extend_from_slice(&x.to_le_bytes());
    }
}

pub(crate) fn put_name(out: &mut Vec<u8>, name: &str) {
    let b = name.as_bytes();
    out.extend_from_slice(&(b.len().min(u16::MAX as usize) as u16).to_le_bytes());
    out.extend_from_slice(&b[..b.len().min(u16::MAX as usize)]);
}

pub(crate) fn put_named(out: &mut Vec<u8>, list: &[(String, f64)]) {
    out.extend_from_slice(&(list.len() as u32).to_le_bytes());
    for (name, v) in list {
        put_name(out, name);
        out.extend_from_slice(&v.to_le_bytes());
    }
}

pub fn encode(set: &GeometryTextureSet) -> Vec<u8> {
    let mut p = Vec::with_capacity(set.map_bytes() + 1024);
    put_f64s(&mut p, &[set.texel_size]);
    put_named(&mut p, &set.stats.values);
    // Stage seconds are a fact about one run, not about the set: files leave them out (an empty
    // list), so the same mesh and options always give the same bytes (batch jobs, caches and
    // checksums rely on it). Files written before this still carry theirs and read back whole.
    put_named(&mut p, &[]);
    p.extend_from_slice(&(set.stats.per_patch.len() as u32).to_le_bytes());
    for (name, values) in &set.stats.per_patch {
        put_name(&mut p, name);
        p.extend_from_slice(&(values.len() as u32).to_le_bytes());
        put_f64s(&mut p, values);
    }
    p.extend_from_slice(&(set.patches.len() as u32).to_le_bytes());
    for patch in &set.patches {
        put_f64s(&mut p, &patch.origin.to_array());
        for a in &patch.axes {
            put_f64s(&mut p, &a.to_array());
        }
        put_f64s(&mut p, &patch.extent.to_array());
        for n in [
            patch.width,
            patch.height,
            patch.height_bits as u32,
            patch.has_colors() as u32,
            patch.faces.len() as u32,
            patch.ring_faces.len() as u32,
        ] {
            p.extend_from_slice(&n.to_le_bytes());
        }
        for f in patch.faces.iter().chain(&patch.ring_faces) {
            p.extend_from_slice(&f.to_le_bytes());
        }
        if patch.height_bits == 8 {
            p.extend(patch.heights.iter().map(|&q| q.min(255) as u8));
        } else {
            for q in &patch.heights {
                p.extend_from_slice(&q.to_le_bytes());
            }
        }
        p.extend_from_slice(bytemuck::cast_slice(&patch.normals));
        p.extend_from_slice(bytemuck::cast_slice(&patch.colors));
        p.extend_from_slice(bytemuck::cast_slice(&patch.outline));
        put_error_bound(patch, &mut p);
    }
    let exponents = (set.patches.iter())
        .filter_map(|p| p.error_bound.as_ref())
        .any(|m| m.storage == ScaleStorage::Exponent);
    let version = match (&set.triangles, exponents) {
        (None, false) => PATCHES_ONLY_VERSION,
        (None, true) => {
            p.extend_from_slice(&0u32.to_le_bytes());
            VERSION
        }
        (Some(t), _) => {
            p.extend_from_slice(&1u32.to_le_bytes());
            put_triangles(t, &mut p);
            if exponents {
                VERSION
            } else {
                TRIANGLES_VERSION
            }
        }
    };
    let mut out = Vec::with_capacity(HEADER + p.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&(p.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&p).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&p);
    out
}

/// A bounds-checked reader that names what it was reading when the data ran out.
pub(crate) struct Reader<'a> {
    pub(crate) data: &'a [u8],
    pub(crate) pos: usize,
}

impl<'a> Reader<'a> {
    pub(crate) fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], String> {
        if self.data.len() - self.pos < n {
            return Err(format!(
                "truncated: {what} needs {n} bytes at payload offset {} but only {} remain",
                self.pos,
                self.data.len() - self.pos
            ));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    pub(crate) fn u16(&mut self, what: &str) -> Result<u16, String> {
        Ok(u16::from_le_bytes(self.take(2, what)?.try_into().unwrap()))
    }
    pub(crate) fn u32(&mut self, what: &str) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().unwrap()))
    }
    pub(crate) fn f64(&mut self, what: &str) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.take(8, what)?.try_into().unwrap()))
    }
    pub(crate) fn vec3(&mut self, what: &str) -> Result<DVec3, String> {
        Ok(DVec3::new(
            self.f64(what)?,
            self.f64(what)?,
            self.f64(what)?,
        ))
    }
    pub(crate) fn name(&mut self, what: &str) -> Result<String, String> {
        let len = self.u16(what)? as usize;
        String::from_utf8(self.take(len, what)?.to_vec())
            .map_err(|_| format!("{what}: a name is not UTF-8"))
    }
    pub(crate) fn named(&mut self, what: &str) -> Result<Vec<(String, f64)>, String> {
        let n = self.u32(what)? as usize;
        let mut out = Vec::with_capacity(n.min(4096));
        for _ in 0..n {
            let name = self.name(what)?;
            out.push((name, self.f64(what)?));
        }
        Ok(out)
    }
    pub(crate) fn named_arrays(&mut self, what: &str) -> Result<Vec<(String, Vec<f64>)>, String> {
        let n = self.u32(what)? as usize;
        let mut out = Vec::with_capacity(n.min(4096));
        for _ in 0..n {
            let name = self.name(what)?;
            let len = self.u32(what)? as usize;
            // Checked before allocating, so a corrupt count cannot ask for terabytes.
            let bytes = self.take(len.saturating_mul(8), what)?;
            let values = bytes
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
                .collect();
            out.push((name, values));
        }
        Ok(out)
    }
}

/// Patch `k` of a file of format `version`; its size is checked before its maps are read.
fn read_patch(r: &mut Reader, k: usize, version: u32) -> Result<Patch, String> {
    let what = format!("patch {k}");
    let origin = r.vec3(&what)?;
    let axes = [r.vec3(&what)?, r.vec3(&what)?, r.vec3(&what)?];
    let extent = r.vec3(&what)?;
    let (w, h) = (r.u32(&what)?, r.u32(&what)?);
    super::validate::check_size(w, h).map_err(|e| format!("{what}: {e}"))?;
    let height_bits = if version >= 2 {
        match r.u32(&what)? {
            b @ (8 | 16) => b as u8,
            b => return Err(format!("{what}: height bits must be 8 or 16, found {b}")),
        }
    } else {
        16
    };
    let colored = if version >= 5 {
        match r.u32(&what)? {
            c @ (0 | 1) => c == 1,
            c => {
                return Err(format!(
                    "{what}: the color-map flag must be 0 or 1, found {c}"
                ))
            }
        }
    } else {
        true
    };
    let (nf, nr) = (r.u32(&what)? as usize, r.u32(&what)? as usize);
    let texels = w as usize * h as usize;
    let ids = r.take((nf + nr) * 4, &format!("{what} face ids"))?;
    let ids: Vec<u32> = ids
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    let code_bytes = height_bits as usize / 8;
    let heights = r.take(texels * code_bytes, &format!("{what} heights"))?;
    let heights = if code_bytes == 1 {
        heights.iter().map(|&q| q as u16).collect()
    } else {
        heights
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]))
            .collect()
    };
    let normals = if version >= 5 {
        bytemuck::cast_slice::<u8, [i8; 2]>(r.take(texels * 2, &format!("{what} normals"))?)
            .to_vec()
    } else {
        let snorm = r.take(texels * 4, &format!("{what} normals"))?;
        bytemuck::cast_slice::<u8, [i8; 4]>(snorm)
            .iter()
            .map(|&n| super::encode_normal(super::decode_snorm8(n)))
            .collect()
    };
    let colors = if colored {
        bytemuck::cast_slice::<u8, [u8; 4]>(r.take(texels * 4, &format!("{what} colors"))?).to_vec()
    } else {
        Vec::new()
    };
    let outline = if version >= 4 {
        bytemuck::cast_slice::<u8, i8>(r.take(texels, &format!("{what} outline"))?).to_vec()
    } else {
        vec![super::OUTLINE_INSIDE; texels]
    };
    let error_bound = if version >= 6 {
        let map_bytes = super::map_bytes(w as usize * h as usize, height_bits, colored);
        read_error_bound(r, &what, (w, h, map_bytes), version)?
    } else {
        None
    };
    Ok(Patch {
        origin,
        axes,
        extent,
        width: w,
        height: h,
        height_bits,
        heights,
        normals,
        colors,
        faces: ids[..nf].to_vec(),
        ring_faces: ids[nf..].to_vec(),
        outline,
        error_bound,
    })
}

/// A patch's error-bound field: 0, none; 1 (version 6 on), an f32 scale and codes in 2 x 2
/// blocks; 2 (version 8 on), an exponent byte and codes in blocks of `bound::block_side`.
fn put_error_bound(patch: &Patch, p: &mut Vec<u8>) {
    match patch
        .error_bound
        .as_ref()
        .map(|map| map.in_file_blocks(patch))
    {
        None => p.extend_from_slice(&0u32.to_le_bytes()),
        Some(map) => {
            match map.storage {
                ScaleStorage::F32 => {
                    p.extend_from_slice(&1u32.to_le_bytes());
                    p.extend_from_slice(&map.scale.to_le_bytes());
                }
                ScaleStorage::Exponent => {
                    let e = super::bound::exponent_at_least(map.scale);
                    p.extend_from_slice(&2u32.to_le_bytes());
                    p.push(e as u8);
                    if map.scale == 0.0 {
                        return; // every code 0: none written
                    }
                }
            }
            p.extend_from_slice(&map.codes);
        }
    }
}

/// A patch's error-bound field (`put_error_bound`) in a file of format `version`, for a patch
/// of `w` x `h` texels whose maps take `map_bytes`.
fn read_error_bound(
    r: &mut Reader,
    what: &str,
    (w, h, map_bytes): (u32, u32, usize),
    version: u32,
) -> Result<Option<super::ErrorBoundMap>, String> {
    match r.u32(what)? {
        0 => Ok(None),
        2 if version >= 8 => {
            let e = r.take(1, &format!("{what} error-bound exponent"))?[0] as i8;
            let block = super::bound::block_side(w, h, map_bytes);
            let (bw, bh) = super::bound::block_dims(w, h, block);
            let scale = super::bound::scale_of_exponent(e);
            let codes = if scale == 0.0 {
                vec![0; bw * bh] // a zero scale's codes are not written
            } else {
                (r.take(bw * bh, &format!("{what} error-bound codes"))?).to_vec()
            };
            Ok(Some(super::ErrorBoundMap {
                scale,
                codes,
                block,
                storage: ScaleStorage::Exponent,
            }))
        }
        1 => {
            let scale = f32::from_le_bytes(
                r.take(4, &format!("{what} error-bound scale"))?
                    .try_into()
                    .unwrap(),
            );
            if !(scale.is_finite() && scale >= 0.0) {
                return Err(format!(
                    "{what}: the error-bound scale must be finite and >= 0, found {scale}"
                ));
            }
            let (bw, bh) = super::bound::block_dims(w, h, super::bound::BLOCK);
            let codes = r
                .take(bw * bh, &format!("{what} error-bound codes"))?
                .to_vec();
            Ok(Some(super::ErrorBoundMap {
                scale,
                codes,
                block: super::bound::BLOCK,
                storage: ScaleStorage::F32,
            }))
        }
        f => Err(format!(
            "{what}: the error-bound flag must be 0, 1 or (from version 8) 2, found {f}"
        )),
    }
}

pub fn decode(bytes: &[u8]) -> Result<GeometryTextureSet, String> {
    if bytes.len() < HEADER || &bytes[..8] != MAGIC {
        return Err("not a .gtex file (bad magic number or shorter than its header)".into());
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
    if !(1..=VERSION).contains(&version) {
        return Err(format!(
            "file format version {version}; this geomtex reads versions 1 to {VERSION}"
        ));
    }
    let len = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
    let crc = u32::from_le_bytes(bytes[24..28].try_into().unwrap());
    let payload = &bytes[HEADER..];
    if payload.len() as u64 != len {
        return Err(format!(
            "truncated or padded: the header promises {len} payload bytes, the file has {}",
            payload.len()
        ));
    }
    if crc32fast::hash(payload) != crc {
        return Err("checksum mismatch: the file is corrupt".into());
    }
    let mut r = Reader {
        data: payload,
        pos: 0,
    };
    let texel_size = r.f64("texel size")?;
    let stats = Stats {
        values: r.named("stats")?,
        seconds: r.named("stage seconds")?,
        per_patch: if version >= 3 {
            r.named_arrays("per-patch stats")?
        } else {
            Vec::new()
        },
    };
    let n = r.u32("patch count")? as usize;
    let mut patches = Vec::with_capacity(n.min(1 << 16));
    for k in 0..n {
        patches.push(read_patch(&mut r, k, version)?);
    }
    let triangles = match (version >= 7).then(|| r.u32("triangle flag")).transpose()? {
        None | Some(0) => None,
        Some(1) => Some(read_triangles(&mut r)?),
        Some(f) => return Err(format!("the triangle flag must be 0 or 1, found {f}")),
    };
    if r.pos != payload.len() {
        return Err(format!(
            "{} bytes of trailing data after the last patch or triangle",
            payload.len() - r.pos
        ));
    }
    let mut set = GeometryTextureSet {
        patches,
        texel_size,
        stats,
        triangles,
    };
    set.validate()?;
    set.sync_error_bound_stats();
    Ok(set)
}

fn rule_code(rule: NormalRule) -> u32 {
    match rule.source {
        NormalSource::Crease => 0,
        NormalSource::Smooth => 1,
        NormalSource::Flat => 2,
    }
}

/// The triangle section of a version 7 or 8 file (layout above).
pub(crate) fn put_triangles(t: &SetTriangles, out: &mut Vec<u8>) {
    let (m, centre) = (t.mesh(), t.centre);
    put_f64s(out, &centre.to_array());
    out.extend_from_slice(&rule_code(t.shaded.rule).to_le_bytes());
    put_f64s(out, &[t.shaded.rule.crease_angle]);
    for n in [
        m.positions.len(),
        m.faces.len(),
        t.clusters(),
        m.colors.is_some() as usize,
    ] {
        out.extend_from_slice(&(n as u32).to_le_bytes());
    }
    for p in &m.positions {
        for x in (*p - centre).as_vec3().to_array() {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    out.extend_from_slice(bytemuck::cast_slice(&m.faces));
    out.extend_from_slice(bytemuck::cast_slice(&t.starts));
    out.extend_from_slice(bytemuck::cast_slice(&t.source_faces));
    out.extend(t.because.iter().map(|&b| b as u8));
    if let Some(colors) = &m.colors {
        out.extend_from_slice(bytemuck::cast_slice(colors));
    }
}

/// Reads what `encode` wrote; sizes are checked before anything is allocated.
fn read_triangles(r: &mut Reader) -> Result<SetTriangles, String> {
    let centre = r.vec3("triangles: centre")?;
    let source = match r.u32("triangles: normal rule")? {
        0 => NormalSource::Crease,
        1 => NormalSource::Smooth,
        2 => NormalSource::Flat,
        other => return Err(format!("triangles: normal rule {other} is not 0, 1 or 2")),
    };
    let crease_angle = r.f64("triangles: crease angle")?;
    let rule = NormalRule::from_keywords(Some(source), Some(crease_angle))
        .map_err(|e| format!("triangles: {e}"))?;
    let mut counts = [0usize; 4];
    for (k, what) in ["vertices", "faces", "clusters", "color flag"]
        .iter()
        .enumerate()
    {
        counts[k] = r.u32(&format!("triangles: {what}"))? as usize;
    }
    let [vertices, faces, clusters, colored] = counts;
    if colored > 1 {
        return Err(format!(
            "triangles: the color flag must be 0 or 1, found {colored}"
        ));
    }
    let words = |r: &mut Reader, n: usize, what: &str| -> Result<Vec<u32>, String> {
        let bytes = r.take(n.saturating_mul(4), what)?;
        Ok(bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
            .collect())
    };
    let floats = words(r, vertices.saturating_mul(3), "triangles: positions")?;
    let positions = floats
        .chunks_exact(3)
        .map(|c| {
            centre
                + glam::Vec3::new(
                    f32::from_bits(c[0]),
                    f32::from_bits(c[1]),
                    f32::from_bits(c[2]),
                )
                .as_dvec3()
        })
        .collect();
    let indices = words(r, faces.saturating_mul(3), "triangles: faces")?;
    let faces: Vec<[u32; 3]> = indices
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let starts = words(r, clusters.saturating_add(1), "triangles: cluster starts")?;
    let source_faces = words(r, indices.len() / 3, "triangles: source face ids")?;
    let because = (r.take(clusters, "triangles: reasons")?.iter())
        .map(|&c| KeptBecause::from_code(c).ok_or(format!("triangles: reason code {c}")))
        .collect::<Result<_, _>>()?;
    let colors = match colored {
        1 => Some(
            (r.take(vertices.saturating_mul(4), "triangles: colors")?
                .chunks_exact(4))
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect(),
        ),
        _ => None,
    };
    let mesh = Mesh {
        positions,
        faces,
        colors,
        appearance: Default::default(),
    };
    let t = SetTriangles::filed(mesh, centre, rule, starts, because, source_faces);
    t.validate()?;
    Ok(t)
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, synced, then renamed over
/// it, so a failure never leaves a half-written file (shared by every format geomtex writes).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> crate::error::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let ctx = |what: &str| format!("{what} {}", path.display());
    let mut builder = tempfile::Builder::new();
    // mkstemp's 0600 would survive the rename; ask for 0666 and let the umask trim it, as
    // for any file the user creates.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    let mut tmp = builder
        .tempfile_in(dir)
        .map_err(|e| GeomtexError::io(ctx("cannot create a temporary file to write"), e))?;
    tmp.write_all(bytes)
        .map_err(|e| GeomtexError::io(ctx("cannot write"), e))?;
    tmp.as_file()
        .sync_all()
        .map_err(|e| GeomtexError::io(ctx("cannot sync"), e))?;
    tmp.persist(path)
        .map_err(|e| GeomtexError::io(ctx("cannot rename into"), e.error))?;
    Ok(())
}

impl GeometryTextureSet {
    /// Writes the set atomically (`write_atomically`).
    pub fn save(&self, path: &Path) -> crate::error::Result<()> {
        write_atomically(path, &encode(self))
    }

    pub fn load(path: &Path) -> crate::error::Result<GeometryTextureSet> {
        let bytes = std::fs::read(path)
            .map_err(|e| GeomtexError::io(format!("cannot read {}", path.display()), e))?;
        decode(&bytes).map_err(|e| GeomtexError::Format(format!("{}: {e}", path.display())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gtex::{decode_normal, encode_snorm8, NO_NORMAL};

    fn sample() -> GeometryTextureSet {
        let patch = Patch {
            origin: DVec3::new(1e6, -2.0, 0.5),
            axes: [DVec3::X, DVec3::Y, DVec3::Z],
            extent: DVec3::new(2.0, 3.0, 0.25),
            width: 2,
            height: 3,
            height_bits: 16,
            heights: vec![0, 1, 2, 65535, 7, 0],
            normals: vec![
                [0, 0],
                [12, -7],
                [-127, 0],
                [100, 27],
                [-50, -77],
                NO_NORMAL,
            ],
            colors: vec![[1, 2, 3, 255]; 6],
            faces: vec![4, 5],
            ring_faces: vec![9],
            outline: vec![127, -3, 0, 5, -127, 1],
            error_bound: None,
        };
        let mut stats = Stats::default();
        stats.set("charts", 1.0);
        stats.set("faces", 10.0);
        stats.seconds.push(("raster".into(), 0.5));
        GeometryTextureSet {
            patches: vec![patch],
            texel_size: 1.0,
            stats,
            triangles: None,
        }
    }

    /// `s` as a file holds it: everything but the stage seconds.
    fn as_filed(mut s: GeometryTextureSet) -> GeometryTextureSet {
        s.stats.seconds.clear();
        s
    }

    #[test]
    fn round_trip_is_exact() {
        let mut s = as_filed(sample());
        assert_eq!(decode(&encode(&sample())).unwrap(), s);
        // Another run's timings give the same bytes.
        let mut slower = sample();
        slower.stats.seconds[0].1 = 7.0;
        assert_eq!(encode(&slower), encode(&sample()));
        // A second patch with 8-bit heights: one byte per texel.
        let mut p8 = s.patches[0].clone();
        p8.height_bits = 8;
        p8.heights = vec![0, 1, 2, 255, 7, 0];
        s.patches.push(p8);
        let b = encode(&s);
        assert_eq!(decode(&b).unwrap(), s);
        let mut two16 = sample();
        two16.patches.push(two16.patches[0].clone());
        let patch16 = encode(&two16).len() - encode(&sample()).len();
        assert_eq!(b.len(), encode(&sample()).len() + patch16 - 6);
        // Per-patch stats travel too.
        s.stats.per_patch = vec![("patch_error".into(), vec![1e-5, 2.5e-6])];
        assert_eq!(decode(&encode(&s)).unwrap(), s);
    }

    /// A file of format `version` with `payload`.
    fn file(version: u32, payload: &[u8]) -> Vec<u8> {
        let mut out = MAGIC.to_vec();
        out.extend_from_slice(&version.to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(&crc32fast::hash(payload).to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(payload);
        out
    }

    /// The payload of a version 4 file holding `s` (written as version 4 wrote it: every patch
    /// with colors, normals as snorm8 x, y, z, 0).
    fn payload_v4(s: &GeometryTextureSet) -> Vec<u8> {
        let v5 = encode(s);
        let mut p = v5[HEADER..].to_vec();
        // Header part of the payload up to the first patch: re-encode it by slicing the v5 one.
        let patches_at = p.len() - s.patches.iter().map(patch_len_v6).sum::<usize>();
        p.truncate(patches_at);
        for patch in &s.patches {
            for v in [
                patch.origin,
                patch.axes[0],
                patch.axes[1],
                patch.axes[2],
                patch.extent,
            ] {
                put_f64s(&mut p, &v.to_array());
            }
            let counts = [patch.width, patch.height, patch.height_bits as u32];
            let faces = [patch.faces.len() as u32, patch.ring_faces.len() as u32];
            for n in counts.into_iter().chain(faces) {
                p.extend_from_slice(&n.to_le_bytes());
            }
            for f in patch.faces.iter().chain(&patch.ring_faces) {
                p.extend_from_slice(&f.to_le_bytes());
            }
            for q in &patch.heights {
                p.extend_from_slice(&q.to_le_bytes());
            }
            for &n in &patch.normals {
                p.extend_from_slice(bytemuck::cast_slice(&encode_snorm8(decode_normal(n))));
            }
            let colors = (0..patch.texels()).map(|t| patch.color(t));
            p.extend(colors.flat_map(|c| c.into_iter()));
            p.extend_from_slice(bytemuck::cast_slice(&patch.outline));
        }
        p
    }

    /// Bytes one 16-bit patch takes in a version 6 file (bound map flag and map included).
    fn patch_len_v6(p: &Patch) -> usize {
        let bound = p.error_bound.as_ref().map_or(0, |m| m.bytes());
        15 * 8 + 6 * 4 + 4 * (p.faces.len() + p.ring_faces.len()) + p.map_bytes() - bound
            + 4
            + bound
    }

    /// A bound map round-trips exactly; a version 5 file (no bound field) reads with none; a
    /// crafted flag or scale is a format error.
    #[test]
    fn error_bound_maps_round_trip_and_version_5_has_none() {
        let mut s = as_filed(sample());
        let cells: Vec<f64> = (0..12).map(|k| 1e-3 * (k as f64 + 1.0)).collect();
        s.patches[0].error_bound = Some(crate::gtex::ErrorBoundMap::with_f32_scale(2, 3, &cells));
        // A load sets the stats from the maps ("bytes" counts the map).
        s.sync_error_bound_stats();
        let bytes = encode(&s);
        assert_eq!(decode(&bytes).unwrap(), s);
        // 2 x 3 texels: 3 x 4 cells, 2 x 2 blocks: flag + scale + 4 codes.
        let without = {
            let mut n = s.clone();
            n.patches[0].error_bound = None;
            encode(&n)
        };
        assert_eq!(bytes.len(), without.len() + 4 + 4);
        // Version 5: the same payload without the (last) flag.
        let v5 = file(5, &without[HEADER..without.len() - 4]);
        let mut none = s.clone();
        none.patches[0].error_bound = None;
        none.sync_error_bound_stats();
        assert_eq!(decode(&v5).unwrap(), none);
        // A flag of 2, and a NaN scale: named format errors.
        let mut p = without[HEADER..].to_vec();
        let at = p.len() - 4;
        p[at] = 2;
        assert!(decode(&file(PATCHES_ONLY_VERSION, &p))
            .unwrap_err()
            .contains("error-bound flag"));
        let mut p = bytes[HEADER..].to_vec();
        let at = p.len() - 8;
        p[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(decode(&file(PATCHES_ONLY_VERSION, &p))
            .unwrap_err()
            .contains("error-bound scale"));
    }

    /// A map made now (an exponent byte, blocks by the patch's size) is written as version 8
    /// and read back exactly, with or without triangles; before version 8 its flag is refused.
    #[test]
    fn exponent_bound_maps_are_version_8_and_round_trip() {
        let mut s = as_filed(sample());
        let cells: Vec<f64> = (0..12).map(|k| 1e-3 * (k as f64 + 1.0)).collect();
        let map = crate::gtex::ErrorBoundMap::for_patch(&s.patches[0], &cells);
        assert_eq!(map.storage, ScaleStorage::Exponent);
        s.patches[0].error_bound = Some(map.clone());
        s.sync_error_bound_stats();
        let without = {
            let mut n = s.clone();
            n.patches[0].error_bound = None;
            encode(&n)
        };
        let bytes = encode(&s);
        assert_eq!(&bytes[8..12], &VERSION.to_le_bytes());
        assert_eq!(decode(&bytes).unwrap(), s);
        // The exponent and codes (both have the flag), and version 8's triangle flag.
        assert_eq!(bytes.len(), without.len() + 1 + map.codes.len() + 4);
        assert_eq!(s.patches[0].error_bound_bytes(), 1 + map.codes.len());
        // With triangles too.
        let mut hybrid = s.clone();
        let sphere = crate::test_shapes::uv_sphere(4, 6);
        let faces = (0..8).collect(); // within the sample's 10 source faces
        hybrid.triangles = Some(SetTriangles::from_charts(
            &sphere,
            NormalRule::default(),
            vec![(faces, KeptBecause::Bound)],
        ));
        let h = encode(&hybrid);
        assert_eq!(&h[8..12], &VERSION.to_le_bytes());
        assert_eq!(decode(&h).unwrap(), hybrid);
        // A map made in blocks other than the patch's rule is written in the rule's, each
        // stored bound kept or raised (never lowered).
        let mut odd = s.clone();
        let odd_map = crate::gtex::ErrorBoundMap::from_cells(2, 3, 4, &cells);
        odd.patches[0].error_bound = Some(odd_map.clone());
        let back = decode(&encode(&odd)).unwrap();
        let read = back.patches[0].error_bound.as_ref().unwrap();
        assert_eq!((read.block, odd_map.block), (map.block, 4));
        for j in -1..3 {
            for i in -1..2 {
                assert!(read.at_cell(2, 3, i, j) >= odd_map.at_cell(2, 3, i, j));
                assert!(read.at_cell(2, 3, i, j) >= cells[((j + 1) * 3 + i + 1) as usize]);
            }
        }
        // A zero map is its exponent byte alone, and reads back whole.
        let mut zero = s.clone();
        zero.patches[0].error_bound = Some(crate::gtex::ErrorBoundMap::for_patch(
            &zero.patches[0],
            &[0.0; 12],
        ));
        zero.sync_error_bound_stats();
        let z = encode(&zero);
        assert_eq!(decode(&z).unwrap(), zero);
        assert_eq!(z.len(), bytes.len() - map.codes.len());
        // The same payload labelled version 7: flag 2 is not read there.
        let err = decode(&file(TRIANGLES_VERSION, &h[HEADER..])).unwrap_err();
        assert!(
            err.contains("error-bound flag must be 0, 1 or (from version 8) 2, found 2"),
            "{err}"
        );
    }

    #[test]
    fn older_versions_read_with_everything_inside_the_outline() {
        let s = as_filed(sample());
        let v4 = file(4, &payload_v4(&s));
        assert!(s.stats.per_patch.is_empty());
        // Version 4 read: normals back through snorm8 (within half a degree), colors kept.
        let read4 = decode(&v4).unwrap();
        for (a, b) in read4.patches[0].normals.iter().zip(&s.patches[0].normals) {
            let cos = decode_normal(*a).dot(decode_normal(*b));
            assert!(
                *a == *b || cos > (0.75f64).to_radians().cos(),
                "{a:?} {b:?}"
            );
        }
        assert_eq!(read4.patches[0].colors, s.patches[0].colors);
        // What versions 1 to 3 hold: the same set with no outline map (everywhere inside).
        let mut old = read4.clone();
        old.patches[0].outline = vec![crate::gtex::OUTLINE_INSIDE; 6];
        // Version 3: the single patch's outline map (its last 6 bytes) is not there.
        let v3 = file(3, &v4[HEADER..v4.len() - 6]);
        assert_eq!(decode(&v3).unwrap(), old);
        // Version 1 also has no per-patch stats (an empty list: its count u32) after the seconds
        // and no height-bits field after width and height.
        // texel size, stats ("charts", "faces") and no seconds, patch count, 15 f64, w, h.
        let stats_end = HEADER + 8 + (4 + (2 + 6 + 8) + (2 + 5 + 8)) + 4;
        let at = stats_end + 4 + 4 + 15 * 8 + 2 * 4;
        let mut payload = v3[HEADER..stats_end].to_vec();
        payload.extend_from_slice(&v3[stats_end + 4..at]);
        payload.extend_from_slice(&v3[at + 4..]);
        assert_eq!(decode(&file(1, &payload)).unwrap(), old);
    }

    #[test]
    fn a_set_without_colors_stores_none() {
        let mut s = as_filed(sample());
        let colored = encode(&s).len();
        s.patches[0].colors.clear();
        let b = encode(&s);
        assert_eq!(colored - b.len(), 6 * 4);
        let back = decode(&b).unwrap();
        assert_eq!(back, s);
        assert_eq!(back.patches[0].color(3), crate::gtex::NEUTRAL_COLOR);
        // The flag is 0 or 1 only (offset: 15 f64, w, h, bits after the patch count).
        let flag = b.len() - patch_len_v6(&s.patches[0]) + 15 * 8 + 3 * 4;
        assert_eq!(&b[flag..flag + 4], &0u32.to_le_bytes());
        let mut payload = b[HEADER..].to_vec();
        payload[flag - HEADER] = 2;
        let err = decode(&file(PATCHES_ONLY_VERSION, &payload)).unwrap_err();
        assert!(
            err.contains("color-map flag must be 0 or 1, found 2"),
            "{err}"
        );
    }

    #[test]
    fn every_truncation_and_flip_is_caught() {
        let b = encode(&sample());
        for cut in 0..b.len() {
            assert!(decode(&b[..cut]).is_err(), "cut at {cut}");
        }
        for i in (HEADER..b.len()).step_by(7) {
            let mut c = b.clone();
            c[i] ^= 0x40;
            assert!(decode(&c).unwrap_err().contains("checksum"));
        }
        let mut v = b.clone();
        v[8] = 9;
        assert!(decode(&v).unwrap_err().contains("version 9"));
    }

    #[test]
    fn a_file_with_a_valid_checksum_but_a_zero_axis_is_a_format_error() {
        let mut s = sample();
        s.patches.push(s.patches[0].clone());
        s.patches[1].axes[1] = DVec3::ZERO;
        let bytes = encode(&s);
        let e = decode(&bytes).unwrap_err();
        assert_eq!(e, "patch 1: axis 1 is not unit length (|a| = 0)");
        let path =
            std::env::temp_dir().join(format!("geomtex-zero-axis-{}.gtex", std::process::id()));
        std::fs::write(&path, &bytes).unwrap();
        let e = GeometryTextureSet::load(&path).unwrap_err();
        std::fs::remove_file(&path).unwrap();
        assert!(
            matches!(&e, crate::error::GeomtexError::Format(m) if m.ends_with("patch 1: axis 1 is not unit length (|a| = 0)")),
            "{e}"
        );
    }
}
