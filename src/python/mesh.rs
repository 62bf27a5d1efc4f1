//! Binding of `Mesh`: arrays in (already checked and converted by `geomtex._mesh`), arrays out.

use std::sync::Arc;

use numpy::{
    PyArray2, PyArray3, PyArrayDyn, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3,
    PyReadonlyArrayDyn, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use std::any::TypeId;

use super::arrays::{expect_columns, flat, image, matrix, rows};
use super::drawn::Drawn;
use super::errors::heavy;
use crate::appearance::{TextureCoords, TextureInput};
use crate::error::GeomtexError;
use crate::mesh::Mesh;
use crate::render::{Object, ShadedMesh};

/// A validated triangle mesh (f64 positions, u32 faces, optional RGBA8 vertex or face colors, or
/// texture coordinates and an RGBA8 texture).
#[pyclass(name = "Mesh", module = "geomtex._core", frozen)]
pub struct PyMesh {
    pub(crate) inner: Arc<Mesh>,
}

/// How a Scene takes a mesh: its payload is the mesh with the normal rule it is shaded by
/// (python/kinds.rs).
pub(crate) const DRAWN: Drawn = Drawn {
    name: "Mesh",
    label: "meshes",
    payload_type: TypeId::of::<ShadedMesh>,
    to_object: |obj, normals| {
        let mesh = obj.cast::<PyMesh>().ok()?.get().inner.clone();
        let rule = normals.unwrap_or_default();
        Some(Ok(Object::new(Arc::new(ShadedMesh::new(mesh, rule)))))
    },
    from_object: |py, object| {
        let shaded = object.payload::<ShadedMesh>()?;
        let address = Arc::as_ptr(&shaded.mesh) as *const () as usize;
        let mesh = PyMesh {
            inner: shaded.mesh.clone(),
        };
        Some(Py::new(py, mesh).map(|m| (m.into_any(), address, Some(shaded.rule))))
    },
};

#[pymethods]
impl PyMesh {
    #[new]
    /// `uv` is (N, 2) per vertex or (M, 3, 2) per face corner; `texture` (H, W, 4), row 0 at
    /// the top. Both or neither (the Python layer warns and drops a lone one).
    #[pyo3(signature = (vertices, faces, vertex_colors = None, face_colors = None, uv = None, texture = None))]
    fn new(
        py: Python<'_>,
        vertices: PyReadonlyArray2<'_, f64>,
        faces: PyReadonlyArray2<'_, i64>,
        vertex_colors: Option<PyReadonlyArray2<'_, u8>>,
        face_colors: Option<PyReadonlyArray2<'_, u8>>,
        uv: Option<PyReadonlyArrayDyn<'_, f64>>,
        texture: Option<PyReadonlyArray3<'_, u8>>,
    ) -> PyResult<Self> {
        expect_columns(&vertices, 3, "vertices", GeomtexError::Mesh)?;
        expect_columns(&faces, 3, "faces", GeomtexError::Mesh)?;
        for (c, name) in [
            (&vertex_colors, "vertex_colors"),
            (&face_colors, "face_colors"),
        ] {
            if let Some(c) = c {
                expect_columns(c, 4, name, GeomtexError::Mesh)?;
            }
        }
        let uv_shape = uv.as_ref().map(|a| a.shape().to_vec());
        let per_corner = match uv_shape.as_deref() {
            None | Some([_, 2]) => false,
            Some([_, 3, 2]) => true,
            Some(s) => {
                return Err(GeomtexError::Mesh(format!(
                    "uv must have shape (N, 2) or (M, 3, 2); got {s:?}"
                ))
                .into())
            }
        };
        let tex_shape = texture.as_ref().map(|a| a.shape().to_vec());
        if let Some(s) = &tex_shape {
            if s[2] != 4 {
                return Err(GeomtexError::Mesh(format!(
                    "texture must have shape (H, W, 4); got {s:?}"
                ))
                .into());
            }
        }
        if uv.is_some() != texture.is_some() {
            return Err(GeomtexError::Mesh(
                "uv and texture come together: pass both or neither".into(),
            )
            .into());
        }
        let (v, f, c) = (
            flat(&vertices),
            flat(&faces),
            vertex_colors.as_ref().map(flat),
        );
        let fc = face_colors.as_ref().map(flat);
        let (coords, pixels) = (uv.as_ref().map(flat), texture.as_ref().map(flat));
        let mesh = heavy(py, "validating the mesh", |_| {
            let textured = coords.as_deref().zip(pixels.as_deref()).zip(tex_shape);
            let texture = textured.map(|((coords, pixels), s)| TextureInput {
                coords,
                per_corner,
                width: s[1],
                height: s[0],
                pixels,
            });
            Mesh::from_flat(&v, &f, c.as_deref())?.with_appearance(fc.as_deref(), texture)
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

    /// (M, 4) uint8 RGBA face colors, or None.
    #[getter]
    fn face_colors<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<u8>>> {
        self.inner
            .appearance
            .face_colors
            .as_ref()
            .map(|c| rows(py, c))
    }

    /// float64 texture coordinates, (N, 2) per vertex or (M, 3, 2) per face corner, or None.
    #[getter]
    fn uv<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArrayDyn<f64>>> {
        let t = self.inner.appearance.texture.as_ref()?;
        Some(match &t.coords {
            TextureCoords::PerVertex(uv) => {
                let flat = uv.iter().flat_map(|p| p.to_array()).collect();
                matrix(py, flat, uv.len(), 2).to_dyn().clone()
            }
            TextureCoords::PerCorner(uv) => {
                let flat = uv.iter().flatten().flat_map(|p| p.to_array()).collect();
                image(py, flat, (uv.len(), 3, 2)).to_dyn().clone()
            }
        })
    }

    /// Whether the mesh carries texture coordinates and a texture image.
    #[getter]
    fn textured(&self) -> bool {
        self.inner.appearance.texture.is_some()
    }

    /// (H, W, 4) uint8 RGBA texture image (row 0 at the top), or None.
    #[getter]
    fn texture<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<u8>>> {
        let t = self.inner.appearance.texture.as_ref()?;
        let pixels = t.image.pixels().iter().flatten().copied().collect();
        Some(image(py, pixels, (t.image.height(), t.image.width(), 4)))
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
        let appearance = &self.inner.appearance;
        let colored = if appearance.texture.is_some() {
            ", textured"
        } else if appearance.face_colors.is_some() {
            ", face-colored"
        } else if self.inner.colors.is_some() {
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
