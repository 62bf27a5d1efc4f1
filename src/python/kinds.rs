//! The binding's side of the renderer's object kinds: for each extension class a Scene takes,
//! how its object becomes a scene object (`render::Object`) and how a scene object becomes it
//! again (`Scene._objects`, which pickling uses). One table, `DRAWN`: `Scene.add`, `_objects` and
//! `Scene.__repr__` read it, so a kind missing from it is refused by name, never drawn as another.
//!
//! Adding a kind: its binding module gives a `Drawn` (python/drawn.rs; most kinds:
//! `Drawn::of::<PyClass>` for a frozen class holding its payload as `inner: Arc<Payload>`), and one
//! line in `DRAWN`.

use pyo3::prelude::*;

use super::drawn::{Drawn, Unbound};
use super::errors::parameter_error;
use crate::mesh::NormalRule;
use crate::render::Object;

/// Every class a Scene takes, one line each.
pub(crate) const DRAWN: [Drawn; 5] = [
    super::gtex::DRAWN,
    super::mesh::DRAWN,
    super::surfels::DRAWN,
    super::gdm::DRAWN,
    super::igt::DRAWN,
];

/// The scene object of `obj` (any class of `DRAWN`); a ParameterError naming them otherwise.
pub(crate) fn object_of(obj: &Bound<'_, PyAny>, normals: Option<NormalRule>) -> PyResult<Object> {
    for drawn in &DRAWN {
        if let Some(object) = (drawn.to_object)(obj, normals) {
            return object;
        }
    }
    let names: Vec<_> = DRAWN.iter().map(|d| d.name).collect();
    Err(parameter_error(format!(
        "expected a {} or a trimesh, got {}",
        names.join(", a "),
        obj.get_type().name()?
    )))
}

/// The entry of `object`'s kind.
fn drawn(object: &Object) -> Option<&'static Drawn> {
    DRAWN
        .iter()
        .find(|d| (d.payload_type)() == object.payload_type())
}

/// The Python object of a scene object, its payload's address and normal rule.
pub(crate) fn unbound(py: Python<'_>, object: &Object) -> PyResult<Unbound> {
    drawn(object)
        .and_then(|d| (d.from_object)(py, object))
        .unwrap_or_else(|| {
            Err(parameter_error(format!(
                "the binding has no class for a {}",
                object.payload_name()
            )))
        })
}

/// The label `Scene.__repr__` counts `object` under.
pub(crate) fn label(object: &Object) -> &'static str {
    drawn(object).map_or("other objects", |d| d.label)
}
