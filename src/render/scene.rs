//! What a render draws: objects of every kind, each placed in the world.
//!
//! Spaces: world (f64, the scene's) and each object's own, placed by `world_from_object`.

use std::sync::Arc;

use glam::DMat4;

use crate::error::{GeomtexError, Result};
use crate::gdm_data::GdmShell;
use crate::gtex::GeometryTextureSet;
use crate::igt_data::IgtMesh;
use crate::mesh::{Mesh, NormalRule};
use crate::surfel_data::SurfelHierarchy;

/// What a scene holds; each variant is drawn by its module in `render::kinds`.
#[derive(Clone)]
pub enum Object {
    Textures(Arc<GeometryTextureSet>),
    /// A rasterized mesh and the rule its normals follow (the same as `convert`'s).
    Mesh(Arc<Mesh>, NormalRule),
    /// A surfel hierarchy, splatted with its levels chosen per tile (`max_pixel_error`).
    Surfels(Arc<SurfelHierarchy>),
    /// A displacement shell: mesostructure tiled over a base mesh's prisms (gdm).
    Gdm(Arc<GdmShell>),
    /// A simplified mesh shaded through an inverse geometric texture (kinds/igt.rs).
    Igt(Arc<IgtMesh>),
}

#[derive(Clone)]
pub struct SceneObject {
    pub object: Object,
    pub world_from_object: DMat4,
}

#[derive(Clone, Default)]
pub struct Scene {
    pub objects: Vec<SceneObject>,
}

impl SceneObject {
    /// A placement the renderer can invert; `index` names the object in the error.
    pub(crate) fn check_placement(&self, index: usize) -> Result<()> {
        let m = &self.world_from_object;
        if !m.is_finite() || m.determinant().abs() < 1e-300 {
            return Err(GeomtexError::Parameter(format!(
                "scene object {index}: world_from_object must be finite and invertible"
            )));
        }
        Ok(())
    }
}
