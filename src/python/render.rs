//! Bindings for the renderer: Camera, Scene, Renderer and Frame.

use std::sync::Mutex;

use glam::{DMat4, DVec3};
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

use super::{parameter_error, to_py_err, PyGeometryTextureSet, PyMesh};
use crate::render::{
    Camera, Method, Object, Projection, Renderer, Scene, SceneObject, SearchOverrides,
};

fn mat4(a: Option<PyReadonlyArray2<'_, f64>>, what: &str) -> PyResult<DMat4> {
    let Some(a) = a else {
        return Ok(DMat4::IDENTITY);
    };
    if a.shape() != [4, 4] {
        return Err(parameter_error(format!(
            "{what} must be a 4x4 matrix, got shape {:?}",
            a.shape()
        )));
    }
    let a = a.as_array();
    // numpy is row-major: column c of the matrix is a[.., c].
    Ok(DMat4::from_cols_array_2d(&std::array::from_fn(|c| {
        std::array::from_fn(|r| a[[r, c]])
    })))
}

fn to_numpy4(m: DMat4, py: Python<'_>) -> Bound<'_, PyArray2<f64>> {
    let rows: Vec<f64> = m.transpose().to_cols_array().to_vec();
    Array2::from_shape_vec((4, 4), rows)
        .unwrap()
        .into_pyarray(py)
}

/// A camera: OpenGL-style pose (looks down -Z, +Y up) as pyrender and trimesh use; see
/// `look_at`, `from_intrinsics` (OpenCV) and `orthographic`.
#[pyclass(name = "Camera", module = "geomtex._core", frozen)]
pub struct PyCamera {
    pub(crate) inner: Camera,
}

#[pymethods]
impl PyCamera {
    /// Perspective camera at `eye` looking at `target`; `yfov_deg` is the vertical field of view.
    #[staticmethod]
    #[pyo3(signature = (eye, target, up = (0.0, 1.0, 0.0), yfov_deg = 45.0, near = None),
        text_signature = "(eye, target, up=(0.0, 1.0, 0.0), yfov_deg=45.0, near=None)")]
    fn look_at(
        eye: [f64; 3],
        target: [f64; 3],
        up: (f64, f64, f64),
        yfov_deg: f64,
        near: Option<f64>,
    ) -> PyResult<Self> {
        let mut c = Camera::look_at(
            DVec3::from_array(eye),
            DVec3::from_array(target),
            DVec3::new(up.0, up.1, up.2),
            yfov_deg,
        )
        .map_err(to_py_err)?;
        c.near = checked_near(near)?;
        Ok(PyCamera { inner: c })
    }

    /// OpenCV intrinsics K (3x3) with an OpenCV camera-to-world pose (looks down +Z, +Y down), for
    /// an image of width x height.
    #[staticmethod]
    #[pyo3(signature = (K, world_from_camera, width, height, near = None))]
    #[allow(non_snake_case)]
    fn from_intrinsics(
        K: PyReadonlyArray2<'_, f64>,
        world_from_camera: PyReadonlyArray2<'_, f64>,
        width: u32,
        height: u32,
        near: Option<f64>,
    ) -> PyResult<Self> {
        if K.shape() != [3, 3] {
            return Err(parameter_error(format!(
                "K must be 3x3, got shape {:?}",
                K.shape()
            )));
        }
        let k = K.as_array();
        let k: [[f64; 3]; 3] = std::array::from_fn(|r| std::array::from_fn(|c| k[[r, c]]));
        let mut c = Camera::from_intrinsics(
            k,
            mat4(Some(world_from_camera), "world_from_camera")?,
            width,
            height,
        )
        .map_err(to_py_err)?;
        c.near = checked_near(near)?;
        Ok(PyCamera { inner: c })
    }

    /// Orthographic camera with an OpenGL pose; `ymag` is half the view's height in world units.
    #[staticmethod]
    #[pyo3(signature = (world_from_camera, ymag, near = None))]
    fn orthographic(
        world_from_camera: PyReadonlyArray2<'_, f64>,
        ymag: f64,
        near: Option<f64>,
    ) -> PyResult<Self> {
        let mut c = Camera::orthographic(mat4(Some(world_from_camera), "world_from_camera")?, ymag)
            .map_err(to_py_err)?;
        c.near = near;
        Ok(PyCamera { inner: c })
    }

    /// (4, 4) float64 OpenGL-style camera-to-world pose.
    #[getter]
    fn world_from_camera<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        to_numpy4(self.inner.world_from_camera, py)
    }

    /// "perspective", "intrinsics" or "orthographic".
    #[getter]
    fn kind(&self) -> &'static str {
        match self.inner.projection {
            Projection::Perspective { .. } => "perspective",
            Projection::Intrinsics { .. } => "intrinsics",
            Projection::Orthographic { .. } => "orthographic",
        }
    }

    /// World rays through every pixel centre of a width x height image: origins and unit
    /// directions, each (height, width, 3) float64, row 0 at the top. The renderer's own rays.
    fn rays<'py>(
        &self,
        py: Python<'py>,
        width: u32,
        height: u32,
    ) -> PyResult<(Bound<'py, PyArray3<f64>>, Bound<'py, PyArray3<f64>>)> {
        let (o, d) = self.inner.pixel_rays(width, height).map_err(to_py_err)?;
        let (o, d) = (o.concat(), d.concat());
        let shape = (height as usize, width as usize, 3);
        Ok((
            Array3::from_shape_vec(shape, o).unwrap().into_pyarray(py),
            Array3::from_shape_vec(shape, d).unwrap().into_pyarray(py),
        ))
    }

    /// The unit vector the camera looks along (its -Z axis in world space); z-depth is measured
    /// along it.
    #[getter]
    fn forward(&self) -> [f64; 3] {
        (-self.inner.world_from_camera.z_axis.truncate())
            .normalize()
            .to_array()
    }

    fn __repr__(&self) -> String {
        format!(
            "<geomtex.Camera {} at {:?}>",
            self.kind(),
            self.inner.eye().to_array()
        )
    }
}

fn panic_message(p: &Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<String>()
        .cloned()
        .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_default()
}

fn checked_near(near: Option<f64>) -> PyResult<Option<f64>> {
    match near {
        Some(n) if !(n.is_finite() && n > 0.0) => {
            Err(parameter_error(format!("near must be positive, got {n}")))
        }
        other => Ok(other),
    }
}

/// Geometry-texture sets and ordinary meshes, each placed by a world_from_object matrix.
#[pyclass(name = "Scene", module = "geomtex._core")]
#[derive(Default)]
pub struct PyScene {
    pub(crate) inner: Scene,
}

fn scene_object(obj: &Bound<'_, PyAny>, world_from_object: DMat4) -> PyResult<SceneObject> {
    let object = if let Ok(s) = obj.cast::<PyGeometryTextureSet>() {
        Object::Textures(s.get().inner.clone())
    } else if let Ok(m) = obj.cast::<PyMesh>() {
        Object::Mesh(m.get().inner.clone())
    } else {
        // trimesh and paths: let the Python side turn them into a Mesh.
        let mesh = obj
            .py()
            .import("geomtex._mesh")?
            .call_method1("as_mesh", (obj,))?;
        Object::Mesh(mesh.cast::<PyMesh>()?.get().inner.clone())
    };
    Ok(SceneObject {
        object,
        world_from_object,
    })
}

#[pymethods]
impl PyScene {
    #[new]
    fn new() -> Self {
        PyScene::default()
    }

    /// Adds a GeometryTextureSet or a Mesh (or trimesh) placed by `world_from_object` (4x4,
    /// default identity). Returns its index.
    #[pyo3(signature = (obj, world_from_object = None))]
    fn add(
        &mut self,
        obj: &Bound<'_, PyAny>,
        world_from_object: Option<PyReadonlyArray2<'_, f64>>,
    ) -> PyResult<usize> {
        let m = mat4(world_from_object, "world_from_object")?;
        self.inner.objects.push(scene_object(obj, m)?);
        Ok(self.inner.objects.len() - 1)
    }

    fn __len__(&self) -> usize {
        self.inner.objects.len()
    }

    fn __repr__(&self) -> String {
        let sets = self
            .inner
            .objects
            .iter()
            .filter(|o| matches!(o.object, Object::Textures(_)))
            .count();
        format!(
            "<geomtex.Scene {sets} texture sets, {} meshes>",
            self.inner.objects.len() - sets
        )
    }
}

/// A headless renderer of a fixed image size. Reuse it: the GPU device, render targets and
/// uploaded textures are kept between frames.
#[pyclass(name = "Renderer", module = "geomtex._core", frozen)]
pub struct PyRenderer {
    inner: Mutex<Renderer>,
    width: u32,
    height: u32,
}

#[pymethods]
impl PyRenderer {
    #[new]
    fn new(py: Python<'_>, width: i64, height: i64) -> PyResult<Self> {
        let (w, h) = (u32::try_from(width), u32::try_from(height));
        let (Ok(w), Ok(h)) = (w, h) else {
            return Err(parameter_error(format!(
                "image size {width}x{height} must be positive"
            )));
        };
        let r = py
            .detach(|| {
                std::panic::catch_unwind(|| Renderer::new(w, h)).unwrap_or_else(|p| {
                    Err(crate::error::GeomtexError::Device(format!(
                        "internal error creating the renderer: {}",
                        panic_message(&p)
                    )))
                })
            })
            .map_err(to_py_err)?;
        Ok(PyRenderer {
            inner: Mutex::new(r),
            width: w,
            height: h,
        })
    }

    #[getter]
    fn width(&self) -> u32 {
        self.width
    }

    #[getter]
    fn height(&self) -> u32 {
        self.height
    }

    /// The GPU adapter in use: name, backend, device_type, driver, driver_info.
    #[getter]
    fn adapter_info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in self.inner.lock().unwrap().info() {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    /// Renders a Scene, a GeometryTextureSet or a Mesh seen by `camera`.
    ///
    /// `quality` picks measured settings ("fast", "balanced" (default) or "exact"); `method`
    /// and the step keywords override them. `count_fetches` uses a counting build of the pipeline
    /// and reports height fetches per ray-cast fragment in `frame.stats`. `lod` (max-pyramid
    /// search only) stops each patch's descent where its nodes are about a pixel.
    #[pyo3(signature = (obj, camera, *, quality = None, method = None, steps_per_texel = None,
        min_linear_steps = None, max_linear_steps = None, binary_steps = None,
        max_traversal_steps = None, count_fetches = false, lod = false,
        background = (255, 255, 255, 0)),
        text_signature = "(self, /, obj, camera, *, quality=None, method=None, steps_per_texel=None, \
min_linear_steps=None, max_linear_steps=None, binary_steps=None, max_traversal_steps=None, \
count_fetches=False, lod=False, background=(255, 255, 255, 0))")]
    #[allow(clippy::too_many_arguments)]
    fn render(
        &self,
        py: Python<'_>,
        obj: &Bound<'_, PyAny>,
        camera: &PyCamera,
        quality: Option<&str>,
        method: Option<&str>,
        steps_per_texel: Option<f32>,
        min_linear_steps: Option<u32>,
        max_linear_steps: Option<u32>,
        binary_steps: Option<u32>,
        max_traversal_steps: Option<u32>,
        count_fetches: bool,
        lod: bool,
        background: (u8, u8, u8, u8),
    ) -> PyResult<PyFrame> {
        let search = SearchOverrides {
            quality: quality.map(str::parse).transpose().map_err(to_py_err)?,
            method: method.map(str::parse).transpose().map_err(to_py_err)?,
            steps_per_texel,
            min_linear_steps,
            max_linear_steps,
            binary_steps,
            max_traversal_steps,
            count_fetches: Some(count_fetches),
            lod: Some(lod),
        }
        .resolve()
        .map_err(to_py_err)?;
        let scene = match obj.cast::<PyScene>() {
            Ok(s) => s.borrow().inner.clone(),
            Err(_) => Scene {
                objects: vec![scene_object(obj, DMat4::IDENTITY)?],
            },
        };
        let cam = camera.inner;
        let frame = py
            .detach(|| {
                // A panic inside wgpu must not cross into Python: report it as a DeviceError.
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    let mut r = self.inner.lock().unwrap_or_else(|e| e.into_inner());
                    let b = background;
                    r.set_background(Some([b.0, b.1, b.2, b.3]));
                    r.render(&scene, &cam, &search)
                }))
                .unwrap_or_else(|p| {
                    Err(crate::error::GeomtexError::Device(format!(
                        "internal error while rendering: {}",
                        panic_message(&p)
                    )))
                })
            })
            .map_err(to_py_err)?;
        let (h, w) = (frame.height as usize, frame.width as usize);
        let stats = PyDict::new(py);
        stats.set_item("gpu_ms", frame.gpu_ms)?;
        stats.set_item("cpu_ms", frame.cpu_ms)?;
        stats.set_item("patches_drawn", frame.patches_drawn)?;
        stats.set_item("patches_culled", frame.patches_culled)?;
        stats.set_item("meshes_drawn", frame.meshes_drawn)?;
        stats.set_item("near", frame.near)?;
        stats.set_item(
            "method",
            if search.method == Method::MaxMip {
                "maxmip"
            } else {
                "linear_binary"
            },
        )?;
        if let Some((fetches, fragments)) = frame.fetches {
            stats.set_item("fetches", fetches)?;
            stats.set_item("raycast_fragments", fragments)?;
            stats.set_item(
                "fetches_per_pixel",
                fetches as f64 / fragments.max(1) as f64,
            )?;
        }
        Ok(PyFrame {
            color: Array3::from_shape_vec((h, w, 4), frame.color)
                .unwrap()
                .into_pyarray(py)
                .unbind(),
            depth: Array2::from_shape_vec((h, w), frame.depth)
                .unwrap()
                .into_pyarray(py)
                .unbind(),
            normal: Array3::from_shape_vec((h, w, 3), frame.normal)
                .unwrap()
                .into_pyarray(py)
                .unbind(),
            patch_id: Array2::from_shape_vec((h, w), frame.patch_id)
                .unwrap()
                .into_pyarray(py)
                .unbind(),
            stats: stats.unbind(),
        })
    }

    fn __repr__(&self) -> String {
        let name = self.inner.lock().unwrap().info()[0].1.clone();
        format!(
            "<geomtex.Renderer {}x{} on {name}>",
            self.width, self.height
        )
    }
}

/// One rendered image: numpy arrays, row 0 at the top.
#[pyclass(name = "Frame", module = "geomtex._core", frozen)]
pub struct PyFrame {
    color: Py<PyArray3<u8>>,
    depth: Py<PyArray2<f32>>,
    normal: Py<PyArray3<f32>>,
    patch_id: Py<PyArray2<i32>>,
    stats: Py<PyDict>,
}

#[pymethods]
impl PyFrame {
    /// (H, W, 4) uint8 RGBA, headlight-shaded; the background on a miss.
    #[getter]
    fn color(&self, py: Python<'_>) -> Py<PyArray3<u8>> {
        self.color.clone_ref(py)
    }

    /// (H, W) float32 z-depth: distance along the camera's forward axis in world units, +inf on
    /// a miss.
    #[getter]
    fn depth(&self, py: Python<'_>) -> Py<PyArray2<f32>> {
        self.depth.clone_ref(py)
    }

    /// (H, W, 3) float32 world-space unit normals, 0 on a miss.
    #[getter]
    fn normal(&self, py: Python<'_>) -> Py<PyArray3<f32>> {
        self.normal.clone_ref(py)
    }

    /// (H, W) int32: patch index (numbered across the scene's texture sets), -1 on a miss,
    /// -2 - k for the scene's k-th mesh.
    #[getter]
    fn patch_id(&self, py: Python<'_>) -> Py<PyArray2<i32>> {
        self.patch_id.clone_ref(py)
    }

    /// gpu_ms (GPU timestamps, None where unsupported), cpu_ms (the whole call), patches_drawn, patches_culled (boxes outside the view),
    /// meshes_drawn, near.
    #[getter]
    fn stats(&self, py: Python<'_>) -> Py<PyDict> {
        self.stats.clone_ref(py)
    }

    fn _repr_png_<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyBytes>> {
        let png = slf
            .py()
            .import("geomtex._preview")?
            .call_method1("frame_png", (slf,))?;
        Ok(png.cast_into::<PyBytes>()?)
    }

    /// Writes the color image as a PNG (atomically).
    fn save(slf: &Bound<'_, Self>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        slf.py()
            .import("geomtex._preview")?
            .call_method1("save_frame", (slf, path))?;
        Ok(())
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let shape = self.depth.bind(py).shape().to_vec();
        format!("<geomtex.Frame {}x{}>", shape[1], shape[0])
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyCamera>()?;
    m.add_class::<PyScene>()?;
    m.add_class::<PyRenderer>()?;
    m.add_class::<PyFrame>()?;
    Ok(())
}
