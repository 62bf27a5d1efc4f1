//! Bindings of `Surfels` (surfel hierarchies), `GeometryTextureSet.to_surfels` and
//! `load_surfels`: arrays and errors only.

use std::sync::Arc;

use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

use super::args::{integer, path};
use super::arrays::{matrix, rows};
use super::drawn::{Drawn, Holds};
use super::errors::heavy;
use super::set::PyGeometryTextureSet;
use crate::error::GeomtexError;
use crate::surfel_data::{SurfelHierarchy, DEFAULT_TILE};
use crate::surfels::file;

/// A surfel hierarchy over a geometry-texture set: every surface texel a surfel, tiles of
/// `tile` x `tile` texels merged 2x2 per level (level 0 finest). Render it like a set
/// (`Renderer.render(surfels, camera, max_pixel_error=1.0)`, `Scene.add(surfels)`).
#[pyclass(name = "Surfels", module = "geomtex._core", frozen)]
pub struct PySurfels {
    pub(crate) inner: Arc<SurfelHierarchy>,
}

/// How a Scene takes surfels (python/kinds.rs).
pub(crate) const DRAWN: Drawn = Drawn::of::<PySurfels>("Surfels", "surfels");

impl Holds for PySurfels {
    type Payload = SurfelHierarchy;
    const NO_NORMALS: &'static str = "Surfels take their set's normals";
    fn payload(&self) -> &Arc<SurfelHierarchy> {
        &self.inner
    }
    fn holding(inner: Arc<SurfelHierarchy>) -> Self {
        PySurfels { inner }
    }
}

impl PySurfels {
    fn wrap(h: SurfelHierarchy) -> Self {
        PySurfels { inner: Arc::new(h) }
    }
}

/// The hierarchy of `set` with tiles of `tile` texels a side (the core's default when None).
pub fn to_surfels(
    py: Python<'_>,
    set: &PyGeometryTextureSet,
    tile: Option<&Bound<'_, PyAny>>,
) -> PyResult<PySurfels> {
    let tile = match tile {
        Some(t) => integer(t, "tile", i64::MIN..=i64::MAX)?,
        None => DEFAULT_TILE as i64,
    };
    let tile = crate::surfel_data::check_tile(tile)?;
    let source = set.inner.clone();
    let h = heavy(py, "building surfels", move |_| {
        SurfelHierarchy::build(source, tile)
    })?;
    Ok(PySurfels::wrap(h))
}

#[pymethods]
impl PySurfels {
    /// Tile side in texels (a power of two up to 64).
    #[getter]
    fn tile(&self) -> u32 {
        self.inner.tile
    }

    /// Levels per tile: log2(tile) + 1.
    #[getter]
    fn levels(&self) -> u32 {
        self.inner.levels
    }

    /// (N, 3) float64 world positions of every surfel, tile by tile, each tile level by level.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let p: Vec<[f64; 3]> = self
            .inner
            .surfels
            .iter()
            .map(|s| s.position.to_array())
            .collect();
        rows(py, &p)
    }

    /// (N, 3) float32 world unit normals.
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        let n: Vec<[f32; 3]> = (self.inner.surfels.iter())
            .map(|s| s.normal.as_vec3().to_array())
            .collect();
        rows(py, &n)
    }

    /// (N,) float64 disc radii (world units).
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_iter(py, self.inner.surfels.iter().map(|s| s.radius))
    }

    /// (N, 4) uint8 RGBA colors.
    #[getter]
    fn colors<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u8>> {
        let c: Vec<[u8; 4]> = self.inner.surfels.iter().map(|s| s.color).collect();
        rows(py, &c)
    }

    /// (N,) int32 level of each surfel (0 = finest).
    #[getter]
    fn level<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i32>> {
        PyArray1::from_iter(py, self.inner.surfels.iter().map(|s| s.level as i32))
    }

    /// (N,) int64 index of each surfel's parent one level up, -1 at the top level.
    #[getter]
    fn parent<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let p = self.inner.surfels.iter().map(|s| {
            if s.parent == u32::MAX {
                -1
            } else {
                s.parent as i64
            }
        });
        PyArray1::from_iter(py, p)
    }

    /// (N,) int32 tile of each surfel.
    #[getter]
    fn tile_of<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i32>> {
        PyArray1::from_iter(py, self.inner.surfel_tiles().into_iter().map(|t| t as i32))
    }

    /// (T,) int32 patch of each tile.
    #[getter]
    fn tile_patch<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i32>> {
        PyArray1::from_iter(py, self.inner.tiles.iter().map(|t| t.patch as i32))
    }

    /// (T, levels + 1) int64: tile t's surfels of level l are `start[t, l]:start[t, l + 1]`.
    #[getter]
    fn tile_start<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        let h = &self.inner;
        let flat = h
            .tiles
            .iter()
            .flat_map(|t| t.start.iter().map(|&s| s as i64));
        matrix(py, flat.collect(), h.tiles.len(), h.levels as usize + 1)
    }

    /// (T, levels) float64 perpendicular error of each tile's levels (world units).
    #[getter]
    fn tile_error<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let h = &self.inner;
        let flat = h.tiles.iter().flat_map(|t| t.error.iter().copied());
        matrix(py, flat.collect(), h.tiles.len(), h.levels as usize)
    }

    /// (T, levels, 4) float64 normal cone of each tile's levels: unit axis xyz, half angle
    /// (radians).
    #[getter]
    fn tile_cone<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        let h = &self.inner;
        let flat: Vec<f64> = (h.tiles.iter())
            .flat_map(|t| t.cone.iter().flat_map(|(a, angle)| [a.x, a.y, a.z, *angle]))
            .collect();
        let shape = (h.tiles.len(), h.levels as usize, 4);
        numpy::ndarray::Array3::from_shape_vec(shape, flat)
            .expect("tiles x levels x 4")
            .into_pyarray(py)
    }

    /// The quadtree above the tiles as arrays (M nodes, T tiles): position (M, 3), normal
    /// (M, 3) and radius (M,) of each node's surfel, level (M,) (counting on from the tiles'
    /// top level), parent (M,) (-1 at a root), error (M,) (world units), cone (M, 4) (unit
    /// axis, half angle of the tiles' top-level normals below), sphere (M, 4) (centre, radius), and
    /// tile_parent (T,) (each tile's node, -1 where none).
    #[getter]
    fn nodes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let h = &self.inner;
        let index = |i: u32| if i == u32::MAX { -1 } else { i as i64 };
        let n = &h.nodes;
        let d = PyDict::new(py);
        let pos: Vec<[f64; 3]> = n.iter().map(|n| n.surfel.position.to_array()).collect();
        let normal: Vec<[f64; 3]> = n.iter().map(|n| n.surfel.normal.to_array()).collect();
        let cone: Vec<[f64; 4]> = n
            .iter()
            .map(|n| n.cone.0.extend(n.cone.1).to_array())
            .collect();
        let sphere: Vec<[f64; 4]> = n
            .iter()
            .map(|n| n.centre.extend(n.bound).to_array())
            .collect();
        d.set_item("position", rows(py, &pos))?;
        d.set_item("normal", rows(py, &normal))?;
        d.set_item(
            "radius",
            PyArray1::from_iter(py, n.iter().map(|n| n.surfel.radius)),
        )?;
        d.set_item(
            "level",
            PyArray1::from_iter(py, n.iter().map(|n| n.surfel.level as i32)),
        )?;
        d.set_item(
            "parent",
            PyArray1::from_iter(py, n.iter().map(|n| index(n.parent))),
        )?;
        d.set_item("error", PyArray1::from_iter(py, n.iter().map(|n| n.error)))?;
        d.set_item("cone", rows(py, &cone))?;
        d.set_item("sphere", rows(py, &sphere))?;
        let tile_parent = h.tiles.iter().map(|t| index(t.parent));
        d.set_item("tile_parent", PyArray1::from_iter(py, tile_parent))?;
        Ok(d)
    }

    /// tile, levels, tiles, surfels, surfels_per_level (finest first), nodes and nodes_per_level
    /// (the quadtree above the tiles, lowest level first), bytes (GPU records).
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let h = &self.inner;
        let d = PyDict::new(py);
        d.set_item("tile", h.tile)?;
        d.set_item("levels", h.levels)?;
        d.set_item("tiles", h.tiles.len())?;
        d.set_item("surfels", h.surfels.len())?;
        d.set_item("surfels_per_level", h.per_level())?;
        d.set_item("nodes", h.nodes.len())?;
        d.set_item("nodes_per_level", h.nodes_per_level())?;
        d.set_item("bytes", h.gpu_bytes())?;
        Ok(d)
    }

    /// The set the hierarchy was built from.
    #[getter]
    fn source(&self) -> PyGeometryTextureSet {
        PyGeometryTextureSet {
            inner: self.inner.source.clone(),
        }
    }

    /// Writes a .gtsurf file atomically: the source set and the tile size (the hierarchy is
    /// rebuilt, deterministically, on load).
    fn save(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = self::path(path, "path")?;
        let inner = self.inner.clone();
        heavy(py, "saving", move |_| inner.save(&path))
    }

    /// The bytes of the .gtsurf file `save` writes.
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        let inner = self.inner.clone();
        let bytes = py.detach(move || file::encode(&inner));
        PyBytes::new(py, &bytes)
    }

    /// A hierarchy from the bytes of a .gtsurf file; FormatError for anything not an intact one.
    #[staticmethod]
    fn from_bytes(py: Python<'_>, data: &[u8]) -> PyResult<Self> {
        let h = py
            .detach(|| file::decode(data))
            .map_err(|e| GeomtexError::Format(format!("Surfels.from_bytes: {e}")))?;
        Ok(PySurfels::wrap(h))
    }

    fn __len__(&self) -> usize {
        self.inner.surfels.len()
    }

    fn __repr__(&self) -> String {
        let h = &self.inner;
        format!(
            "<geomtex.Surfels {} surfels in {} tiles of {}x{} texels, {} levels>",
            h.surfels.len(),
            h.tiles.len(),
            h.tile,
            h.tile,
            h.levels
        )
    }
}

/// Reads a .gtsurf file (FormatError if it is not an intact one).
#[pyfunction]
pub fn load_surfels(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<PySurfels> {
    let path = self::path(path, "path")?;
    let h = heavy(py, "loading", move |_| SurfelHierarchy::load(&path))?;
    Ok(PySurfels::wrap(h))
}
