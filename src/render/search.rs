//! How a ray finds its first hit in a height map: the method, its settings, the quality presets
//! and the per-call overrides on top of them.
//!
//! Spaces: none; step counts are in texels of patch-local space.

use std::str::FromStr;

use crate::error::{parse_choice, GeomtexError, Result};

/// How a ray finds its first hit in a height map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The paper's search: a linear march balanced by slant, then bisection.
    LinearBinary,
    /// Exact: descend a max pyramid, skip what the ray passes above, solve each cell in closed
    /// form.
    MaxMip,
}

impl Method {
    pub fn as_str(&self) -> &'static str {
        match self {
            Method::LinearBinary => "linear_binary",
            Method::MaxMip => "maxmip",
        }
    }
}

impl FromStr for Method {
    type Err = GeomtexError;

    fn from_str(s: &str) -> Result<Method> {
        let choices = [
            ("linear_binary", Method::LinearBinary),
            ("maxmip", Method::MaxMip),
        ];
        parse_choice("method", s, &choices)
    }
}

/// How a frame's camera rays meet a texture set's boxes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Primary {
    /// Per pixel, the boxes of its screen tile nearest first, stopping at the first box behind
    /// the nearest hit (kinds/gtex/tiles.rs).
    #[default]
    Tiles,
    /// Every box drawn, each fragment searching its box (overdraw multiplies the searches).
    Boxes,
}

impl Primary {
    pub fn as_str(&self) -> &'static str {
        match self {
            Primary::Tiles => "tiles",
            Primary::Boxes => "boxes",
        }
    }
}

impl FromStr for Primary {
    type Err = GeomtexError;

    fn from_str(s: &str) -> Result<Primary> {
        parse_choice(
            "primary",
            s,
            &[("tiles", Primary::Tiles), ("boxes", Primary::Boxes)],
        )
    }
}

/// Measured settings for a speed/accuracy trade (see `SearchOptions::preset`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Quality {
    Fast,
    Balanced,
    /// The default: with tiled frames it took 0.62–0.70× the CPU time of Balanced on the bunny's
    /// five headline views, and it is exact on rough surfaces where Balanced steps over spikes.
    #[default]
    Exact,
}

impl FromStr for Quality {
    type Err = GeomtexError;

    fn from_str(s: &str) -> Result<Quality> {
        let choices = [
            ("fast", Quality::Fast),
            ("balanced", Quality::Balanced),
            ("exact", Quality::Exact),
        ];
        parse_choice("quality", s, &choices)
    }
}

/// Search settings of a render.
#[derive(Clone, Copy, Debug)]
pub struct SearchOptions {
    pub method: Method,
    /// Linear samples per texel the ray crosses in the patch (the balance by slant).
    pub steps_per_texel: f32,
    pub min_linear_steps: u32,
    pub max_linear_steps: u32,
    pub binary_steps: u32,
    /// Most node visits of the max-pyramid traversal per fragment.
    pub max_traversal_steps: u32,
    /// Count height-map fetches per fragment (a slower counting build of the pipeline).
    pub count_fetches: bool,
    /// Level of detail (max-pyramid search only): each patch's traversal stops at the pyramid
    /// level whose nodes are about one pixel at the patch's nearest point, and hits the node's
    /// mid height there instead of descending to the exact bilinear cell.
    pub lod: bool,
    /// Surfels: each tile's coarsest level whose perpendicular error projects to at most this
    /// many pixels.
    pub max_pixel_error: f32,
    /// With `lod`, when the caller gave `max_pixel_error`: each patch's stop level is its
    /// coarsest whose error bound (kinds/gtex/lod.rs) projects to at most this many pixels at
    /// its nearest point; None: the level whose nodes are about a pixel wide.
    pub lod_bound_pixels: Option<f32>,
    /// How frames meet texture sets' boxes.
    pub primary: Primary,
}

impl Default for SearchOptions {
    fn default() -> Self {
        SearchOptions {
            method: Method::LinearBinary,
            steps_per_texel: 0.5,
            min_linear_steps: 2,
            max_linear_steps: 1024,
            binary_steps: 8,
            max_traversal_steps: 4096,
            count_fetches: false,
            lod: false,
            max_pixel_error: 1.0,
            lod_bound_pixels: None,
            primary: Primary::Tiles,
        }
    }
}

impl SearchOptions {
    /// The settings a quality stands for.
    pub fn preset(quality: Quality) -> SearchOptions {
        match quality {
            Quality::Fast => SearchOptions {
                steps_per_texel: 0.25,
                binary_steps: 6,
                ..Default::default()
            },
            Quality::Balanced => SearchOptions::default(),
            Quality::Exact => SearchOptions {
                method: Method::MaxMip,
                ..Default::default()
            },
        }
    }

    pub fn validate(&self) -> Result<()> {
        let ok = self.steps_per_texel.is_finite()
            && self.steps_per_texel > 0.0
            && self.min_linear_steps >= 1
            && self.max_linear_steps >= self.min_linear_steps
            && self.max_linear_steps <= 65536
            && self.binary_steps <= 64
            && (1..=1 << 20).contains(&self.max_traversal_steps);
        if self.lod && self.method != Method::MaxMip {
            return Err(GeomtexError::Parameter(
                "lod needs the max-pyramid search (method='maxmip' or quality='exact')".into(),
            ));
        }
        if !(self.max_pixel_error.is_finite() && self.max_pixel_error > 0.0) {
            return Err(GeomtexError::Parameter(format!(
                "max_pixel_error must be a positive number of pixels, got {}",
                self.max_pixel_error
            )));
        }
        if ok {
            Ok(())
        } else {
            Err(GeomtexError::Parameter(format!(
                "search options out of range: {self:?} (need steps_per_texel > 0, \
                 1 <= min_linear_steps <= max_linear_steps <= 65536, binary_steps <= 64, \
                 1 <= max_traversal_steps <= 2^20)"
            )))
        }
    }
}

/// A caller's choices: a quality preset (Exact when none) and any settings that override it.
#[derive(Clone, Copy, Debug, Default)]
pub struct SearchOverrides {
    pub quality: Option<Quality>,
    pub method: Option<Method>,
    pub steps_per_texel: Option<f32>,
    pub min_linear_steps: Option<u32>,
    pub max_linear_steps: Option<u32>,
    pub binary_steps: Option<u32>,
    pub max_traversal_steps: Option<u32>,
    pub count_fetches: Option<bool>,
    pub lod: Option<bool>,
    pub max_pixel_error: Option<f32>,
    pub primary: Option<Primary>,
}

impl SearchOverrides {
    /// The preset of the quality, then each given override, validated.
    pub fn resolve(&self) -> Result<SearchOptions> {
        let preset = SearchOptions::preset(self.quality.unwrap_or_default());
        let lod = self.lod.unwrap_or(preset.lod);
        let max_pixel_error = self.max_pixel_error.unwrap_or(preset.max_pixel_error);
        let options = SearchOptions {
            method: self.method.unwrap_or(preset.method),
            steps_per_texel: self.steps_per_texel.unwrap_or(preset.steps_per_texel),
            min_linear_steps: self.min_linear_steps.unwrap_or(preset.min_linear_steps),
            max_linear_steps: self.max_linear_steps.unwrap_or(preset.max_linear_steps),
            binary_steps: self.binary_steps.unwrap_or(preset.binary_steps),
            max_traversal_steps: self
                .max_traversal_steps
                .unwrap_or(preset.max_traversal_steps),
            count_fetches: self.count_fetches.unwrap_or(preset.count_fetches),
            lod,
            max_pixel_error,
            lod_bound_pixels: (lod && self.max_pixel_error.is_some()).then_some(max_pixel_error),
            primary: self.primary.unwrap_or(preset.primary),
        };
        options.validate()?;
        Ok(options)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back_and_bad_names_say_what_is_allowed() {
        for m in [Method::LinearBinary, Method::MaxMip] {
            assert_eq!(m.as_str().parse::<Method>().unwrap(), m);
        }
        assert_eq!("exact".parse::<Quality>().unwrap(), Quality::Exact);
        let e = "best".parse::<Quality>().unwrap_err().to_string();
        assert_eq!(
            e,
            "quality must be 'fast', 'balanced' or 'exact', got \"best\""
        );
        let e = "bvh".parse::<Method>().unwrap_err().to_string();
        assert_eq!(e, "method must be 'linear_binary' or 'maxmip', got \"bvh\"");
    }

    #[test]
    fn overrides_apply_on_top_of_the_preset() {
        let fast = SearchOverrides {
            quality: Some(Quality::Fast),
            binary_steps: Some(3),
            ..Default::default()
        }
        .resolve()
        .unwrap();
        assert_eq!((fast.steps_per_texel, fast.binary_steps), (0.25, 3));
        let plain = SearchOverrides::default().resolve().unwrap();
        assert_eq!(plain.method, Method::MaxMip);
        let lod_without_maxmip = SearchOverrides {
            quality: Some(Quality::Balanced),
            lod: Some(true),
            ..Default::default()
        };
        assert!(lod_without_maxmip.resolve().is_err());
        let by_bound = SearchOverrides {
            lod: Some(true),
            max_pixel_error: Some(0.5),
            ..Default::default()
        };
        assert_eq!(by_bound.resolve().unwrap().lod_bound_pixels, Some(0.5));
        let by_pixel = SearchOverrides {
            lod: Some(true),
            ..Default::default()
        };
        assert_eq!(by_pixel.resolve().unwrap().lod_bound_pixels, None);
    }
}
