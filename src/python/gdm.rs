//! Bindings of the generalized-displacement-map core (`gdm`): a volume class and the explicit
//! mesh of a shell. Arrays and errors only: the package's `geomtex.gdm` checks array-likes and
//! builds the user-facing classes over these.

use std::sync::Arc;

use glam::{DVec2, DVec3};
use numpy::ndarray::{Array3, Array4, Array5};
use numpy::{
    IntoPyArray, PyArray1, PyArray3, PyArray5, PyReadonlyArray1, PyReadonlyArray2,
    PyReadonlyArray3, PyReadonlyArray4, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use super::args::{opt_text, real};
use super::arrays::{flat, image, rows, ArrayPair};
use super::drawn::{Drawn, Holds};
use super::errors::heavy;
use super::gtex::with_progress;
use crate::error::{parse_choice, GeomtexError};
use crate::gdm::{distance_function, lower_bound_function, Marcher, Seams, TileSurface};
use crate::gdm_data::{
    CompressedTable, GdmShell, Pattern, Shell, Volume, DEFAULT_PIECES, PATTERNS,
};

/// A mesostructure tile: an occupancy grid (x, y periodic), optional per-voxel RGBA.
#[pyclass(name = "GdmVolume", module = "geomtex._core", frozen)]
pub struct PyGdmVolume {
    pub(crate) inner: Arc<Volume>,
}

fn shape3(a: &[usize]) -> [usize; 3] {
    [a[0], a[1], a[2]]
}

#[pymethods]
impl PyGdmVolume {
    /// `occupancy` a C-ordered (nx, ny, nz) uint8 array (non-zero = solid); `colors` an
    /// (nx, ny, nz, 4) uint8 array or None.
    #[new]
    #[pyo3(signature = (occupancy, colors = None, check_seams = true))]
    fn new(
        occupancy: PyReadonlyArray3<'_, u8>,
        colors: Option<PyReadonlyArray4<'_, u8>>,
        check_seams: bool,
    ) -> PyResult<Self> {
        let size = shape3(occupancy.shape());
        let solid = flat(&occupancy).into_iter().map(|v| v != 0).collect();
        let colors = match colors {
            Some(c) => {
                if c.shape() != [size[0], size[1], size[2], 4] {
                    return Err(GeomtexError::Parameter(format!(
                        "colors must have shape {:?} + (4,), got {:?}",
                        size,
                        c.shape()
                    ))
                    .into());
                }
                let v = flat(&c);
                Some(
                    v.chunks_exact(4)
                        .map(|p| [p[0], p[1], p[2], p[3]])
                        .collect(),
                )
            }
            None => None,
        };
        let volume = Volume::new(size, solid, colors, check_seams)?;
        Ok(PyGdmVolume {
            inner: Arc::new(volume),
        })
    }

    /// A built-in tile: "chain", "weave" or "lattice", at `size` (nx, ny, nz) voxels.
    #[staticmethod]
    fn procedural(pattern: &Bound<'_, PyAny>, size: (usize, usize, usize)) -> PyResult<Self> {
        let name = opt_text(Some(pattern), "pattern")?.unwrap_or_default();
        let pattern: Pattern = parse_choice("pattern", &name, &PATTERNS)?;
        let volume = Volume::procedural(pattern, [size.0, size.1, size.2])?;
        Ok(PyGdmVolume {
            inner: Arc::new(volume),
        })
    }

    /// (nx, ny, nz).
    #[getter]
    fn size(&self) -> (usize, usize, usize) {
        let [x, y, z] = self.inner.size;
        (x, y, z)
    }

    /// (nx, ny, nz) bool occupancy.
    #[getter]
    fn occupancy<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<bool>> {
        let [x, y, z] = self.inner.size;
        Array3::from_shape_vec((x, y, z), self.inner.solid.clone())
            .expect("sized")
            .into_pyarray(py)
    }

    /// (nx*ny*nz, 4) uint8 colors, x-major, or None.
    #[getter]
    fn colors<'py>(&self, py: Python<'py>) -> Option<Bound<'py, numpy::PyArray2<u8>>> {
        self.inner.colors.as_ref().map(|c| rows(py, c))
    }

    /// (nx, ny, nz) uint8 Chebyshev distance (voxels, capped at 255) to the nearest solid voxel.
    fn empty_radius<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<u8>> {
        let [x, y, z] = self.inner.size;
        Array3::from_shape_vec((x, y, z), self.inner.empty_radius())
            .expect("sized")
            .into_pyarray(py)
    }

    /// The exact march of (N, 3) float64 rays in texture space (voxel units, unit directions):
    /// (t float64, hit bool) per ray, t capped at `max_t`.
    #[pyo3(signature = (origins, directions, max_t = None))]
    fn march<'py>(
        &self,
        py: Python<'py>,
        origins: PyReadonlyArray2<'_, f64>,
        directions: PyReadonlyArray2<'_, f64>,
        max_t: Option<&Bound<'_, PyAny>>,
    ) -> ArrayPair<'py, PyArray1<f64>, PyArray1<bool>> {
        let max_t = max_t.map(|m| real(m, "max_t")).transpose()?;
        let o = flat(&origins);
        let d = flat(&directions);
        if o.len() != d.len() || !o.len().is_multiple_of(3) {
            return Err(GeomtexError::Parameter(
                "origins and directions must both be (N, 3)".into(),
            )
            .into());
        }
        let volume = self.inner.clone();
        let ends = heavy(py, "marching rays", move |_| {
            let m = Marcher::new(&volume);
            let limit = max_t.unwrap_or(f64::INFINITY);
            Ok(o.chunks_exact(3)
                .zip(d.chunks_exact(3))
                .map(|(o, d)| m.march(DVec3::from_slice(o), DVec3::from_slice(d), limit))
                .collect::<Vec<_>>())
        })?;
        Ok((
            PyArray1::from_iter(py, ends.iter().map(|e| e.t)),
            PyArray1::from_iter(py, ends.iter().map(|e| e.hit)),
        ))
    }

    /// The 5D distance function at `directions` = (theta, phi) counts: (distance float32, hit
    /// bool), both of shape (nx, ny, nz, theta, phi), distances in voxels. With `lower_bound`,
    /// each entry is instead a lower bound over the lookup's interpolation footprint (bound.rs).
    #[pyo3(signature = (directions, progress = None, lower_bound = false))]
    fn distance_function<'py>(
        &self,
        py: Python<'py>,
        directions: (usize, usize),
        progress: Option<Py<PyAny>>,
        lower_bound: bool,
    ) -> ArrayPair<'py, PyArray5<f32>, PyArray5<bool>> {
        let volume = self.inner.clone();
        let counts = [directions.0, directions.1];
        let table = with_progress(py, "computing a distance function", progress, move |p| {
            if lower_bound {
                lower_bound_function(&volume, counts, p)
            } else {
                distance_function(&volume, counts, p)
            }
        })?;
        let [x, y, z] = table.size;
        let shape = (x, y, z, counts[0], counts[1]);
        let d = Array5::from_shape_vec(shape, table.distance).expect("sized");
        let h = Array5::from_shape_vec(shape, table.hit).expect("sized");
        Ok((d.into_pyarray(py), h.into_pyarray(py)))
    }
}

fn points(a: &PyReadonlyArray2<'_, f64>) -> Vec<DVec3> {
    flat(a).chunks_exact(3).map(DVec3::from_slice).collect()
}

fn triangles(a: &PyReadonlyArray2<'_, u32>) -> Vec<[u32; 3]> {
    flat(a)
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect()
}

/// A shell from the package's checked arrays: (V, 3) positions and unit normals, (F, 3) faces,
/// (F, 3, 2) texture coordinates in tiles.
fn shell_of(
    positions: &PyReadonlyArray2<'_, f64>,
    normals: &PyReadonlyArray2<'_, f64>,
    faces: &PyReadonlyArray2<'_, u32>,
    uv: &PyReadonlyArray3<'_, f64>,
    thickness: f64,
    size: [usize; 3],
) -> PyResult<Shell> {
    let shell = Shell {
        positions: points(positions),
        normals: points(normals),
        faces: triangles(faces),
        uv: flat(uv)
            .chunks_exact(6)
            .map(|c| std::array::from_fn(|k| DVec2::new(c[2 * k], c[2 * k + 1])))
            .collect(),
        thickness,
        size,
    };
    let checks = [
        shell.normals.len() == shell.positions.len(),
        shell.uv.len() == shell.faces.len(),
        (shell.faces.iter().flatten()).all(|&k| (k as usize) < shell.positions.len()),
        thickness.is_finite() && thickness > 0.0,
    ];
    if checks.contains(&false) {
        return Err(GeomtexError::Parameter(
            "shell: normals, uv, faces or thickness do not fit the base mesh".into(),
        )
        .into());
    }
    Ok(shell)
}

/// SVD terms from the package's (nx, ny, phi, k) weights and (k, theta, nz) eigen-maps.
fn table_of(
    weights: &PyReadonlyArray4<'_, f32>,
    eigen: &PyReadonlyArray3<'_, f32>,
    refine: f32,
    bound: bool,
    size: [usize; 3],
) -> PyResult<CompressedTable> {
    if bound && refine != 0.0 {
        return Err(GeomtexError::Parameter(
            "lookup: a conservative table is followed by the exact march; refine must be 0".into(),
        )
        .into());
    }
    if !(0.0..=64.0).contains(&refine) {
        return Err(GeomtexError::Parameter(format!(
            "lookup: refine must be 0..=64 voxels, got {refine}"
        ))
        .into());
    }
    let (w, e) = (weights.shape(), eigen.shape());
    if w[..2] != size[..2] || e[2] != size[2] || w[3] != e[0] || w[3] == 0 || w[2] == 0 || e[1] == 0
    {
        return Err(GeomtexError::Parameter(format!(
            "lookup: weights {w:?} and eigen-maps {e:?} do not fit a {size:?} volume"
        ))
        .into());
    }
    Ok(CompressedTable {
        directions: [e[1], w[2]],
        k: w[3],
        weights: flat(weights),
        eigen: flat(eigen),
        refine,
        bound,
    })
}

/// A shell the renderer draws: prisms over a base mesh carrying a volume (see geomtex.gdm.Shell).
#[pyclass(name = "GdmShell", module = "geomtex._core", frozen)]
pub struct PyGdmShell {
    pub(crate) inner: Arc<GdmShell>,
}

/// How a Scene takes a displacement shell (python/kinds.rs).
pub(crate) const DRAWN: Drawn = Drawn::of::<PyGdmShell>("GdmShell", "GDM shells");

impl Holds for PyGdmShell {
    type Payload = GdmShell;
    const NO_NORMALS: &'static str = "a shell's normals come from its volume";
    fn payload(&self) -> &Arc<GdmShell> {
        &self.inner
    }
    fn holding(inner: Arc<GdmShell>) -> Self {
        PyGdmShell { inner }
    }
}

#[pymethods]
impl PyGdmShell {
    #[new]
    #[pyo3(signature = (positions, normals, faces, uv, thickness, volume, color, pieces = None,
        lookup = None, count_steps = false))]
    #[allow(clippy::too_many_arguments)] // the shell's parts, as the package's Shell holds them
    fn new(
        positions: PyReadonlyArray2<'_, f64>,
        normals: PyReadonlyArray2<'_, f64>,
        faces: PyReadonlyArray2<'_, u32>,
        uv: PyReadonlyArray3<'_, f64>,
        thickness: f64,
        volume: &PyGdmVolume,
        color: (u8, u8, u8, u8),
        pieces: Option<u32>,
        lookup: Option<(
            PyReadonlyArray4<'_, f32>,
            PyReadonlyArray3<'_, f32>,
            f32,
            bool,
        )>,
        count_steps: bool,
    ) -> PyResult<Self> {
        let volume = volume.inner.clone();
        let volume_size = volume.size;
        let shell = shell_of(&positions, &normals, &faces, &uv, thickness, volume.size)?;
        let pieces = pieces.unwrap_or(DEFAULT_PIECES);
        if !(1..=64).contains(&pieces) {
            return Err(
                GeomtexError::Parameter(format!("pieces must be in 1..=64, got {pieces}")).into(),
            );
        }
        Ok(PyGdmShell {
            inner: Arc::new(GdmShell {
                shell,
                volume,
                color: [color.0, color.1, color.2, color.3],
                pieces,
                lookup: lookup
                    .map(|(w, e, refine, bound)| table_of(&w, &e, refine, bound, volume_size))
                    .transpose()?,
                count_steps,
            }),
        })
    }

    /// Prisms (base faces).
    #[getter]
    fn prisms(&self) -> usize {
        self.inner.shell.faces.len()
    }

    /// What the shell was made of, as `GdmShell(*state)` takes it again (for pickling):
    /// positions, normals, faces, uv, thickness, volume, color, pieces, lookup, count_steps.
    fn _state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let g = &self.inner;
        let s = &g.shell;
        let points = |v: &[DVec3]| rows(py, &v.iter().map(|p| p.to_array()).collect::<Vec<_>>());
        let uv: Vec<f64> = s.uv.iter().flatten().flat_map(|c| c.to_array()).collect();
        let uv = image(py, uv, (s.uv.len(), 3, 2));
        let volume = Py::new(
            py,
            PyGdmVolume {
                inner: g.volume.clone(),
            },
        )?;
        let lookup = match &g.lookup {
            None => py.None().into_bound(py),
            Some(t) => {
                let [nx, ny, nz] = g.volume.size;
                let [n_theta, n_phi] = t.directions;
                let weights = Array4::from_shape_vec((nx, ny, n_phi, t.k), t.weights.clone())
                    .expect("sized")
                    .into_pyarray(py);
                let eigen = image(py, t.eigen.clone(), (t.k, n_theta, nz));
                (weights, eigen, t.refine, t.bound)
                    .into_pyobject(py)?
                    .into_any()
            }
        };
        PyTuple::new(
            py,
            [
                points(&s.positions).into_any(),
                points(&s.normals).into_any(),
                rows(py, &s.faces).into_any(),
                uv.into_any(),
                s.thickness.into_pyobject(py)?.into_any(),
                volume.into_bound(py).into_any(),
                (g.color[0], g.color[1], g.color[2], g.color[3])
                    .into_pyobject(py)?
                    .into_any(),
                g.pieces.into_pyobject(py)?.into_any(),
                lookup,
                pyo3::types::PyBool::new(py, g.count_steps)
                    .to_owned()
                    .into_any(),
            ],
        )
    }
}

/// The explicit mesh of a shell: the tile's surface (vertices in voxel units over one period,
/// faces) clipped to each base face's prism and mapped into object space; (vertices, faces).
#[pyfunction]
#[allow(clippy::too_many_arguments)] // the shell's parts, as the package's Shell holds them
pub fn gdm_explicit_mesh<'py>(
    py: Python<'py>,
    positions: PyReadonlyArray2<'_, f64>,
    normals: PyReadonlyArray2<'_, f64>,
    faces: PyReadonlyArray2<'_, u32>,
    uv: PyReadonlyArray3<'_, f64>,
    thickness: f64,
    volume: &PyGdmVolume,
    tile_vertices: PyReadonlyArray2<'_, f64>,
    tile_faces: PyReadonlyArray2<'_, u32>,
    seam_fins: PyReadonlyArray1<'_, u8>,
) -> ArrayPair<'py, numpy::PyArray2<f64>, numpy::PyArray2<u32>> {
    let volume = volume.inner.clone();
    let size = volume.size;
    let shell = shell_of(&positions, &normals, &faces, &uv, thickness, size)?;
    let tile = TileSurface::new(points(&tile_vertices), triangles(&tile_faces), size)?;
    let fins = seam_fins.as_slice()?.to_vec();
    if fins.len() != shell.faces.len() {
        return Err(GeomtexError::Parameter(format!(
            "seam_fins holds {} faces but the base mesh has {}",
            fins.len(),
            shell.faces.len()
        ))
        .into());
    }
    let (v, f) = heavy(py, "building a shell's explicit mesh", move |_| {
        let seams = Seams {
            volume: &volume,
            fins: &fins,
        };
        Ok(shell.explicit_mesh(&tile, Some(&seams)))
    })?;
    let v: Vec<[f64; 3]> = v.iter().map(|p| p.to_array()).collect();
    Ok((rows(py, &v), rows(py, &f)))
}
