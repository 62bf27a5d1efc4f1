//! A generalized displacement map's data (Wang et al. 2004): a mesostructure tile (volume.rs),
//! the prisms of a shell over a base mesh (shell.rs), and a shell ready to render with its
//! optional compressed distance table. `gdm` computes the distance tables and the explicit
//! reference geometry from them; the renderer draws a `GdmShell`.
//!
//! Spaces: texture space in voxel units of the tile (volume.rs); the base mesh's object space.

pub mod shell;
pub mod volume;

pub use shell::Shell;
pub use volume::{Pattern, Volume, PATTERNS};

use std::sync::Arc;

/// A shell ready to render: the prisms over a base mesh and the tile they carry, drawn in
/// `color` (RGBA).
pub struct GdmShell {
    pub shell: Shell,
    pub volume: Arc<Volume>,
    pub color: [u8; 4],
    /// Straight pieces each prism's ray is cut into in texture space (each piece's ends mapped
    /// exactly), so the march follows the prism's curved map.
    pub pieces: u32,
    /// When set, the paper's lookup in the SVD-compressed distance function replaces the exact
    /// march.
    pub lookup: Option<CompressedTable>,
    /// Diagnostics: the normal target holds (lookups, march steps, field samples) of the fragment that wrote
    /// each pixel instead of its normal.
    pub count_steps: bool,
}

/// A distance function as k SVD terms: d = sum_i W_i(x, y, phi) E_i(theta, z).
pub struct CompressedTable {
    /// [theta, phi] direction counts.
    pub directions: [usize; 2],
    pub k: usize,
    /// W[((x * ny + y) * n_phi + phi) * k + i].
    pub weights: Vec<f32>,
    /// E[(i * n_theta + theta) * nz + z].
    pub eigen: Vec<f32>,
    /// Half-width in voxels of the exact search around the distance looked up; 0: the paper's
    /// lookup alone (its distance kept where the field confirms solid there).
    pub refine: f32,
    /// The terms hold a conservative table (bound.rs, its SVD error subtracted): the renderer
    /// steps by it and finishes with the exact march instead of trusting one lookup.
    pub bound: bool,
}

/// Default pieces per prism.
pub const DEFAULT_PIECES: u32 = 4;

impl GdmShell {
    /// A tile voxel's longer edge in object units: the shell's thickness over the tile's layers,
    /// or a voxel's extent along the base surface (the median over faces of the square root of
    /// a face's area over its area in texture voxels).
    pub fn voxel_size(&self) -> f64 {
        let s = &self.shell;
        let vertical = s.thickness / s.size[2].max(1) as f64;
        let [nx, ny] = [s.size[0] as f64, s.size[1] as f64];
        let mut along: Vec<f64> = (s.faces.iter().zip(&s.uv))
            .map(|(f, uv)| {
                let [a, b, c] = f.map(|k| s.positions[k as usize]);
                let area = 0.5 * (b - a).cross(c - a).length();
                let [p, q, r] = uv.map(|t| glam::DVec2::new(t.x * nx, t.y * ny));
                let texels = 0.5 * (q - p).perp_dot(r - p).abs();
                if texels > 0.0 {
                    (area / texels).sqrt()
                } else {
                    0.0
                }
            })
            .collect();
        // The median: a sliver of texture space (a seam of a generated layout) would blow the
        // largest up.
        along.sort_by(f64::total_cmp);
        vertical.max(along.get(along.len() / 2).copied().unwrap_or(0.0))
    }
}
