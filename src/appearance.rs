//! Where a mesh's base color comes from — vertex colors, face colors, or a texture image read
//! through texture coordinates — and the one function that gives the color at a face's
//! barycentric point whatever the source (`Mesh::face_color(..).at(..)`).
//!
//! Spaces: texture coordinates (u, v) have (0, 0) at the image's bottom-left corner and (1, 1) at
//! its top-right (OBJ's convention, which trimesh also gives glTF's UVs in), repeating outside
//! [0, 1]. Images are RGBA8, row-major with row 0 at the top; pixel (i, j) of a level is centred
//! at (i + 0.5, j + 0.5) in that level's pixel units.

use std::sync::Arc;

use glam::{DMat2, DVec2};

use crate::error::{GeomtexError, Result};

/// Texture coordinates, one pair per vertex or one per face corner (seams without splitting
/// vertices).
#[derive(Clone, Debug)]
pub enum TextureCoords {
    PerVertex(Vec<DVec2>),
    PerCorner(Vec<[DVec2; 3]>),
}

/// One level of an image's mip chain.
#[derive(Clone, Debug)]
struct Level {
    width: usize,
    height: usize,
    pixels: Vec<[u8; 4]>,
}

impl Level {
    fn texel(&self, i: i64, j: i64) -> [f64; 4] {
        let i = i.rem_euclid(self.width as i64) as usize;
        let j = j.rem_euclid(self.height as i64) as usize;
        self.pixels[j * self.width + i].map(f64::from)
    }

    /// Bilinear sample at (u, v), repeating.
    fn bilinear(&self, uv: DVec2) -> [f64; 4] {
        let x = uv.x * self.width as f64 - 0.5;
        let y = (1.0 - uv.y) * self.height as f64 - 0.5;
        let (i, j) = (x.floor(), y.floor());
        let (fx, fy) = (x - i, y - j);
        let (i, j) = (i as i64, j as i64);
        let [a, b, c, d] = [
            self.texel(i, j),
            self.texel(i + 1, j),
            self.texel(i, j + 1),
            self.texel(i + 1, j + 1),
        ];
        std::array::from_fn(|k| {
            (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy
        })
    }

    /// The next level: each pixel the mean of the 2 x 2 block above it (the last row or column
    /// of an odd size repeated).
    fn halved(&self) -> Level {
        let (w, h) = (self.width.div_ceil(2), self.height.div_ceil(2));
        let mut pixels = Vec::with_capacity(w * h);
        for j in 0..h {
            for i in 0..w {
                let mut sum = [0u32; 4];
                for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let si = (2 * i + di).min(self.width - 1);
                    let sj = (2 * j + dj).min(self.height - 1);
                    for (s, v) in sum.iter_mut().zip(self.pixels[sj * self.width + si]) {
                        *s += u32::from(v);
                    }
                }
                pixels.push(sum.map(|s| ((s + 2) / 4) as u8));
            }
        }
        Level {
            width: w,
            height: h,
            pixels,
        }
    }
}

/// An RGBA8 image with its mip chain, built once when the mesh is made.
#[derive(Clone, Debug)]
pub struct Image {
    levels: Vec<Level>,
}

impl Image {
    /// From row-major RGBA8 pixels (row 0 at the top).
    pub fn new(width: usize, height: usize, pixels: &[u8]) -> Result<Image> {
        if width == 0 || height == 0 {
            return Err(GeomtexError::Mesh(format!(
                "the texture image is empty ({width} x {height} pixels)"
            )));
        }
        if pixels.len() != width * height * 4 {
            return Err(GeomtexError::Mesh(format!(
                "the texture image holds {} values; expected {} (RGBA for {width} x {height} pixels)",
                pixels.len(),
                width * height * 4
            )));
        }
        let mut levels = vec![Level {
            width,
            height,
            pixels: pixels
                .chunks_exact(4)
                .map(|q| [q[0], q[1], q[2], q[3]])
                .collect(),
        }];
        while levels.last().is_some_and(|l| l.width > 1 || l.height > 1) {
            let next = levels[levels.len() - 1].halved();
            levels.push(next);
        }
        Ok(Image { levels })
    }

    pub fn width(&self) -> usize {
        self.levels[0].width
    }

    pub fn height(&self) -> usize {
        self.levels[0].height
    }

    /// Row-major RGBA8 pixels of the full-size image.
    pub fn pixels(&self) -> &[[u8; 4]] {
        &self.levels[0].pixels
    }

    /// The mip chain, full size first: each level's width, height and row-major pixels.
    pub fn levels(&self) -> impl Iterator<Item = (usize, usize, &[[u8; 4]])> {
        (self.levels.iter()).map(|l| (l.width, l.height, l.pixels.as_slice()))
    }

    /// The color at (u, v) averaged over a footprint `footprint` full-size pixels wide:
    /// bilinear up to one pixel, blended between the two mip levels around it beyond.
    pub fn sample(&self, uv: DVec2, footprint: f64) -> [f64; 4] {
        let top = (self.levels.len() - 1) as f64;
        let lod = footprint.max(1.0).log2().min(top);
        let lower = lod.floor();
        let a = self.levels[lower as usize].bilinear(uv);
        let t = lod - lower;
        if t == 0.0 {
            return a;
        }
        let b = self.levels[lower as usize + 1].bilinear(uv);
        std::array::from_fn(|k| a[k] * (1.0 - t) + b[k] * t)
    }
}

/// Texture coordinates and the image they read.
#[derive(Clone, Debug)]
pub struct Texture {
    pub coords: TextureCoords,
    pub image: Arc<Image>,
}

/// The color sources a mesh carries besides its vertex colors (`Mesh::colors`). When several
/// are present the texture wins, then face colors, then vertex colors.
#[derive(Clone, Debug, Default)]
pub struct Appearance {
    /// RGBA8 per face.
    pub face_colors: Option<Vec<[u8; 4]>>,
    pub texture: Option<Texture>,
}

impl Appearance {
    /// Per-corner texture coordinates follow faces whose winding `Mesh::rewound` flips.
    pub fn rewound(&self, flips: &[bool]) -> Appearance {
        let mut out = self.clone();
        if let Some(Texture {
            coords: TextureCoords::PerCorner(uv),
            ..
        }) = &mut out.texture
        {
            for (corners, _) in uv.iter_mut().zip(flips).filter(|(_, &flip)| flip) {
                corners.swap(1, 2);
            }
        }
        out
    }
}

/// Texture coordinates and image as flat arrays, before validation.
pub struct TextureInput<'a> {
    /// N*2 per vertex, or M*6 per face corner.
    pub coords: &'a [f64],
    pub per_corner: bool,
    pub width: usize,
    pub height: usize,
    /// Row-major RGBA8, row 0 at the top.
    pub pixels: &'a [u8],
}

/// What gives one face's points their base color: made once per face drawn.
pub enum FaceColor<'a> {
    Uniform([u8; 4]),
    /// Interpolated vertex colors.
    Corners([[u8; 4]; 3]),
    Texture {
        image: &'a Image,
        uv: [DVec2; 3],
        /// Full-size texture pixels per unit of the grid the face is drawn on.
        footprint: f64,
    },
}

impl FaceColor<'_> {
    /// The RGBA8 color at barycentric coordinates `l`.
    pub fn at(&self, l: [f64; 3]) -> [u8; 4] {
        let rgba = match self {
            FaceColor::Uniform(c) => return *c,
            FaceColor::Corners(cs) => {
                std::array::from_fn(|k| (0..3).map(|v| l[v] * f64::from(cs[v][k])).sum::<f64>())
            }
            FaceColor::Texture {
                image,
                uv,
                footprint,
            } => image.sample(uv[0] * l[0] + uv[1] * l[1] + uv[2] * l[2], *footprint),
        };
        rgba.map(|v| v.round().clamp(0.0, 255.0) as u8)
    }
}

/// How many full-size texture pixels one unit step of the drawing grid crosses on a face whose
/// corners sit at `grid` (grid units) and `uv`: the longer of the two columns of
/// d(pixels)/d(grid). Zero for a face with no area on the grid.
pub(crate) fn footprint(grid: [DVec2; 3], uv: [DVec2; 3], image: &Image) -> f64 {
    let pixels = DVec2::new(image.width() as f64, image.height() as f64);
    let grid_edges = DMat2::from_cols(grid[1] - grid[0], grid[2] - grid[0]);
    if grid_edges.determinant().abs() < 1e-300 {
        return 0.0;
    }
    let pixel_edges = DMat2::from_cols((uv[1] - uv[0]) * pixels, (uv[2] - uv[0]) * pixels);
    let pixels_from_grid = pixel_edges * grid_edges.inverse();
    pixels_from_grid
        .x_axis
        .length()
        .max(pixels_from_grid.y_axis.length())
}

/// Checks and gathers the texture coordinates: the right count, all finite.
pub(crate) fn texture_coords(
    t: &TextureInput<'_>,
    n_vertices: usize,
    n_faces: usize,
) -> Result<TextureCoords> {
    let (count, unit) = if t.per_corner {
        (n_faces * 6, "face corner")
    } else {
        (n_vertices * 2, "vertex")
    };
    if t.coords.len() != count {
        let what = if t.per_corner { "faces" } else { "vertices" };
        let n = if t.per_corner { n_faces } else { n_vertices };
        return Err(GeomtexError::Mesh(format!(
            "texture coordinates hold {} values; expected {count} (u, v for each {unit} of {n} {what})",
            t.coords.len()
        )));
    }
    if let Some(k) = t.coords.iter().position(|c| !c.is_finite()) {
        let place = if t.per_corner {
            format!("face {} corner {}", k / 6, (k % 6) / 2)
        } else {
            format!("vertex {}", k / 2)
        };
        return Err(GeomtexError::Mesh(format!(
            "texture coordinate {} of {place} is not finite ({})",
            ["u", "v"][k % 2],
            t.coords[k]
        )));
    }
    let pairs: Vec<DVec2> = t
        .coords
        .chunks_exact(2)
        .map(|p| DVec2::new(p[0], p[1]))
        .collect();
    Ok(if t.per_corner {
        TextureCoords::PerCorner(pairs.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    } else {
        TextureCoords::PerVertex(pairs)
    })
}
