//! Which per-pixel outputs a frame reads back or computes (`render(..., outputs=...)`).
//!
//! Spaces: none.

use crate::error::{GeomtexError, Result};

/// The per-pixel outputs of a frame: every target is drawn, but only the targets named here are
/// copied off the adapter and converted (on lavapipe the copies and conversions are a large share
/// of a small frame's time). `error_bound` and `coverage_uncertain` are computed on the CPU after
/// read-back (error_bound.rs, coverage.rs), from the depth and patch ids (read for them even when
/// not asked for).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Outputs {
    pub color: bool,
    pub albedo: bool,
    pub depth: bool,
    pub normal: bool,
    pub patch_id: bool,
    pub error_bound: bool,
    pub coverage_uncertain: bool,
}

impl Outputs {
    pub const ALL: Outputs = Outputs {
        color: true,
        albedo: true,
        depth: true,
        normal: true,
        patch_id: true,
        error_bound: true,
        coverage_uncertain: true,
    };
    /// What a render reads back unless told otherwise: all but `coverage_uncertain`, whose probe
    /// rays cost a ray query per frame (see render::coverage).
    pub const DEFAULT: Outputs = Outputs {
        coverage_uncertain: false,
        ..Outputs::ALL
    };
    pub const NONE: Outputs = Outputs {
        color: false,
        albedo: false,
        depth: false,
        normal: false,
        patch_id: false,
        error_bound: false,
        coverage_uncertain: false,
    };
    /// Every output's name, in the order `names` lists them.
    pub const NAMES: [&'static str; 7] = [
        "color",
        "albedo",
        "depth",
        "normal",
        "patch_id",
        "error_bound",
        "coverage_uncertain",
    ];

    fn flags_mut(&mut self) -> [&mut bool; 7] {
        [
            &mut self.color,
            &mut self.albedo,
            &mut self.depth,
            &mut self.normal,
            &mut self.patch_id,
            &mut self.error_bound,
            &mut self.coverage_uncertain,
        ]
    }

    fn flags(&self) -> [bool; 7] {
        [
            self.color,
            self.albedo,
            self.depth,
            self.normal,
            self.patch_id,
            self.error_bound,
            self.coverage_uncertain,
        ]
    }

    /// The outputs named (at least one; each of `NAMES`).
    pub fn parse<S: AsRef<str>>(names: &[S]) -> Result<Outputs> {
        let mut outputs = Outputs::NONE;
        for name in names {
            let name = name.as_ref();
            let k = Self::NAMES.iter().position(|n| *n == name).ok_or_else(|| {
                GeomtexError::Parameter(format!(
                    "unknown output {name:?}; outputs are {}",
                    Self::NAMES.join(", ")
                ))
            })?;
            *outputs.flags_mut()[k] = true;
        }
        if outputs == Outputs::NONE {
            return Err(GeomtexError::Parameter(format!(
                "outputs must name at least one of {}",
                Self::NAMES.join(", ")
            )));
        }
        Ok(outputs)
    }

    /// The names of the outputs held, in `NAMES` order.
    pub fn names(&self) -> Vec<&'static str> {
        (Self::NAMES.iter().zip(self.flags()))
            .filter_map(|(n, on)| on.then_some(*n))
            .collect()
    }

    /// Both sets of outputs.
    pub fn union(self, other: Outputs) -> Outputs {
        let (a, b) = (self.flags(), other.flags());
        let mut out = Outputs::NONE;
        for (k, flag) in out.flags_mut().into_iter().enumerate() {
            *flag = a[k] || b[k];
        }
        out
    }

    /// Whether any output computed after read-back (error bounds, coverage) is asked for.
    pub fn needs_bounds(&self) -> bool {
        self.error_bound || self.coverage_uncertain
    }

    /// What to read back for these outputs: the depth and patch ids too where the outputs
    /// computed from them are asked for.
    pub fn to_read(self) -> Outputs {
        if self.needs_bounds() {
            self.union(Outputs {
                depth: true,
                patch_id: true,
                ..Outputs::NONE
            })
        } else {
            self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_parse_by_name_and_refuse_the_unknown() {
        let o = Outputs::parse(&["normal", "depth"]).unwrap();
        assert_eq!(o.names(), ["depth", "normal"]);
        assert_eq!(
            o.union(Outputs::parse(&["color"]).unwrap()).names().len(),
            3
        );
        assert!(Outputs::parse(&["colour"]).is_err());
        assert!(Outputs::parse::<&str>(&[]).is_err());
    }

    #[test]
    fn bounds_read_the_depth_and_patch_ids_they_are_made_from() {
        let o = Outputs::parse(&["error_bound"]).unwrap();
        assert_eq!(o.to_read().names(), ["depth", "patch_id", "error_bound"]);
        assert_eq!(
            Outputs::parse(&["color"]).unwrap().to_read().names(),
            ["color"]
        );
        assert_eq!(
            Outputs::DEFAULT.names(),
            [
                "color",
                "albedo",
                "depth",
                "normal",
                "patch_id",
                "error_bound"
            ]
        );
    }
}
