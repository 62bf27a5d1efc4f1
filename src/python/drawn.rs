//! What the binding knows of one class the renderer draws (`Drawn`), given by each kind's
//! binding module and listed in one table by python/kinds.rs.

use std::any::{Any, TypeId};
use std::sync::Arc;

use pyo3::prelude::*;

use super::errors::parameter_error;
use crate::mesh::NormalRule;
use crate::render::Object;

/// One class the renderer draws, as the binding sees it.
pub(crate) struct Drawn {
    /// The Python class's name (errors).
    pub name: &'static str,
    /// How `Scene.__repr__` counts them (plural).
    pub label: &'static str,
    /// The type of the payload its scene objects hold.
    pub payload_type: fn() -> TypeId,
    /// The scene object of `obj` with its mesh normal rule, if `obj` is of this class.
    pub to_object: fn(&Bound<'_, PyAny>, Option<NormalRule>) -> Option<PyResult<Object>>,
    /// The Python object of a scene object of this kind, the address of what it holds (an
    /// object added twice is stored once) and its normal rule; `None` for another kind's.
    pub from_object: fn(Python<'_>, &Object) -> Option<PyResult<Unbound>>,
}

/// A scene object as Python sees it again: the object, the address identifying its payload and
/// its normal rule (meshes only).
pub(crate) type Unbound = (Py<PyAny>, usize, Option<NormalRule>);

/// An extension class whose object is a renderer payload held as an `Arc`.
pub(crate) trait Holds:
    pyo3::PyClass<Frozen = pyo3::pyclass::boolean_struct::True> + Sync
{
    type Payload: Any + Send + Sync;
    /// Why `normals`/`crease_angle` do not apply to it (they are a mesh's).
    const NO_NORMALS: &'static str;
    fn payload(&self) -> &Arc<Self::Payload>;
    fn holding(payload: Arc<Self::Payload>) -> Self;
}

impl Drawn {
    /// The entry of a class that holds its payload as it is (sets, surfels, shells, IGT meshes).
    pub const fn of<T: Holds + Into<pyo3::PyClassInitializer<T>>>(
        name: &'static str,
        label: &'static str,
    ) -> Drawn {
        Drawn {
            name,
            label,
            payload_type: TypeId::of::<T::Payload>,
            to_object: to_object::<T>,
            from_object: from_object::<T>,
        }
    }
}

fn to_object<T: Holds>(
    obj: &Bound<'_, PyAny>,
    normals: Option<NormalRule>,
) -> Option<PyResult<Object>> {
    let held = obj.cast::<T>().ok()?;
    if normals.is_some() {
        return Some(Err(parameter_error(format!(
            "normals and crease_angle apply to meshes; {}",
            T::NO_NORMALS
        ))));
    }
    Some(Ok(Object::new(held.get().payload().clone())))
}

fn from_object<T: Holds + Into<pyo3::PyClassInitializer<T>>>(
    py: Python<'_>,
    object: &Object,
) -> Option<PyResult<Unbound>> {
    let payload = object.payload::<T::Payload>()?;
    let address = Arc::as_ptr(&payload) as *const () as usize;
    Some(Py::new(py, T::holding(payload)).map(|o| (o.into_any(), address, None)))
}
