//! The Python binding layer (`geomtex._core`): thin wrappers over the core, numpy in and out,
//! the GIL released around heavy work, and every core error mapped in one place (`to_py_err`)
//! onto the exception tree defined in `geomtex/_errors.py`.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

use crate::convert::ConvertArgs;
use crate::error::GeomtexError;
use crate::gtex::GeometryTextureSet;
use crate::mesh::Mesh;

mod render;

/// The one place core errors become Python exceptions.
fn to_py_err(e: GeomtexError) -> PyErr {
    let class = match &e {
        GeomtexError::Mesh(_) => "MeshError",
        GeomtexError::Parameter(_) => "ParameterError",
        GeomtexError::Format(_) => "FormatError",
        GeomtexError::Io { .. } => "FileError",
        GeomtexError::Cancelled(_) => "CancelledError",
        GeomtexError::Device(_) => "DeviceError",
    };
    let msg = e.to_string();
    Python::attach(
        |py| match py.import("geomtex._errors").and_then(|m| m.getattr(class)) {
            Ok(cls) => match cls.call1((msg.clone(),)) {
                Ok(inst) => PyErr::from_value(inst),
                Err(err) => err,
            },
            Err(_) => PyRuntimeError::new_err(msg),
        },
    )
}

fn parameter_error(msg: String) -> PyErr {
    to_py_err(GeomtexError::Parameter(msg))
}

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
        let shape_err = |what: &str, shape: &[usize], cols: usize| {
            to_py_err(GeomtexError::Mesh(format!(
                "{what} must have shape (N, {cols}); got {shape:?}"
            )))
        };
        if vertices.shape()[1] != 3 {
            return Err(shape_err("vertices", vertices.shape(), 3));
        }
        if faces.shape()[1] != 3 {
            return Err(shape_err("faces", faces.shape(), 3));
        }
        if let Some(c) = &vertex_colors {
            if c.shape()[1] != 4 {
                return Err(shape_err("vertex_colors", c.shape(), 4));
            }
        }
        let v = vertices
            .as_array()
            .as_standard_layout()
            .into_owned()
            .into_raw_vec_and_offset()
            .0;
        let f = faces
            .as_array()
            .as_standard_layout()
            .into_owned()
            .into_raw_vec_and_offset()
            .0;
        let c = vertex_colors.map(|c| {
            c.as_array()
                .as_standard_layout()
                .into_owned()
                .into_raw_vec_and_offset()
                .0
        });
        let mesh = py
            .detach(|| Mesh::from_flat(&v, &f, c.as_deref()))
            .map_err(to_py_err)?;
        Ok(PyMesh {
            inner: Arc::new(mesh),
        })
    }

    /// (N, 3) float64 vertex positions (a copy).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let flat: Vec<f64> = self
            .inner
            .positions
            .iter()
            .flat_map(|p| p.to_array())
            .collect();
        Array2::from_shape_vec((self.inner.positions.len(), 3), flat)
            .unwrap()
            .into_pyarray(py)
    }

    /// (M, 3) uint32 vertex indices (a copy).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        let flat: Vec<u32> = self.inner.faces.iter().flatten().copied().collect();
        Array2::from_shape_vec((self.inner.faces.len(), 3), flat)
            .unwrap()
            .into_pyarray(py)
    }

    /// (N, 4) uint8 RGBA vertex colors, or None.
    #[getter]
    fn vertex_colors<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<u8>>> {
        self.inner.colors.as_ref().map(|c| {
            let flat: Vec<u8> = c.iter().flatten().copied().collect();
            Array2::from_shape_vec((c.len(), 4), flat)
                .unwrap()
                .into_pyarray(py)
        })
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
        let flat = [lo.to_array(), hi.to_array()].concat();
        Array2::from_shape_vec((2, 3), flat)
            .unwrap()
            .into_pyarray(py)
    }

    fn __repr__(&self) -> String {
        format!(
            "<geomtex.Mesh {} vertices, {} faces{}>",
            self.inner.positions.len(),
            self.inner.faces.len(),
            if self.inner.colors.is_some() {
                ", colored"
            } else {
                ""
            }
        )
    }
}

/// Height-map patches in oriented boxes, converted from a mesh or loaded from a .gtex file.
#[pyclass(name = "GeometryTextureSet", module = "geomtex._core", frozen)]
pub struct PyGeometryTextureSet {
    pub(crate) inner: Arc<GeometryTextureSet>,
}

/// Stats that are fractions or lengths; every other stat is a count and comes out as int.
const FLOAT_STATS: &[&str] = &[
    "empty_fraction",
    "texel_size",
    "diagonal",
    "vsa_mean_error",
    "reconstruction_error_p99",
    "reconstruction_error_max",
    "max_quantization_error",
];

#[pymethods]
impl PyGeometryTextureSet {
    fn __len__(&self) -> usize {
        self.inner.patches.len()
    }

    /// Figures of the conversion (see DESIGN.md), with per-stage wall-clock seconds under
    /// "seconds".
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (name, v) in &self.inner.stats.values {
            if !FLOAT_STATS.contains(&name.as_str()) && v.fract() == 0.0 && v.abs() < 9e15 {
                d.set_item(name, *v as i64)?;
            } else {
                d.set_item(name, *v)?;
            }
        }
        let s = PyDict::new(py);
        for (name, v) in &self.inner.stats.seconds {
            s.set_item(name, *v)?;
        }
        d.set_item("seconds", s)?;
        for (name, v) in &self.inner.stats.per_patch {
            d.set_item(name, PyArray1::from_slice(py, v))?;
        }
        Ok(d)
    }

    /// World size of one texel (the same in every patch).
    #[getter]
    fn texel_size(&self) -> f64 {
        self.inner.texel_size
    }

    /// (P, 4, 4) float64: each patch's world_from_patch (unit cube → world box).
    #[getter]
    fn world_from_patch<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        let mut flat = Vec::with_capacity(self.inner.patches.len() * 16);
        for p in &self.inner.patches {
            // Row-major for numpy: row r = (col0[r], col1[r], col2[r], col3[r]).
            let m = p.world_from_patch().transpose();
            flat.extend_from_slice(&m.to_cols_array());
        }
        Array3::from_shape_vec((self.inner.patches.len(), 4, 4), flat)
            .unwrap()
            .into_pyarray(py)
    }

    /// (M,) int32: the patch holding each source face, -1 for degenerate faces left out.
    fn face_patch<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i32>> {
        Array1::from_vec(self.inner.face_patch()).into_pyarray(py)
    }

    /// One patch's maps and frame as numpy arrays: height (H, W) codes, uint16 or uint8 as
    /// `height_bits` says (0 = empty, else h = (code - 1) / (2**height_bits - 2)), normal
    /// (H, W, 4) int8 (patch-local xyz/127), color (H, W, 4) uint8, world_from_patch (4, 4),
    /// origin (3,), axes (3, 3) (rows x, y, z), extent (3,), faces and ring_faces (uint32).
    fn patch<'py>(&self, py: Python<'py>, index: isize) -> PyResult<Bound<'py, PyDict>> {
        let n = self.inner.patches.len() as isize;
        let i = if index < 0 { index + n } else { index };
        if i < 0 || i >= n {
            return Err(pyo3::exceptions::PyIndexError::new_err(format!(
                "patch index {index} out of range for {n} patches"
            )));
        }
        let p = &self.inner.patches[i as usize];
        let (h, w) = (p.height as usize, p.width as usize);
        let d = PyDict::new(py);
        if p.height_bits == 8 {
            let codes: Vec<u8> = p.heights.iter().map(|&q| q as u8).collect();
            d.set_item(
                "height",
                Array2::from_shape_vec((h, w), codes)
                    .unwrap()
                    .into_pyarray(py),
            )?;
        } else {
            d.set_item(
                "height",
                Array2::from_shape_vec((h, w), p.heights.clone())
                    .unwrap()
                    .into_pyarray(py),
            )?;
        }
        d.set_item("height_bits", p.height_bits)?;
        let normals: Vec<i8> = p.normals.iter().flatten().copied().collect();
        d.set_item(
            "normal",
            Array3::from_shape_vec((h, w, 4), normals)
                .unwrap()
                .into_pyarray(py),
        )?;
        let colors: Vec<u8> = p.colors.iter().flatten().copied().collect();
        d.set_item(
            "color",
            Array3::from_shape_vec((h, w, 4), colors)
                .unwrap()
                .into_pyarray(py),
        )?;
        let m = p.world_from_patch().transpose().to_cols_array().to_vec();
        d.set_item(
            "world_from_patch",
            Array2::from_shape_vec((4, 4), m).unwrap().into_pyarray(py),
        )?;
        d.set_item(
            "origin",
            Array1::from_vec(p.origin.to_array().to_vec()).into_pyarray(py),
        )?;
        let axes: Vec<f64> = p.axes.iter().flat_map(|a| a.to_array()).collect();
        d.set_item(
            "axes",
            Array2::from_shape_vec((3, 3), axes)
                .unwrap()
                .into_pyarray(py),
        )?;
        d.set_item(
            "extent",
            Array1::from_vec(p.extent.to_array().to_vec()).into_pyarray(py),
        )?;
        d.set_item("faces", Array1::from_vec(p.faces.clone()).into_pyarray(py))?;
        d.set_item(
            "ring_faces",
            Array1::from_vec(p.ring_faces.clone()).into_pyarray(py),
        )?;
        Ok(d)
    }

    /// Every non-empty texel as a world point: ((N, 3) float64 points, (N, 3) float32 unit
    /// normals).
    fn to_points<'py>(
        &self,
        py: Python<'py>,
    ) -> (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f32>>) {
        let inner = self.inner.clone();
        let (p, n) = py.detach(move || inner.to_points());
        let k = p.len();
        (
            Array2::from_shape_vec((k, 3), p.into_flattened())
                .unwrap()
                .into_pyarray(py),
            Array2::from_shape_vec((k, 3), n.into_flattened())
                .unwrap()
                .into_pyarray(py),
        )
    }

    /// Exact first hits of world rays on the set's surface, computed on the CPU in f64 (the
    /// reference the GPU searches are tested against): ((N,) float64 distances along the rays,
    /// +inf on a miss; (N,) int32 patch indices, -1 on a miss). Directions must be unit vectors.
    fn first_hits<'py>(
        &self,
        py: Python<'py>,
        origins: PyReadonlyArray2<'py, f64>,
        directions: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i32>>)> {
        if origins.shape()[1] != 3 || directions.shape() != origins.shape() {
            return Err(parameter_error(format!(
                "origins and directions must both be (N, 3); got {:?} and {:?}",
                origins.shape(),
                directions.shape()
            )));
        }
        let (o, d) = (origins.as_array(), directions.as_array());
        let rays: Vec<(glam::DVec3, glam::DVec3)> = (0..o.nrows())
            .map(|i| {
                (
                    glam::DVec3::new(o[[i, 0]], o[[i, 1]], o[[i, 2]]),
                    glam::DVec3::new(d[[i, 0]], d[[i, 1]], d[[i, 2]]),
                )
            })
            .collect();
        let inner = self.inner.clone();
        let hits = py.detach(move || crate::heightfield::first_hits(&inner, &rays));
        let (t, k): (Vec<f64>, Vec<i32>) = hits.into_iter().unzip();
        Ok((
            Array1::from_vec(t).into_pyarray(py),
            Array1::from_vec(k).into_pyarray(py),
        ))
    }

    /// Writes a .gtex file atomically (no half file is ever left behind).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let inner = self.inner.clone();
        py.detach(move || inner.save(&path)).map_err(to_py_err)
    }

    /// A copy with every height map filtered: "gaussian" (low-pass) or "high_pass" (unsharp
    /// masking, h + gain (h - gaussian h)); `sigma` in world units; normals rebuilt.
    #[pyo3(signature = (kind, sigma, *, gain = 1.0))]
    fn filtered(&self, py: Python<'_>, kind: &str, sigma: f64, gain: f64) -> PyResult<Self> {
        let filter = crate::filters::MapFilter::from_name(kind, Some(gain)).map_err(to_py_err)?;
        let inner = self.inner.clone();
        let set = py
            .detach(move || crate::filters::filtered(&inner, filter, sigma))
            .map_err(to_py_err)?;
        Ok(PyGeometryTextureSet {
            inner: Arc::new(set),
        })
    }

    /// Gaps (world units, float64) between neighbouring patches at points along their charts'
    /// shared edges of `mesh` (the mesh the set was converted from).
    fn seam_gaps<'py>(
        &self,
        py: Python<'py>,
        mesh: &Bound<'py, PyMesh>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let (inner, m) = (self.inner.clone(), mesh.get().inner.clone());
        let gaps = py
            .detach(move || crate::filters::seam_gaps(&inner, &m))
            .map_err(to_py_err)?;
        Ok(gaps.into_pyarray(py))
    }

    /// Builds a set straight from regular height grids (see geomtex._grids for the arguments,
    /// which it checks and colors before the grids are tiled here with the GIL released).
    #[staticmethod]
    #[pyo3(signature = (grids, extent, *, properties = None, cmap = "viridis",
        property_range = None, max_resolution = 256, height_bits = 16))]
    #[allow(clippy::too_many_arguments)]
    fn from_heightmaps(
        py: Python<'_>,
        grids: &Bound<'_, PyAny>,
        extent: &Bound<'_, PyAny>,
        properties: Option<&Bound<'_, PyAny>>,
        cmap: &str,
        property_range: Option<&Bound<'_, PyAny>>,
        max_resolution: i64,
        height_bits: i64,
    ) -> PyResult<Self> {
        type Prepared<'py> = (
            PyReadonlyArray2<'py, f64>,
            (f64, f64, f64, f64),
            Option<numpy::PyReadonlyArray3<'py, u8>>,
        );
        let prepared: Vec<Prepared> = py
            .import("geomtex._grids")?
            .call_method1("prepare", (grids, extent, properties, cmap, property_range))?
            .extract()?;
        let grids: Vec<crate::grids::HeightGrid> = prepared
            .iter()
            .map(|(z, (x0, y0, dx, dy), colors)| {
                let shape = z.shape();
                crate::grids::HeightGrid {
                    width: shape[1],
                    height: shape[0],
                    origin: glam::DVec2::new(*x0, *y0),
                    spacing: glam::DVec2::new(*dx, *dy),
                    z: z.as_array().iter().copied().collect(),
                    colors: colors.as_ref().map(|c| {
                        c.as_array()
                            .as_standard_layout()
                            .as_slice()
                            .unwrap()
                            .chunks_exact(4)
                            .map(|q| [q[0], q[1], q[2], q[3]])
                            .collect()
                    }),
                }
            })
            .collect();
        let (tile, bits) = (Some(max_resolution), Some(height_bits));
        let set = py
            .detach(move || crate::grids::from_grids(&grids, tile, bits))
            .map_err(to_py_err)?;
        Ok(PyGeometryTextureSet {
            inner: Arc::new(set),
        })
    }

    fn _repr_png_<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyBytes>> {
        let png = slf
            .py()
            .import("geomtex._preview")?
            .call_method1("set_png", (slf,))?;
        Ok(png.cast_into::<PyBytes>()?)
    }

    fn __repr__(&self) -> String {
        let s = &self.inner;
        format!(
            "<geomtex.GeometryTextureSet {} patches, {} texels ({:.1}% empty), texel {:.4e}>",
            s.patches.len(),
            s.texels(),
            100.0 * s.empty_texels() as f64 / s.texels().max(1) as f64,
            s.texel_size
        )
    }
}

/// Loads a .gtex file; FormatError if it is not one, is truncated, corrupt or of another version.
#[pyfunction]
fn load(py: Python<'_>, path: PathBuf) -> PyResult<PyGeometryTextureSet> {
    let set = py
        .detach(move || GeometryTextureSet::load(&path))
        .map_err(to_py_err)?;
    Ok(PyGeometryTextureSet {
        inner: Arc::new(set),
    })
}

/// Converts a mesh to geometry textures (see geomtex.convert for the keywords).
#[pyfunction]
#[pyo3(signature = (mesh, *, max_resolution = None, texel_size = None, max_error = None,
    max_error_rel = None, error_scope = "set", charts = None,
    chart_error = None, max_charts = 4096, compactness = 1.0, lloyd_iterations = 6, overlap_rings = 1,
    dilation = 2, frame = "min_area", normals = "smooth", height_bits = 16, progress = None))]
#[allow(clippy::too_many_arguments)]
fn convert(
    py: Python<'_>,
    mesh: &Bound<'_, PyMesh>,
    max_resolution: Option<i64>,
    texel_size: Option<f64>,
    max_error: Option<f64>,
    max_error_rel: Option<f64>,
    error_scope: &str,
    charts: Option<i64>,
    chart_error: Option<f64>,
    max_charts: i64,
    compactness: f64,
    lloyd_iterations: i64,
    overlap_rings: i64,
    dilation: i64,
    frame: &str,
    normals: &str,
    height_bits: i64,
    progress: Option<Py<PyAny>>,
) -> PyResult<PyGeometryTextureSet> {
    let opts = ConvertArgs {
        max_resolution,
        texel_size,
        max_error,
        max_error_rel,
        error_scope: Some(error_scope.parse().map_err(to_py_err)?),
        charts,
        chart_error,
        max_charts: Some(max_charts),
        compactness: Some(compactness),
        lloyd_iterations: Some(lloyd_iterations),
        overlap_rings: Some(overlap_rings),
        dilation: Some(dilation),
        frame: Some(frame.parse().map_err(to_py_err)?),
        normals: Some(normals.parse().map_err(to_py_err)?),
        height_bits: Some(height_bits),
    }
    .into_options()
    .map_err(to_py_err)?;
    let inner = mesh.get().inner.clone();
    // An exception raised by the callback (KeyboardInterrupt from tqdm, say) stops the
    // conversion and is re-raised as it was.
    let callback_error: Mutex<Option<PyErr>> = Mutex::new(None);
    let result = py.detach(|| {
        let report = |stage: &str, fraction: f64| -> bool {
            let Some(cb) = &progress else { return true };
            Python::attach(|py| match cb.call1(py, (stage, fraction)) {
                Ok(r) => r.is_none(py) || r.is_truthy(py).unwrap_or(true),
                Err(e) => {
                    *callback_error.lock().unwrap() = Some(e);
                    false
                }
            })
        };
        crate::convert::convert(&inner, &opts, &report)
    });
    match result {
        Ok(set) => Ok(PyGeometryTextureSet {
            inner: Arc::new(set),
        }),
        Err(e) => Err(callback_error
            .into_inner()
            .unwrap()
            .unwrap_or_else(|| to_py_err(e))),
    }
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyMesh>()?;
    m.add_class::<PyGeometryTextureSet>()?;
    m.add_function(wrap_pyfunction!(convert, m)?)?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    render::register(m)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
