//! Bindings of `InverseGeometricTexture` (`build_igt`, `load_igt`): arrays and errors only.

use std::sync::Arc;

use numpy::{PyArray1, PyArray2, PyArray3, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

use super::args::{opt_integer, opt_text, path};
use super::arrays::{expect_columns, flat, image, matrix, rows};
use super::drawn::{Drawn, Holds};
use super::errors::heavy;
use super::gtex::with_progress;
use super::mesh::PyMesh;
use crate::error::GeomtexError;
use crate::igt::{self, IgtOptions};
use crate::igt_data::{self, file, IgtMesh, InverseGeometricTexture, Lod, Lookup};
use crate::mesh::{Mesh, NormalRule};

/// An inverse geometric texture: per cell of a primary parameterization (the conversion's
/// charts, or a spherical or cylindrical map) the list of the detailed mesh's triangles that
/// overlap it, those triangles in primary space, and their attributes.
#[pyclass(name = "InverseGeometricTexture", module = "geomtex._core", frozen)]
pub struct PyIgt {
    pub(crate) inner: Arc<InverseGeometricTexture>,
}

impl PyIgt {
    fn wrap(igt: InverseGeometricTexture) -> Self {
        PyIgt {
            inner: Arc::new(igt),
        }
    }
}

/// Which optional attributes to keep or compute: ("colors", "uv", "ao"); normals are always
/// kept; by default colors and uv (the mesh's own), no occlusion (it is computed, at a cost).
fn attribute_flags(attributes: Option<Vec<String>>) -> PyResult<(bool, bool, bool)> {
    let Some(names) = attributes else {
        return Ok((true, true, false));
    };
    for n in &names {
        if !["normals", "colors", "uv", "ao"].contains(&n.as_str()) {
            return Err(GeomtexError::Parameter(format!(
                "attributes may name 'normals', 'colors', 'uv' and 'ao', got {n:?}"
            ))
            .into());
        }
    }
    let has = |n: &str| names.iter().any(|x| x == n);
    Ok((has("colors"), has("uv"), has("ao")))
}

/// The occlusion options from `ao_rays` and `ao_distance` (which need "ao" among the
/// attributes).
fn occlusion_options(
    ao: bool,
    rays: Option<&Bound<'_, PyAny>>,
    distance: Option<f64>,
) -> PyResult<Option<igt::OcclusionOptions>> {
    let rays = opt_integer(rays, "ao_rays", 1..=igt::occlusion::MAX_RAYS as i64)?;
    if !ao {
        if rays.is_some() || distance.is_some() {
            return Err(GeomtexError::Parameter(
                "ao_rays and ao_distance need 'ao' among the attributes".into(),
            )
            .into());
        }
        return Ok(None);
    }
    if let Some(d) = distance.filter(|d| !(d.is_finite() && *d > 0.0)) {
        return Err(GeomtexError::Parameter(format!(
            "ao_distance must be positive and finite (mesh units), got {d}"
        ))
        .into());
    }
    let mut o = igt::OcclusionOptions::default();
    o.rays = rays.map_or(o.rays, |r| r as u32);
    o.distance = distance;
    Ok(Some(o))
}

/// Builds the inverse geometric texture of a detailed mesh (see geomtex.igt.build).
#[pyfunction]
#[pyo3(signature = (mesh, *, primary = None, resolution = None, attributes = None,
    normals = None, crease_angle = None, charts = None, ao_rays = None, ao_distance = None,
    progress = None))]
#[allow(clippy::too_many_arguments)] // one per keyword of geomtex.igt.build
pub fn build_igt(
    py: Python<'_>,
    mesh: &Bound<'_, PyMesh>,
    primary: Option<&Bound<'_, PyAny>>,
    resolution: Option<&Bound<'_, PyAny>>,
    attributes: Option<Vec<String>>,
    normals: Option<&Bound<'_, PyAny>>,
    crease_angle: Option<f64>,
    charts: Option<&Bound<'_, PyAny>>,
    ao_rays: Option<&Bound<'_, PyAny>>,
    ao_distance: Option<f64>,
    progress: Option<Py<PyAny>>,
) -> PyResult<PyIgt> {
    let mut opts = IgtOptions::default();
    if let Some(p) = opt_text(primary, "primary")? {
        opts.primary = p.parse()?;
    }
    if let Some(r) = opt_integer(resolution, "resolution", i64::MIN..=i64::MAX)? {
        opts.resolution = igt_data::check_resolution(r)?;
    }
    let ao;
    (opts.colors, opts.uv, ao) = attribute_flags(attributes)?;
    opts.ao = occlusion_options(ao, ao_rays, ao_distance)?;
    let source = opt_text(normals, "normals")?
        .map(|s| s.parse())
        .transpose()?;
    opts.normals = NormalRule::from_keywords(source, crease_angle)?;
    opts.charts.charts = opt_integer(charts, "charts", 1..=4096)?.map(|c| c as usize);
    let mesh = mesh.get().inner.clone();
    let built = with_progress(py, "building an inverse geometric texture", progress, |p| {
        igt::build(&mesh, &opts, p)
    })?;
    Ok(PyIgt::wrap(built))
}

#[pymethods]
impl PyIgt {
    /// "charts", "spherical" or "cylindrical".
    #[getter]
    fn primary(&self) -> &'static str {
        self.inner.primary.name()
    }

    #[getter]
    fn resolution(&self) -> u32 {
        self.inner.resolution
    }

    /// Figures: faces, grids, cells, empty_cells, empty_fraction, entries, list_mean (over
    /// non-empty cells), list_max, bytes_hash, bytes_lists, bytes_triangles,
    /// bytes_attributes, bytes_image, bytes (the four tables), bytes_per_face,
    /// seconds_<stage>, and histogram (cells per list length 0..31, then 32 or more).
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (name, v) in &self.inner.stats {
            d.set_item(name, v)?;
        }
        d.set_item("histogram", self.inner.histogram.clone())?;
        Ok(d)
    }

    /// Per grid (G rows): origin (G, 3), axes (G, 3, 3) rows x, y, z, cell (G, 2) world units
    /// per cell, shape (G, 2) width and height in cells, first_cell (G,).
    #[getter]
    fn grids<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let g = &self.inner.grids;
        let d = PyDict::new(py);
        let origin: Vec<[f64; 3]> = g.iter().map(|g| g.origin.to_array()).collect();
        d.set_item("origin", rows(py, &origin))?;
        let axes: Vec<f64> = (g.iter())
            .flat_map(|g| g.axes.iter().flat_map(|a| a.to_array()))
            .collect();
        d.set_item("axes", image(py, axes, (g.len(), 3, 3)))?;
        let cell: Vec<[f64; 2]> = g.iter().map(|g| g.cell.to_array()).collect();
        d.set_item("cell", rows(py, &cell))?;
        let shape: Vec<[i64; 2]> = (g.iter())
            .map(|g| [g.width as i64, g.height as i64])
            .collect();
        d.set_item("shape", rows(py, &shape))?;
        let first = g.iter().map(|g| g.first_cell as i64);
        d.set_item("first_cell", PyArray1::from_iter(py, first))?;
        Ok(d)
    }

    /// (cells + 1,) int64: the list of cell c is cell_entries[cell_start[c]:cell_start[c + 1]].
    #[getter]
    fn cell_start<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        PyArray1::from_iter(py, self.inner.cell_start.iter().map(|&x| x as i64))
    }

    /// (L,) int64 entry indices, cell by cell.
    #[getter]
    fn cell_entries<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        PyArray1::from_iter(py, self.inner.cell_entries.iter().map(|&x| x as i64))
    }

    /// (E,) int64 detailed face of each entry.
    #[getter]
    fn entry_face<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        PyArray1::from_iter(py, self.inner.entries.iter().map(|e| e.face as i64))
    }

    /// (E,) int64 grid of each entry.
    #[getter]
    fn entry_grid<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        PyArray1::from_iter(py, self.inner.entries.iter().map(|e| e.grid as i64))
    }

    /// (E, 3, 2) float32 corners of each entry in its grid's primary space (cell units).
    #[getter]
    fn entry_corners<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f32>> {
        let e = &self.inner.entries;
        let flat: Vec<f32> = e.iter().flat_map(|e| e.corners.concat()).collect();
        image(py, flat, (e.len(), 3, 2))
    }

    /// (F,) int64 grid of each detailed face (-1: degenerate, never listed).
    #[getter]
    fn face_grid<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let g = self.inner.face_grid.iter();
        PyArray1::from_iter(py, g.map(|&g| if g == u32::MAX { -1 } else { g as i64 }))
    }

    /// (F, 3, 3) float32 corner normals of the detailed faces.
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f32>> {
        let n = &self.inner.attributes.normals;
        image(
            py,
            n.iter().flatten().flatten().copied().collect(),
            (n.len(), 3, 3),
        )
    }

    /// (F, 3, 4) uint8 corner colors, or None.
    #[getter]
    fn colors<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<u8>>> {
        let c = self.inner.attributes.colors.as_ref()?;
        Some(image(
            py,
            c.iter().flatten().flatten().copied().collect(),
            (c.len(), 3, 4),
        ))
    }

    /// (F, 3, 2) float32 corner texture coordinates, or None.
    #[getter]
    fn uv<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<f32>>> {
        let c = self.inner.attributes.uv.as_ref()?;
        Some(image(
            py,
            c.iter().flatten().flatten().copied().collect(),
            (c.len(), 3, 2),
        ))
    }

    /// (F, 3) float32 ambient occlusion at the corners (the unoccluded fraction of each
    /// vertex's cosine-weighted hemisphere, in steps of 1/255), or None.
    #[getter]
    fn ao<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f32>>> {
        let a = self.inner.attributes.ao.as_ref()?;
        let v = a.iter().flatten().map(|&b| f32::from(b) / 255.0).collect();
        Some(matrix(py, v, a.len(), 3))
    }

    /// (H, W, 4) uint8 texture image, row 0 at the top, or None.
    #[getter]
    fn texture<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<u8>>> {
        let i = self.inner.attributes.image.as_ref()?;
        let flat = i.pixels().iter().flatten().copied().collect();
        Some(image(py, flat, (i.height(), i.width(), 4)))
    }

    /// Raises ParameterError unless the mesh (V, 3) / (M, 3) lies where the detailed mesh does
    /// (within 0.25 of its diagonal past its bounding box): what `shade` checks first, for
    /// geomtex.igt.attach to check before it assigns faces their grids.
    fn check_near(
        &self,
        vertices: PyReadonlyArray2<'_, f64>,
        faces: PyReadonlyArray2<'_, i64>,
    ) -> PyResult<()> {
        expect_columns(&vertices, 3, "vertices", GeomtexError::Mesh)?;
        expect_columns(&faces, 3, "faces", GeomtexError::Mesh)?;
        let mesh = Mesh::from_flat(&flat(&vertices), &flat(&faces), None)?;
        Ok(crate::igt::check_near_source(&self.inner, &mesh)?)
    }

    /// The detailed face under each world point (N, 3) and its barycentrics: projected into
    /// grid `grids[k]` (required with several grids), the first listed triangle containing it,
    /// else the nearest listed one. Returns (face (N,) int64, -1 where nothing is listed near;
    /// barycentric (N, 3) float64; inside (N,) bool, False where the fallback answered).
    #[pyo3(signature = (points, grids = None))]
    #[allow(clippy::type_complexity)] // face ids, barycentrics and inside flags, as numpy arrays
    fn lookup<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
        grids: Option<Vec<i64>>,
    ) -> PyResult<(
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray1<bool>>,
    )> {
        expect_columns(&points, 3, "points", GeomtexError::Parameter)?;
        let pts: Vec<glam::DVec3> = flat(&points)
            .chunks_exact(3)
            .map(glam::DVec3::from_slice)
            .collect();
        let inner = self.inner.clone();
        let hits = heavy(py, "looking up points", move |_| {
            inner.lookup_many(&pts, grids.as_deref())
        })?;
        let faces = PyArray1::from_iter(py, hits.iter().map(|h| h.face));
        let bary = matrix(
            py,
            hits.iter().flat_map(|h| h.bary).collect(),
            hits.len(),
            3,
        );
        let inside = PyArray1::from_iter(py, hits.iter().map(|h| h.inside));
        Ok((faces, bary, inside))
    }

    /// (V, 3) float64 vertices of the detailed mesh.
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let v: Vec<[f64; 3]> = self.inner.positions.iter().map(|p| p.to_array()).collect();
        rows(py, &v)
    }

    /// (F, 3) int64 faces of the detailed mesh.
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        let f: Vec<[i64; 3]> = self.inner.faces.iter().map(|t| t.map(i64::from)).collect();
        rows(py, &f)
    }

    /// A simplified mesh (V, 3) / (M, 3) to render through this texture, each face projected
    /// into grid `face_grid[m]` (see geomtex.igt.simplify); `lookup` "ray" (default) or
    /// "projection"; `samples` 1 (default) or 5 lookups per pixel, averaged; `lod` "off"
    /// (default), "auto" or a distance (see geomtex.igt.attach).
    #[pyo3(signature = (vertices, faces, face_grid, lookup = None, samples = None, lod = None))]
    #[allow(clippy::too_many_arguments)] // one per keyword of geomtex.igt.attach
    fn shade(
        &self,
        py: Python<'_>,
        vertices: PyReadonlyArray2<'_, f64>,
        faces: PyReadonlyArray2<'_, i64>,
        face_grid: Vec<i64>,
        lookup: Option<&str>,
        samples: Option<i64>,
        lod: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyIgtMesh> {
        let lod = match lod {
            None => Lod::default(),
            Some(v) => match v.extract::<String>() {
                Ok(t) => Lod::from_keyword(Some(&t), None)?,
                Err(_) => Lod::from_keyword(
                    None,
                    Some(v.extract::<f64>().map_err(|_| {
                        GeomtexError::Parameter(format!(
                            "lod must be 'auto', 'off' or a distance, got {v}"
                        ))
                    })?),
                )?,
            },
        };
        expect_columns(&vertices, 3, "vertices", GeomtexError::Mesh)?;
        expect_columns(&faces, 3, "faces", GeomtexError::Mesh)?;
        let lookup = lookup.map_or(Ok(Lookup::default()), str::parse::<Lookup>)?;
        let mesh = Mesh::from_flat(&flat(&vertices), &flat(&faces), None)?;
        let igt = self.inner.clone();
        let shaded = heavy(py, "shading a mesh through the texture", move |cancel| {
            Ok(IgtMesh::new(igt, mesh, face_grid, lookup, cancel)?
                .with_samples(samples.unwrap_or(1))?
                .with_lod(lod))
        })?;
        Ok(PyIgtMesh {
            inner: Arc::new(shaded),
        })
    }

    /// Writes a .gtigt file atomically.
    fn save(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = self::path(path, "path")?;
        let inner = self.inner.clone();
        heavy(py, "saving", move |_| inner.save(&path))
    }

    /// The bytes of the .gtigt file `save` writes.
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        let inner = self.inner.clone();
        let bytes = py.detach(move || file::encode(&inner));
        PyBytes::new(py, &bytes)
    }

    /// A texture from the bytes of a .gtigt file; FormatError for anything not an intact one.
    #[staticmethod]
    fn from_bytes(py: Python<'_>, data: &[u8]) -> PyResult<Self> {
        let igt = py.detach(|| file::decode(data)).map_err(|e| {
            GeomtexError::Format(format!("InverseGeometricTexture.from_bytes: {e}"))
        })?;
        Ok(PyIgt::wrap(igt))
    }

    fn __repr__(&self) -> String {
        let i = &self.inner;
        format!(
            "<geomtex.InverseGeometricTexture {} faces, {} primary, {} grids, {} cells, mean list \
             {:.2}>",
            i.face_count(),
            i.primary.name(),
            i.grids.len(),
            i.cells(),
            i.stat("list_mean").unwrap_or(0.0)
        )
    }
}

/// A simplified mesh shaded through an inverse geometric texture; render it like a mesh
/// (`Scene.add`, `Renderer.render`).
#[pyclass(name = "IgtMesh", module = "geomtex._core", frozen)]
pub struct PyIgtMesh {
    pub(crate) inner: Arc<IgtMesh>,
}

/// How a Scene takes a mesh shaded through an inverse geometric texture (python/kinds.rs).
pub(crate) const DRAWN: Drawn = Drawn::of::<PyIgtMesh>("IgtMesh", "IGT meshes");

impl Holds for PyIgtMesh {
    type Payload = IgtMesh;
    const NO_NORMALS: &'static str = "an IgtMesh takes its detailed mesh's normals \
         (geomtex.igt.build(..., normals=...))";
    fn payload(&self) -> &Arc<IgtMesh> {
        &self.inner
    }
    fn holding(inner: Arc<IgtMesh>) -> Self {
        PyIgtMesh { inner }
    }
}

#[pymethods]
impl PyIgtMesh {
    /// The texture it is shaded through.
    #[getter]
    fn igt(&self) -> PyIgt {
        PyIgt {
            inner: self.inner.igt.clone(),
        }
    }

    /// (V, 3) float64 vertices of the simplified mesh.
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let v: Vec<[f64; 3]> = (self.inner.mesh.positions.iter())
            .map(|p| p.to_array())
            .collect();
        rows(py, &v)
    }

    /// (M, 3) int64 faces of the simplified mesh.
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        let f: Vec<[i64; 3]> = (self.inner.mesh.faces.iter())
            .map(|t| t.map(i64::from))
            .collect();
        rows(py, &f)
    }

    /// (M,) int64 grid each face projects into.
    #[getter]
    fn face_grid<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        PyArray1::from_iter(py, self.inner.face_grid.iter().map(|&g| g as i64))
    }

    /// "ray" or "projection": how fragments find their detailed triangle.
    #[getter]
    fn lookup(&self) -> &'static str {
        self.inner.lookup.name()
    }

    /// Lookups per pixel: 1 or 5 (averaged).
    #[getter]
    fn samples(&self) -> u32 {
        self.inner.samples
    }

    /// The shader LoD: "auto", "off", or the distance (float) beyond which the baked texture
    /// shades.
    #[getter]
    fn lod(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        Ok(match self.inner.lod {
            Lod::Distance(d) => f64::from(d).into_pyobject(py)?.into_any().unbind(),
            other => other.name().into_pyobject(py)?.into_any().unbind(),
        })
    }

    /// (M, K) int64: per face, the grids the ray lookup walks (its own first; -1 pads).
    #[getter]
    fn search_grids<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let lists = &self.inner.face_search_grids;
        let k = lists.iter().map(Vec::len).max().unwrap_or(0);
        let mut flat = vec![-1i64; lists.len() * k];
        for (row, list) in flat.chunks_mut(k.max(1)).zip(lists) {
            for (slot, &g) in row.iter_mut().zip(list) {
                *slot = i64::from(g);
            }
        }
        numpy::PyArrayMethods::reshape(&PyArray1::from_vec(py, flat), [lists.len(), k])
    }

    /// (M, 2) float64: per face, how far (object units) the ray lookup searches outside (the
    /// side its normal points to) and inside the face's plane (the measured distance to the
    /// detailed surface, with slack).
    #[getter]
    fn face_window<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let w: Vec<[f64; 2]> = (self.inner.face_window.iter())
            .map(|w| w.map(f64::from))
            .collect();
        rows(py, &w)
    }

    fn __len__(&self) -> usize {
        self.inner.mesh.faces.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "<geomtex.IgtMesh {} faces shading {} detailed faces>",
            self.inner.mesh.faces.len(),
            self.inner.igt.face_count()
        )
    }
}

/// Reads a .gtigt file (FormatError if it is not an intact one).
#[pyfunction]
pub fn load_igt(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<PyIgt> {
    let path = self::path(path, "path")?;
    let igt = heavy(py, "loading", move |_| InverseGeometricTexture::load(&path))?;
    Ok(PyIgt::wrap(igt))
}
