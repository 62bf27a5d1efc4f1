//! Bindings of `GeometryTextureSet`, `convert` and `load`: arrays and errors only. Options arrive
//! as `Option`s and fall back to the core's defaults (`ConvertArgs`, `MapFilter::from_name`,
//! `grids::from_grids`); the notebook helpers (`_repr_png_`, `from_heightmaps`) are Python,
//! attached by the package.

use std::sync::{Arc, Mutex};

use glam::{DVec2, DVec3};
use numpy::{
    PyArray1, PyArray2, PyArray3, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

use super::args::{integer, opt_integer, opt_real, opt_text, path, rays, real};
use super::arrays::{flat, image, mat4_to_numpy, matrix, rows, ArrayPair};
use super::drawn::{Drawn, Holds};
use super::errors::heavy;
use super::mesh::PyMesh;
use super::set::PyGeometryTextureSet;
use crate::convert::{ConvertArgs, ConvertOptions};
use crate::error::GeomtexError;
use crate::filters::MapFilter;
use crate::grids::HeightGrid;
use crate::gtex::{GeometryTextureSet, Patch, StatValue};
use crate::progress::Progress;

/// How a Scene takes a set (python/kinds.rs).
pub(crate) const DRAWN: Drawn = Drawn::of::<PyGeometryTextureSet>("GeometryTextureSet", "sets");

impl Holds for PyGeometryTextureSet {
    type Payload = GeometryTextureSet;
    const NO_NORMALS: &'static str =
        "a GeometryTextureSet's normals were chosen by convert(..., normals=...)";
    fn payload(&self) -> &Arc<GeometryTextureSet> {
        &self.inner
    }
    fn holding(inner: Arc<GeometryTextureSet>) -> Self {
        PyGeometryTextureSet { inner }
    }
}

impl PyGeometryTextureSet {
    /// Gaps and normal steps along the charts' shared edges of `mesh` (a geomtex.Mesh that must
    /// be the set's source), measured with the GIL released.
    fn seams(&self, py: Python<'_>, mesh: &Bound<'_, PyAny>) -> PyResult<crate::filters::Seams> {
        let mesh = mesh.cast::<PyMesh>().map_err(|_| {
            GeomtexError::Mesh(format!(
                "mesh must be a geomtex.Mesh, got {}",
                mesh.get_type().name().map_or("?".into(), |n| n.to_string())
            ))
        })?;
        let (inner, m) = (self.inner.clone(), mesh.get().inner.clone());
        check_source(&inner, &m)?;
        heavy(py, "measuring seams", move |cancel| {
            crate::filters::seams(&inner, &m, cancel)
        })
    }
}

/// Puts typed figures into a dict (counts as int, lengths as float, None where not measured).
pub fn set_stats(d: &Bound<'_, PyDict>, figures: &[(&str, StatValue)]) -> PyResult<()> {
    for (name, value) in figures {
        match *value {
            StatValue::Int(v) => d.set_item(name, v)?,
            StatValue::Float(v) => d.set_item(name, v)?,
            StatValue::Text(v) => d.set_item(name, v)?,
            StatValue::Absent => d.set_item(name, d.py().None())?,
        }
    }
    Ok(())
}

/// One patch's maps and frame as a dict of numpy arrays.
fn patch_dict<'py>(py: Python<'py>, p: &Patch) -> PyResult<Bound<'py, PyDict>> {
    let (h, w) = (p.height as usize, p.width as usize);
    let d = PyDict::new(py);
    if p.height_bits == 8 {
        let codes: Vec<u8> = p.heights.iter().map(|&q| q as u8).collect();
        d.set_item("height", matrix(py, codes, h, w))?;
    } else {
        d.set_item("height", matrix(py, p.heights.clone(), h, w))?;
    }
    d.set_item("height_bits", p.height_bits)?;
    // Decoded to the layouts callers have always read (normals stored as 2-byte octahedral
    // codes, colors possibly absent).
    let normals: Vec<i8> = p.normals_snorm8().into_iter().flatten().collect();
    d.set_item("normal", image(py, normals, (h, w, 4)))?;
    let colors: Vec<u8> = (0..p.texels()).flat_map(|t| p.color(t)).collect();
    d.set_item("color", image(py, colors, (h, w, 4)))?;
    d.set_item("has_colors", p.has_colors())?;
    d.set_item("outline", matrix(py, p.outline.clone(), h, w))?;
    d.set_item("world_from_patch", mat4_to_numpy(py, p.world_from_patch()))?;
    d.set_item("origin", PyArray1::from_slice(py, &p.origin.to_array()))?;
    d.set_item("axes", rows(py, &p.axes.map(|a| a.to_array())))?;
    d.set_item("extent", PyArray1::from_slice(py, &p.extent.to_array()))?;
    d.set_item("faces", PyArray1::from_slice(py, &p.faces))?;
    d.set_item("ring_faces", PyArray1::from_slice(py, &p.ring_faces))?;
    // Per cell (rows and columns from cell -1, as `_with_cell_bounds` takes them), each cell
    // showing its block's stored bound.
    let bound = (p.error_bound.as_ref())
        .map(|map| matrix(py, map.decoded_cells(p.width, p.height), h + 1, w + 1));
    d.set_item("error_bound", bound)?;
    Ok(d)
}

#[pymethods]
impl PyGeometryTextureSet {
    fn __len__(&self) -> usize {
        self.inner.patches.len()
    }

    /// Figures of the conversion (see DESIGN.md), with per-stage wall-clock seconds under
    /// "seconds" and per-patch arrays under their own names.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let stats = &self.inner.stats;
        let d = PyDict::new(py);
        set_stats(&d, &stats.typed())?;
        let seconds = PyDict::new(py);
        for (name, v) in &stats.seconds {
            seconds.set_item(name, *v)?;
        }
        d.set_item("seconds", seconds)?;
        for (name, v) in &stats.per_patch {
            if name == "patch_resolution" {
                // Texel counts, stored as f64 like every per-patch figure.
                let counts: Vec<u32> = v.iter().map(|&r| r as u32).collect();
                d.set_item(name, PyArray1::from_vec(py, counts))?;
            } else {
                d.set_item(name, PyArray1::from_slice(py, v))?;
            }
        }
        Ok(d)
    }

    /// A hybrid set's triangles (None for a set of height maps only): vertices (V, 3)
    /// float64, faces (F, 3) uint32 into them, cluster_starts (C + 1,) uint32 (cluster c is
    /// faces cluster_starts[c]:cluster_starts[c + 1], one per chart kept), source_faces (F,)
    /// uint32 (each face's index in the source mesh), kept_because (C,) str ("bound": no
    /// height map within the bound took fewer bytes than its faces; "budget": moved back so
    /// the set costs no more than the mesh), and bytes.
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(t) = &self.inner.triangles else {
            return Ok(None);
        };
        let m = t.mesh();
        let d = PyDict::new(py);
        let vertices: Vec<f64> = m.positions.iter().flat_map(|p| p.to_array()).collect();
        d.set_item("vertices", matrix(py, vertices, m.positions.len(), 3))?;
        let faces: Vec<u32> = m.faces.iter().flatten().copied().collect();
        d.set_item("faces", matrix(py, faces, m.faces.len(), 3))?;
        d.set_item("cluster_starts", PyArray1::from_slice(py, &t.starts))?;
        d.set_item("source_faces", PyArray1::from_slice(py, &t.source_faces))?;
        let because: Vec<&str> = t.because.iter().map(|b| b.name()).collect();
        d.set_item("kept_because", because)?;
        d.set_item("bytes", t.bytes())?;
        Ok(Some(d))
    }

    /// World size of one texel (the finest patch's where texels differ).
    #[getter]
    fn texel_size(&self) -> f64 {
        self.inner.texel_size
    }

    /// (P, 4, 4) float64: each patch's world_from_patch (unit cube → world box).
    #[getter]
    fn world_from_patch<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        let patches = &self.inner.patches;
        let flat: Vec<f64> = patches
            .iter()
            .flat_map(|p| p.world_from_patch().transpose().to_cols_array())
            .collect();
        image(py, flat, (patches.len(), 4, 4))
    }

    /// (M,) int32: the patch holding each source face, -1 for degenerate faces left out, -2
    /// for faces a hybrid set keeps as triangles.
    fn face_patch<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<i32>>> {
        let inner = self.inner.clone();
        let faces = heavy(py, "listing face patches", move |_| Ok(inner.face_patch()))?;
        Ok(PyArray1::from_vec(py, faces))
    }

    /// One patch's maps and frame as numpy arrays: height (H, W) codes, uint16 or uint8 as
    /// `height_bits` says (0 = empty, else h = (code - 1) / (2**height_bits - 2)), normal
    /// (H, W, 4) int8 (patch-local xyz/127, decoded from the stored octahedral codes; 0 where
    /// none), color (H, W, 4) uint8 (neutral 200, 200, 200, 255 without a color map),
    /// has_colors (bool), outline (H, W) int8 (signed distance from each texel centre to the
    /// faces' outline, 127 = 2 texels, positive inside), world_from_patch (4, 4),
    /// origin (3,), axes (3, 3) (rows x, y, z), extent (3,), faces and ring_faces (uint32),
    /// error_bound (H + 1, W + 1) float64 per cell from cell -1, or None.
    fn patch<'py>(
        &self,
        py: Python<'py>,
        index: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let index = integer(index, "index", i64::MIN..=i64::MAX)?;
        let n = self.inner.patches.len() as i64;
        let i = if index < 0 { index + n } else { index };
        if !(0..n).contains(&i) {
            return Err(pyo3::exceptions::PyIndexError::new_err(format!(
                "patch index {index} out of range for {n} patches"
            )));
        }
        patch_dict(py, &self.inner.patches[i as usize])
    }

    /// Every texel holding surface (a height, and its centre inside the outline) as a world
    /// point: ((N, 3) float64 points, (N, 3) float32 unit normals).
    fn to_points<'py>(&self, py: Python<'py>) -> ArrayPair<'py, PyArray2<f64>, PyArray2<f32>> {
        let inner = self.inner.clone();
        let (p, n) = heavy(
            py,
            "collecting texel points",
            move |_| Ok(inner.to_points()),
        )?;
        let k = p.len();
        Ok((
            matrix(py, p.into_flattened(), k, 3),
            matrix(py, n.into_flattened(), k, 3),
        ))
    }

    /// Exact first hits of world rays on the set's surface, computed on the CPU in f64 (the
    /// reference the GPU searches are tested against): ((N,) float64 distances along the rays,
    /// +inf on a miss; (N,) int32 patch indices, -1 on a miss, -2 on a hybrid set's triangles).
    /// Directions must be unit vectors.
    fn first_hits<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
    ) -> ArrayPair<'py, PyArray1<f64>, PyArray1<i32>> {
        let rays = rays(origins, directions)?;
        let inner = self.inner.clone();
        let hits = heavy(py, "casting rays on the CPU", move |cancel| {
            crate::heightfield::first_hits(&inner, &rays, cancel)
        })?;
        let (t, k): (Vec<f64>, Vec<i32>) = hits.into_iter().unzip();
        Ok((PyArray1::from_vec(py, t), PyArray1::from_vec(py, k)))
    }

    /// The set as the bytes of a .gtex file (what `save` writes): exact, checksummed, and how
    /// the set is pickled.
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        let inner = self.inner.clone();
        let bytes = py.detach(move || crate::gtex::file::encode(&inner));
        PyBytes::new(py, &bytes)
    }

    /// A set from the bytes of a .gtex file (`to_bytes`, or a file read by the caller);
    /// FormatError for anything that is not an intact one.
    #[staticmethod]
    fn from_bytes(py: Python<'_>, data: &[u8]) -> PyResult<Self> {
        let set = py
            .detach(|| crate::gtex::file::decode(data))
            .map_err(|e| GeomtexError::Format(format!("GeometryTextureSet.from_bytes: {e}")))?;
        Ok(PyGeometryTextureSet::wrap(set))
    }

    /// The surfel hierarchy of this set: every surface texel a surfel, tiles of `tile` x `tile`
    /// texels (a power of two up to 64, default 8) merged 2x2 per level.
    #[pyo3(signature = (tile = None))]
    fn to_surfels(
        &self,
        py: Python<'_>,
        tile: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<super::surfels::PySurfels> {
        super::surfels::to_surfels(py, self, tile)
    }

    /// Writes a .gtex file atomically (no half file is ever left behind).
    fn save(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = self::path(path, "path")?;
        let inner = self.inner.clone();
        heavy(py, "saving", move |_| inner.save(&path))
    }

    /// A copy with every height map filtered: "gaussian" (low-pass) or "high_pass" (unsharp
    /// masking, h + gain (h - gaussian h); `gain` is refused for "gaussian"); `sigma` in world
    /// units. Normals are filtered by the same weights in world space.
    #[pyo3(signature = (kind, sigma, *, gain = None))]
    fn filtered(
        &self,
        py: Python<'_>,
        kind: &Bound<'_, PyAny>,
        sigma: &Bound<'_, PyAny>,
        gain: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let kind = opt_text(Some(kind), "kind")?.unwrap_or_default();
        let filter = MapFilter::from_name(&kind, opt_real(gain, "gain")?)?;
        let sigma = real(sigma, "sigma")?;
        let inner = self.inner.clone();
        let set = heavy(py, "filtering", move |cancel| {
            crate::filters::filtered(&inner, filter, sigma, cancel)
        })?;
        Ok(Self::wrap(set))
    }

    /// Gaps (world units, float64) between neighbouring patches at points along their charts'
    /// shared edges of `mesh` (the mesh the set was converted from; another mesh is refused).
    fn seam_gaps<'py>(
        &self,
        py: Python<'py>,
        mesh: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let seams = self.seams(py, mesh)?;
        Ok(PyArray1::from_vec(py, seams.gaps))
    }

    /// Angles (degrees, float64) between the normals two neighbouring patches show at the same
    /// points as `seam_gaps`: the shading step where they meet.
    fn seam_normal_steps<'py>(
        &self,
        py: Python<'py>,
        mesh: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let seams = self.seams(py, mesh)?;
        Ok(PyArray1::from_vec(py, seams.normal_steps))
    }

    /// Builds a set from height grids already checked and colored by `geomtex._grids.prepare`
    /// (`GeometryTextureSet.from_heightmaps` is the public entry).
    #[staticmethod]
    #[pyo3(signature = (prepared, *, max_resolution = None, height_bits = None))]
    fn _from_prepared_grids(
        py: Python<'_>,
        prepared: Vec<PreparedGrid<'_>>,
        max_resolution: Option<&Bound<'_, PyAny>>,
        height_bits: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let any = i64::MIN..=i64::MAX;
        let max_resolution = opt_integer(max_resolution, "max_resolution", any.clone())?;
        let height_bits = opt_integer(height_bits, "height_bits", any)?;
        let grids: Vec<HeightGrid> = prepared.iter().map(height_grid).collect();
        let set = heavy(py, "building patches from height grids", move |_| {
            crate::grids::from_grids(&grids, max_resolution, height_bits)
        })?;
        Ok(Self::wrap(set))
    }

    /// A copy of the set whose patches carry error-bound maps made from per-cell bounds (one
    /// (h + 1, w + 1) float64 array of world bounds per patch, rows from cell -1, or None for no
    /// map): for tests of what frames make of the maps before conversion computes them.
    fn _with_cell_bounds(
        &self,
        cell_bounds: Vec<Option<PyReadonlyArray2<'_, f64>>>,
    ) -> PyResult<Self> {
        let mut set = (**self.payload()).clone();
        if cell_bounds.len() != set.patches.len() {
            return Err(GeomtexError::Parameter(format!(
                "one bound array (or None) per patch: {} patches, {} given",
                set.patches.len(),
                cell_bounds.len()
            ))
            .into());
        }
        for (p, cells) in set.patches.iter_mut().zip(&cell_bounds) {
            p.error_bound = match cells {
                None => None,
                Some(a) => {
                    let fits = a.shape() == [p.height as usize + 1, p.width as usize + 1];
                    let values = a.as_slice().map(<[f64]>::to_vec).unwrap_or_default();
                    if !fits || values.iter().any(|v| !v.is_finite() || *v < 0.0) {
                        return Err(GeomtexError::Parameter(format!(
                            "a patch of {}x{} texels takes a ({}, {}) contiguous array of finite \
                             bounds >= 0",
                            p.width,
                            p.height,
                            p.height + 1,
                            p.width + 1
                        ))
                        .into());
                    }
                    Some(crate::gtex::ErrorBoundMap::for_patch(p, &values))
                }
            };
        }
        set.sync_error_bound_stats();
        Ok(Self::wrap(set))
    }

    fn __repr__(&self) -> String {
        let s = &self.inner;
        let triangles = (s.triangles.as_ref())
            .map(|t| format!(", {} triangles", t.mesh().faces.len()))
            .unwrap_or_default();
        format!(
            "<geomtex.GeometryTextureSet {} patches, {} texels ({:.1}% empty), texel {:.4e}{triangles}>",
            s.patches.len(),
            s.texels(),
            100.0 * s.empty_texels() as f64 / s.texels().max(1) as f64,
            s.texel_size
        )
    }
}

/// One grid as `geomtex._grids.prepare` hands it over: heights (rows, cols), (x0, y0, dx, dy),
/// optional colors (rows, cols, 4).
type PreparedGrid<'py> = (
    PyReadonlyArray2<'py, f64>,
    (f64, f64, f64, f64),
    Option<PyReadonlyArray3<'py, u8>>,
);

fn height_grid((z, (x0, y0, dx, dy), colors): &PreparedGrid<'_>) -> HeightGrid {
    let shape = z.shape();
    HeightGrid {
        width: shape[1],
        height: shape[0],
        origin: DVec2::new(*x0, *y0),
        spacing: DVec2::new(*dx, *dy),
        z: flat(z),
        colors: colors.as_ref().map(|c| {
            let bytes = flat(c);
            bytes
                .chunks_exact(4)
                .map(|q| [q[0], q[1], q[2], q[3]])
                .collect()
        }),
    }
}

/// Refuses (ParameterError) a mesh that is not the set's source: another face count, or faces that do not lie
/// in the boxes of the patches that list them (sampled, 8 per patch; in-plane only, with a
/// 10% margin, since a filter refits boxes around a surface it moved).
fn check_source(set: &GeometryTextureSet, mesh: &crate::mesh::Mesh) -> PyResult<()> {
    // The mesh itself is fine; as an argument it contradicts the set, as the core words it.
    let not_source = |why: String| -> PyErr {
        GeomtexError::Parameter(format!("{why}: not the mesh it was converted from")).into()
    };
    let Some(faces) = set.stats.get("faces") else {
        return Err(not_source(
            "the set holds no source face count (built from grids?)".into(),
        ));
    };
    if faces as usize != mesh.faces.len() {
        return Err(not_source(format!(
            "mesh has {} faces, the set's source had {faces}",
            mesh.faces.len()
        )));
    }
    let (mut sampled, mut outside) = (0usize, Vec::new());
    for (k, p) in set.patches.iter().enumerate() {
        for &f in p.faces.iter().step_by(p.faces.len().div_ceil(8).max(1)) {
            let Some(face) = mesh.faces.get(f as usize) else {
                continue;
            };
            let centroid = face
                .iter()
                .map(|&v| mesh.positions[v as usize])
                .sum::<DVec3>()
                / 3.0;
            let l = p.world_to_local(centroid);
            sampled += 1;
            if !((-0.1..=1.1).contains(&l.x) && (-0.1..=1.1).contains(&l.y)) {
                outside.push((f, k));
            }
        }
    }
    if outside.len() * 10 > sampled {
        let (f, k) = outside[0];
        return Err(not_source(format!(
            "{} of {sampled} sampled faces lie outside the boxes of the patches that hold them \
             (face {f}, patch {k})",
            outside.len()
        )));
    }
    Ok(())
}

/// Loads a .gtex file; FormatError if it is not one, is truncated, corrupt or of another version.
#[pyfunction]
pub fn load(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<PyGeometryTextureSet> {
    let path = self::path(path, "path")?;
    let set = heavy(py, "loading", move |_| GeometryTextureSet::load(&path))?;
    Ok(PyGeometryTextureSet::wrap(set))
}

/// Converts a mesh to geometry textures (see geomtex.convert for the keywords; every keyword left
/// as None takes the core's default).
#[pyfunction]
#[pyo3(signature = (mesh, *, max_resolution = None, texel_size = None, max_error = None,
    max_error_rel = None, error_scope = None, partition = None, cone_angle = None,
    chart_size = None, charts = None, chart_error = None, max_charts = None,
    compactness = None, lloyd_iterations = None, overlap_rings = None, dilation = None,
    frame = None, normals = None, crease_angle = None, height_bits = None, max_bytes = None,
    guarantee = None, hybrid = None, progress = None))]
#[allow(clippy::too_many_arguments)] // one per keyword of geomtex.convert
pub fn convert(
    py: Python<'_>,
    mesh: &Bound<'_, PyMesh>,
    max_resolution: Option<i64>,
    texel_size: Option<f64>,
    max_error: Option<f64>,
    max_error_rel: Option<f64>,
    error_scope: Option<&Bound<'_, PyAny>>,
    partition: Option<&Bound<'_, PyAny>>,
    cone_angle: Option<f64>,
    chart_size: Option<f64>,
    charts: Option<i64>,
    chart_error: Option<f64>,
    max_charts: Option<i64>,
    compactness: Option<f64>,
    lloyd_iterations: Option<i64>,
    overlap_rings: Option<i64>,
    dilation: Option<i64>,
    frame: Option<&Bound<'_, PyAny>>,
    normals: Option<&Bound<'_, PyAny>>,
    crease_angle: Option<f64>,
    height_bits: Option<i64>,
    max_bytes: Option<i64>,
    guarantee: Option<bool>,
    hybrid: Option<bool>,
    progress: Option<Py<PyAny>>,
) -> PyResult<PyGeometryTextureSet> {
    let options = ConvertArgs {
        max_resolution,
        texel_size,
        max_error,
        max_error_rel,
        error_scope: opt_text(error_scope, "error_scope")?
            .map(|s| s.parse())
            .transpose()?,
        partition: opt_text(partition, "partition")?
            .map(|s| s.parse())
            .transpose()?,
        cone_angle,
        chart_size,
        charts,
        chart_error,
        max_charts,
        compactness,
        lloyd_iterations,
        overlap_rings,
        dilation,
        frame: opt_text(frame, "frame")?.map(|s| s.parse()).transpose()?,
        normals: opt_text(normals, "normals")?
            .map(|s| s.parse())
            .transpose()?,
        crease_angle,
        height_bits,
        max_bytes,
        guarantee,
        hybrid,
    }
    .into_options()?;
    let set = convert_reporting(py, mesh.get().inner.clone(), &options, progress)?;
    Ok(PyGeometryTextureSet::wrap(set))
}

/// Runs a conversion with the GIL released, calling `progress(stage, fraction)` with the GIL
/// taken back (`with_progress`).
fn convert_reporting(
    py: Python<'_>,
    mesh: Arc<crate::mesh::Mesh>,
    options: &ConvertOptions,
    progress: Option<Py<PyAny>>,
) -> PyResult<GeometryTextureSet> {
    with_progress(py, "converting", progress, |p| {
        crate::convert::convert(&mesh, options, p)
    })
}

/// Runs `work` with the GIL released (`heavy`), its progress reports calling
/// `progress(stage, fraction)` with the GIL taken back. An exception raised by the callback
/// (KeyboardInterrupt from tqdm, say) stops the work and is re-raised as it was.
pub(crate) fn with_progress<T: Send>(
    py: Python<'_>,
    what: &str,
    progress: Option<Py<PyAny>>,
    work: impl FnOnce(Progress) -> crate::error::Result<T> + Send,
) -> PyResult<T> {
    let callback_error: Mutex<Option<PyErr>> = Mutex::new(None);
    let report = |stage: &str, fraction: f64| -> bool {
        let Some(callback) = &progress else {
            return true;
        };
        Python::attach(|py| match callback.call1(py, (stage, fraction)) {
            Ok(r) => r.is_none(py) || r.is_truthy(py).unwrap_or(true),
            Err(e) => {
                *callback_error.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
                false
            }
        })
    };
    let result = heavy(py, what, |cancel| work(Progress::new(&report, cancel)));
    let raised = callback_error
        .into_inner()
        .unwrap_or_else(|p| p.into_inner());
    result.map_err(|e| raised.unwrap_or(e))
}
