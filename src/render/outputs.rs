//! Which per-pixel outputs a frame reads back (`render(..., outputs=...)`).
//!
//! Spaces: none.

use crate::error::{GeomtexError, Result};

/// The per-pixel outputs a frame reads back: every target is drawn, but only these are copied
/// off the adapter and converted (on lavapipe the copies and conversions are a large share of a
/// small frame's time).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Outputs {
    pub color: bool,
    pub albedo: bool,
    pub depth: bool,
    pub normal: bool,
    pub patch_id: bool,
}

impl Outputs {
    pub const ALL: Outputs = Outputs {
        color: true,
        albedo: true,
        depth: true,
        normal: true,
        patch_id: true,
    };
    pub const NONE: Outputs = Outputs {
        color: false,
        albedo: false,
        depth: false,
        normal: false,
        patch_id: false,
    };
    /// Every output's name, in the order `names` lists them.
    pub const NAMES: [&'static str; 5] = ["color", "albedo", "depth", "normal", "patch_id"];

    fn flags_mut(&mut self) -> [&mut bool; 5] {
        [
            &mut self.color,
            &mut self.albedo,
            &mut self.depth,
            &mut self.normal,
            &mut self.patch_id,
        ]
    }

    fn flags(&self) -> [bool; 5] {
        [
            self.color,
            self.albedo,
            self.depth,
            self.normal,
            self.patch_id,
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
}
