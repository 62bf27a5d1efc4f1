//! What every set must satisfy before anything draws or measures it: the checks a loaded .gtex
//! file goes through after its checksum (a valid checksum only says the bytes are the ones
//! written, not that the writer was sane), and that sets built in memory go through too, so the
//! renderer never sees an impossible set. Messages name the patch and the field.
//!
//! Space: world (frames), patch-local (maps).

use glam::DVec3;

use super::{GeometryTextureSet, Patch, HEIGHT_BITS};

/// Longest side of a patch in texels: the renderer's atlas layers are 4096 x 4096.
pub const MAX_PATCH_SIDE: u32 = 4096;

/// How far from unit length and from orthogonal a patch's axes may be. Frames are built and stored
/// in f64, so real sets sit near 1e-15; 1e-6 leaves room for files written by other tools in f32.
pub const AXIS_TOLERANCE: f64 = 1e-6;

/// Width and height of a patch: 1 to `MAX_PATCH_SIDE` each. Checked before its maps are read, so
/// a corrupt size cannot ask for gigabytes.
pub fn check_size(width: u32, height: u32) -> Result<(), String> {
    for (name, n) in [("width", width), ("height", height)] {
        if !(1..=MAX_PATCH_SIDE).contains(&n) {
            return Err(format!(
                "{name} is {n} texels; a patch has 1 to {MAX_PATCH_SIDE}"
            ));
        }
    }
    Ok(())
}

fn finite(v: DVec3) -> bool {
    v.is_finite()
}

/// Origin, axes (orthonormal, right-handed, within `AXIS_TOLERANCE`) and extents (positive).
fn check_frame(p: &Patch) -> Result<(), String> {
    if !finite(p.origin) {
        return Err(format!("origin is not finite ({})", p.origin));
    }
    for (i, a) in p.axes.iter().enumerate() {
        if !finite(*a) || (a.length() - 1.0).abs() > AXIS_TOLERANCE {
            return Err(format!(
                "axis {i} is not unit length (|a| = {})",
                a.length()
            ));
        }
    }
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        let c = p.axes[i].dot(p.axes[j]);
        if c.abs() > AXIS_TOLERANCE {
            return Err(format!("axes {i} and {j} are not orthogonal (dot = {c:e})"));
        }
    }
    if p.axes[0].cross(p.axes[1]).dot(p.axes[2]) < 0.0 {
        return Err("axes are left-handed (x × y points away from z)".into());
    }
    for (i, e) in p.extent.to_array().into_iter().enumerate() {
        if !(e.is_finite() && e > 0.0) {
            return Err(format!("extent {i} must be positive and finite, got {e}"));
        }
    }
    Ok(())
}

/// Map lengths and height codes within the patch's bit depth.
fn check_maps(p: &Patch) -> Result<(), String> {
    check_size(p.width, p.height)?;
    if !HEIGHT_BITS.contains(&p.height_bits) {
        return Err(format!(
            "height bits must be 8 or 16, found {}",
            p.height_bits
        ));
    }
    let texels = p.texels();
    for (name, len) in [
        ("heights", p.heights.len()),
        ("normals", p.normals.len()),
        ("colors", p.colors.len()),
        ("outline", p.outline.len()),
    ] {
        // No color map at all is fine (the mesh had no colors); a partial one is not.
        if len != texels && !(name == "colors" && len == 0) {
            return Err(format!(
                "{name} hold {len} texels, the {}x{} map needs {texels}",
                p.width, p.height
            ));
        }
    }
    // -128 only as both bytes of NO_NORMAL: encode_normal writes -127..=127.
    let odd = |n: &[i8; 2]| (n[0] == i8::MIN || n[1] == i8::MIN) && *n != super::NO_NORMAL;
    if let Some(t) = p.normals.iter().position(odd) {
        return Err(format!(
            "normal code {:?} at texel {t} is not octahedral (-128 only in [-128, -128], no normal)",
            p.normals[t]
        ));
    }
    let code_max = p.code_max();
    if let Some(t) = p.heights.iter().position(|&q| q > code_max) {
        return Err(format!(
            "height code {} at texel {t} exceeds {code_max}, the largest {}-bit code",
            p.heights[t], p.height_bits
        ));
    }
    Ok(())
}

/// Face ids below the source mesh's face count (the "faces" stat), which a set listing faces
/// must carry.
fn check_faces(p: &Patch, faces: Option<f64>) -> Result<(), String> {
    let Some(&largest) = p.faces.iter().chain(&p.ring_faces).max() else {
        return Ok(());
    };
    match faces {
        Some(n) if (largest as f64) < n => Ok(()),
        Some(n) => Err(format!(
            "face id {largest} is past the source mesh's {n} faces"
        )),
        None => Err(format!(
            "lists face ids (up to {largest}) but the set has no 'faces' count"
        )),
    }
}

impl GeometryTextureSet {
    /// Every check above, plus the set's own fields: a positive texel size, a whole "faces"
    /// count if any, and one value per patch in every per-patch stat.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.texel_size.is_finite() && self.texel_size > 0.0) {
            return Err(format!(
                "texel size must be positive and finite, got {}",
                self.texel_size
            ));
        }
        let faces = self.stats.get("faces");
        if let Some(n) = faces {
            if !(n >= 0.0 && n.fract() == 0.0 && n <= u32::MAX as f64 + 1.0) {
                return Err(format!("the 'faces' stat is not a face count: {n}"));
            }
        }
        for (name, values) in &self.stats.per_patch {
            if values.len() != self.patches.len() {
                return Err(format!(
                    "per-patch stat '{name}' has {} values for {} patches",
                    values.len(),
                    self.patches.len()
                ));
            }
        }
        for (k, p) in self.patches.iter().enumerate() {
            check_frame(p)
                .and_then(|()| check_maps(p))
                .and_then(|()| check_faces(p, faces))
                .map_err(|e| format!("patch {k}: {e}"))?;
        }
        let Some(t) = &self.triangles else {
            return Ok(());
        };
        t.validate()?;
        match (t.source_faces.iter().max(), faces) {
            (Some(&f), Some(n)) if f as f64 >= n => Err(format!(
                "triangles: source face id {f} is past the source mesh's {n} faces"
            )),
            (Some(_), None) => {
                Err("triangles list face ids but the set has no 'faces' count".into())
            }
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gtex::{Stats, NO_NORMAL};

    fn set() -> GeometryTextureSet {
        let patch = Patch {
            origin: DVec3::new(1.0, 2.0, 3.0),
            axes: [DVec3::X, DVec3::Y, DVec3::Z],
            extent: DVec3::new(2.0, 3.0, 0.25),
            width: 2,
            height: 2,
            height_bits: 8,
            heights: vec![0, 1, 254, 255],
            normals: vec![[0, 0], [5, -9], NO_NORMAL, [127, 0]],
            colors: vec![[1, 2, 3, 255]; 4],
            faces: vec![0, 1],
            ring_faces: vec![2],
            outline: vec![127, 0, -5, 127],
            error_bound: None,
        };
        let mut stats = Stats::default();
        stats.set("faces", 3.0);
        GeometryTextureSet {
            patches: vec![patch.clone(), patch],
            texel_size: 1.0,
            stats,
            triangles: None,
        }
    }

    type Change = Box<dyn FnOnce(&mut GeometryTextureSet)>;

    /// The message `change` to the second patch (or the set) gives.
    fn error(change: impl FnOnce(&mut GeometryTextureSet)) -> String {
        let mut s = set();
        change(&mut s);
        s.validate().unwrap_err()
    }

    #[test]
    fn each_impossible_field_is_named() {
        assert_eq!(set().validate(), Ok(()));
        let cases: Vec<(Change, &str)> = vec![
            (
                Box::new(|s| s.patches[1].axes[1] = DVec3::ZERO),
                "patch 1: axis 1 is not unit length (|a| = 0)",
            ),
            (
                Box::new(|s| s.patches[1].origin.y = f64::NAN),
                "patch 1: origin is not finite",
            ),
            (
                Box::new(|s| s.patches[1].axes[0] = DVec3::new(1.0, 1e-5, 0.0).normalize()),
                "patch 1: axes 0 and 1 are not orthogonal",
            ),
            (
                Box::new(|s| s.patches[1].axes[2] = -DVec3::Z),
                "patch 1: axes are left-handed",
            ),
            (
                Box::new(|s| s.patches[1].extent.z = 0.0),
                "patch 1: extent 2 must be positive and finite, got 0",
            ),
            (
                Box::new(|s| s.patches[1].width = 0),
                "patch 1: width is 0 texels",
            ),
            (
                Box::new(|s| s.patches[1].height = 4097),
                "patch 1: height is 4097 texels; a patch has 1 to 4096",
            ),
            (
                Box::new(|s| s.patches[1].normals.pop().map(drop).unwrap()),
                "patch 1: normals hold 3 texels, the 2x2 map needs 4",
            ),
            (
                Box::new(|s| s.patches[1].colors.pop().map(drop).unwrap()),
                "patch 1: colors hold 3 texels, the 2x2 map needs 4",
            ),
            (
                Box::new(|s| s.patches[1].normals[3] = [-128, 4]),
                "patch 1: normal code [-128, 4] at texel 3 is not octahedral",
            ),
            (
                Box::new(|s| s.patches[1].outline.push(0)),
                "patch 1: outline hold 5 texels, the 2x2 map needs 4",
            ),
            (
                Box::new(|s| s.patches[1].heights[2] = 256),
                "patch 1: height code 256 at texel 2 exceeds 255",
            ),
            (
                Box::new(|s| s.patches[1].height_bits = 12),
                "patch 1: height bits must be 8 or 16",
            ),
            (
                Box::new(|s| s.patches[1].ring_faces[0] = 3),
                "patch 1: face id 3 is past the source mesh's 3 faces",
            ),
            (
                Box::new(|s| s.stats = Stats::default()),
                "patch 0: lists face ids (up to 2) but the set has no 'faces' count",
            ),
            (
                Box::new(|s| s.stats.set("faces", 1e300)),
                "the 'faces' stat is not a face count",
            ),
            (
                Box::new(|s| s.stats.per_patch = vec![("e".into(), vec![1.0])]),
                "per-patch stat 'e' has 1 values for 2 patches",
            ),
            (
                Box::new(|s| s.texel_size = f64::INFINITY),
                "texel size must be positive and finite, got inf",
            ),
        ];
        for (change, expected) in cases {
            let e = error(change);
            assert!(
                e.starts_with(expected),
                "{e:?} should start with {expected:?}"
            );
        }
    }
}
