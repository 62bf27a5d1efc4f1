//! The Python class of a geometry-texture set. Its methods are gtex.rs's; the class is here so
//! that the bindings returning one (`Surfels.source` in surfels.rs) and those it returns
//! (`GeometryTextureSet.to_surfels`) do not import each other.

use std::sync::Arc;

use pyo3::prelude::*;

use crate::gtex::GeometryTextureSet;

/// Height-map patches in oriented boxes, converted from a mesh or loaded from a .gtex file.
#[pyclass(name = "GeometryTextureSet", module = "geomtex._core", frozen)]
pub struct PyGeometryTextureSet {
    pub(crate) inner: Arc<GeometryTextureSet>,
}

impl PyGeometryTextureSet {
    pub(crate) fn wrap(set: GeometryTextureSet) -> Self {
        PyGeometryTextureSet {
            inner: Arc::new(set),
        }
    }
}
