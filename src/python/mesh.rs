//! Binding of `Mesh`: arrays in (already checked and converted by `geomtex._mesh`), arrays out.

use std::sync::Arc;

use numpy::{PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;

use super::arrays::{expect_columns, flat, matrix, rows};
use super::errors::heavy;
use crate::error::GeomtexError;
use crate::mesh::Mesh;

/// A validated triangle mesh (f64 positions, u32 faces, optional RGBA8 vertex colors).
#[pyclass(name = "Mesh", module = "geomtex._core", subclass, frozen)]
pub struct PyMesh {
    pub(crate) inner: Arc<Mesh>,
}

#[pymethods]
impl PyMesh {
    #[new]
    #[pyo3(signature = (vertices, faces, vertex_colors = None))]
    fn new(
        py: Python<'_>,
        vertices: PyReadonlyArray2<'_, f64>,
        faces: PyReadonlyArray2<'_, i64>,
        vertex_colors: Option<PyReadonlyArray2<'_, u8>>,
    ) -> PyResult<Self> {
        expect_columns(&vertices, 3, "vertices", GeomtexError::Mesh)?;
        expect_columns(&faces, 3, "faces", GeomtexError::Mesh)?;
        if let Some(c) = &vertex_colors {
            expect_columns(c, 4, "vertex_colors", GeomtexError::Mesh)?;
        }
        let (v, f, c) = (
            flat(&vertices),
            flat(&faces),
            vertex_colors.as_ref().map(flat),
        );
        let mesh = heavy(py, "validating the mesh", |_| {
            Mesh::from_flat(&v, &f, c.as_deref())
        })?;
        Ok(PyMesh {
            inner: Arc::new(mesh),
        })
    }

    /// (N, 3) float64 vertex positions (a copy).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let positions: Vec<[f64; 3]> = self.inner.positions.iter().map(|p| p.to_array()).collect();
        rows(py, &positions)
    }

    /// (M, 3) uint32 vertex indices (a copy).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        rows(py, &self.inner.faces)
    }

    /// (N, 4) uint8 RGBA vertex colors, or None.
    #[getter]
    fn vertex_colors<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<u8>>> {
        self.inner.colors.as_ref().map(|c| rows(py, c))
    }

    #[getter]
    fn n_vertices(&self) -> usize {
        self.inner.positions.len()
    }

    #[getter]
    fn n_faces(&self) -> usize {
        self.inner.faces.len()
    }

    /// Length of the bounding-box diagonal.
    #[getter]
    fn diagonal(&self) -> f64 {
        self.inner.diagonal()
    }

    /// (2, 3) float64: the bounding box's min and max corners.
    #[getter]
    fn bounds<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let (lo, hi) = self.inner.bounds();
        matrix(py, [lo.to_array(), hi.to_array()].concat(), 2, 3)
    }

    fn __repr__(&self) -> String {
        let colored = if self.inner.colors.is_some() {
            ", colored"
        } else {
            ""
        };
        format!(
            "<geomtex.Mesh {} vertices, {} faces{colored}>",
            self.inner.positions.len(),
            self.inner.faces.len(),
        )
    }
}
