//! What a render draws: objects of every kind, each placed in the world.
//!
//! Spaces: world (f64, the scene's) and each object's own, placed by `world_from_object`.

use std::any::{Any, TypeId};
use std::sync::Arc;

use glam::DMat4;

use crate::error::{GeomtexError, Result};
use crate::mesh::{Mesh, NormalRule};

/// What a scene holds: a payload of any type a kind of `render::kinds` is registered for — a
/// `GeometryTextureSet`, a `ShadedMesh`, a `SurfelHierarchy`, a `GdmShell` (displacement shell),
/// an `IgtMesh` (a simplified mesh shaded through an inverse geometric texture) — shared, not
/// copied. Which kind draws it is decided once, by its type (kinds::Registry).
#[derive(Clone)]
pub struct Object {
    payload: Arc<dyn Any + Send + Sync>,
    /// The payload's type name, for errors.
    name: &'static str,
}

impl Object {
    pub fn new<T: Any + Send + Sync>(payload: Arc<T>) -> Object {
        Object {
            payload,
            name: std::any::type_name::<T>(),
        }
    }

    /// The payload if it is a `T` (the same allocation the object was made with).
    pub fn payload<T: Any + Send + Sync>(&self) -> Option<Arc<T>> {
        self.payload.clone().downcast::<T>().ok()
    }

    pub fn payload_type(&self) -> TypeId {
        (*self.payload).type_id()
    }

    /// The payload type's name, as errors give it.
    pub fn payload_name(&self) -> &'static str {
        self.name.rsplit("::").next().unwrap_or(self.name)
    }
}

/// A rasterized mesh and the rule its normals follow (the same as `convert`'s): the payload of
/// the mesh kind.
pub struct ShadedMesh {
    pub mesh: Arc<Mesh>,
    pub rule: NormalRule,
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
