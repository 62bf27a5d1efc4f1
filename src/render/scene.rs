//! What a render draws: objects of every kind, each placed in the world.
//!
//! Spaces: world (f64, the scene's) and each object's own, placed by `world_from_object`.

use std::any::{Any, TypeId};
use std::sync::Arc;

use glam::DMat4;

use crate::error::{GeomtexError, Result};

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

pub use crate::mesh::ShadedMesh;

#[derive(Clone)]
pub struct SceneObject {
    pub object: Object,
    pub world_from_object: DMat4,
}

#[derive(Clone, Default)]
pub struct Scene {
    pub objects: Vec<SceneObject>,
}

impl Scene {
    /// The scene as the renderers draw it: each set with triangles (a hybrid set) followed by
    /// its triangles as a mesh, placed as the set (a set of triangles alone is just the mesh).
    /// So every backend, kind and query draws them as it draws meshes: their hits get the next
    /// mesh id (-2 - k) and no error bound (they are the source's own faces).
    /// Surfels of a hybrid set likewise: the surfels of its patches, then its triangles.
    pub fn drawn(&self) -> Scene {
        let mut objects = Vec::with_capacity(self.objects.len());
        for placed in &self.objects {
            let Some((triangles, has_patches)) = hybrid_parts(&placed.object) else {
                objects.push(placed.clone());
                continue;
            };
            if has_patches {
                objects.push(placed.clone());
            }
            objects.push(SceneObject {
                object: Object::new(triangles.shaded.clone()),
                world_from_object: placed.world_from_object,
            });
        }
        Scene { objects }
    }
}

/// A hybrid set's (or its surfels') triangles, and whether there is anything else to draw.
fn hybrid_parts(object: &Object) -> Option<(&crate::gtex::SetTriangles, bool)> {
    use crate::gtex::GeometryTextureSet;
    use crate::surfel_data::SurfelHierarchy;
    let payload: &(dyn Any + Send + Sync) = &*object.payload;
    if let Some(set) = payload.downcast_ref::<GeometryTextureSet>() {
        return Some((set.triangles.as_ref()?, !set.patches.is_empty()));
    }
    let surfels = payload.downcast_ref::<SurfelHierarchy>()?;
    Some((
        surfels.source.triangles.as_ref()?,
        !surfels.tiles.is_empty(),
    ))
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
