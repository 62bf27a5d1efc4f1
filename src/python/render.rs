//! Bindings of the renderer: Camera, Scene, Renderer and Frame. Presets, defaults and the
//! string→enum parsing live in `crate::render`; trimesh objects and paths are turned into meshes
//! by the Python package before they reach these classes.

use std::sync::{Arc, Mutex, MutexGuard};

use glam::{DMat4, DVec3};
use numpy::{PyArray1, PyArray2, PyArray3, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::args::{
    affine_mat4, image_size, mat3, opt_flag, opt_real, opt_text, opt_u32, rays, real, rgba8, vec3,
};
use super::arrays::{image, mat4_to_numpy, matrix, ArrayPair};
use super::errors::{heavy, parameter_error};
use super::gtex::set_stats;
use super::kinds;
use crate::error::GeomtexError;
use crate::mesh::{NormalRule, NormalSource};
use crate::render::cpu::CpuRenderer;
use crate::render::{
    check_image_size, Camera, FrameRequest, Light, Outputs, Projection, Quality, Renderer, Scene,
    SceneObject, SearchOverrides,
};

/// A camera: OpenGL-style pose (looks down -Z, +Y up) as pyrender and trimesh use; see
/// `look_at`, `from_intrinsics` (OpenCV) and `orthographic`.
#[pyclass(name = "Camera", module = "geomtex._core", frozen)]
pub struct PyCamera {
    pub(crate) inner: Camera,
}

#[pymethods]
impl PyCamera {
    /// Perspective camera at `eye` looking at `target`; `yfov_deg` is the vertical field of view
    /// (default 45), `up` defaults to +Y.
    #[staticmethod]
    #[pyo3(signature = (eye, target, up = None, yfov_deg = None, near = None))]
    fn look_at(
        eye: &Bound<'_, PyAny>,
        target: &Bound<'_, PyAny>,
        up: Option<&Bound<'_, PyAny>>,
        yfov_deg: Option<&Bound<'_, PyAny>>,
        near: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let up: Option<DVec3> = up.map(|u| vec3(u, "up")).transpose()?;
        let camera = Camera::look_at(
            vec3(eye, "eye")?,
            vec3(target, "target")?,
            up.unwrap_or(Camera::DEFAULT_UP),
            opt_real(yfov_deg, "yfov_deg")?.unwrap_or(Camera::DEFAULT_YFOV_DEG),
        )?;
        Ok(PyCamera {
            inner: camera.with_near(opt_real(near, "near")?)?,
        })
    }

    /// OpenCV intrinsics K (3x3) with an OpenCV camera-to-world pose (looks down +Z, +Y down), for
    /// an image of width x height.
    #[staticmethod]
    #[pyo3(signature = (K, world_from_camera, width, height, near = None))]
    #[allow(non_snake_case)] // K is the name every OpenCV user knows
    fn from_intrinsics(
        K: &Bound<'_, PyAny>,
        world_from_camera: &Bound<'_, PyAny>,
        width: &Bound<'_, PyAny>,
        height: &Bound<'_, PyAny>,
        near: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let world_from_camera = affine_mat4(Some(world_from_camera), "world_from_camera")?;
        let (width, height) = image_size(width, height)?;
        let camera = Camera::from_intrinsics(mat3(K, "K")?, world_from_camera, width, height)?;
        Ok(PyCamera {
            inner: camera.with_near(opt_real(near, "near")?)?,
        })
    }

    /// Orthographic camera with an OpenGL pose; `ymag` is half the view's height in world units.
    #[staticmethod]
    #[pyo3(signature = (world_from_camera, ymag, near = None))]
    fn orthographic(
        world_from_camera: &Bound<'_, PyAny>,
        ymag: &Bound<'_, PyAny>,
        near: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let world_from_camera = affine_mat4(Some(world_from_camera), "world_from_camera")?;
        let camera = Camera::orthographic(world_from_camera, real(ymag, "ymag")?)?;
        Ok(PyCamera {
            inner: camera.with_near(opt_real(near, "near")?)?,
        })
    }

    /// (4, 4) float64 OpenGL-style camera-to-world pose.
    #[getter]
    fn world_from_camera<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        mat4_to_numpy(py, self.inner.world_from_camera)
    }

    /// "perspective", "intrinsics" or "orthographic".
    #[getter]
    fn kind(&self) -> &'static str {
        self.inner.projection.kind()
    }

    /// World rays through every pixel centre of a width x height image: origins and unit
    /// directions, each (height, width, 3) float64, row 0 at the top. The renderer's own rays.
    /// At most 2^26 rays (8192 x 8192) per call.
    fn rays<'py>(
        &self,
        py: Python<'py>,
        width: &Bound<'py, PyAny>,
        height: &Bound<'py, PyAny>,
    ) -> ArrayPair<'py, PyArray3<f64>, PyArray3<f64>> {
        let (width, height) = image_size(width, height)?;
        let camera = self.inner;
        let (origins, directions) = heavy(py, "computing camera rays", move |_| {
            camera.pixel_rays(width, height)
        })?;
        let shape = (height as usize, width as usize, 3);
        Ok((
            image(py, origins.into_flattened(), shape),
            image(py, directions.into_flattened(), shape),
        ))
    }

    /// What the camera is made of, as pickling stores it: (kind, world_from_camera (4, 4)
    /// OpenGL pose, projection numbers, near or None); `_from_state` makes it again.
    fn _state<'py>(&self, py: Python<'py>) -> CameraState<'py> {
        let c = &self.inner;
        let numbers = match c.projection {
            Projection::Perspective { yfov } => vec![yfov],
            Projection::Intrinsics {
                fx,
                fy,
                cx,
                cy,
                width,
                height,
            } => vec![fx, fy, cx, cy, f64::from(width), f64::from(height)],
            Projection::Orthographic { ymag } => vec![ymag],
        };
        let kind = c.projection.kind();
        (
            kind,
            mat4_to_numpy(py, c.world_from_camera),
            numbers,
            c.near,
        )
    }

    /// The camera `_state` described, checked as the constructors check their arguments.
    #[staticmethod]
    fn _from_state(
        kind: &str,
        world_from_camera: &Bound<'_, PyAny>,
        numbers: Vec<f64>,
        near: Option<f64>,
    ) -> PyResult<Self> {
        let pose = affine_mat4(Some(world_from_camera), "world_from_camera")?;
        let size =
            |v: f64| (v >= 1.0 && v <= f64::from(u32::MAX) && v.fract() == 0.0).then_some(v as u32);
        let projection = match (kind, numbers.as_slice()) {
            ("perspective", &[yfov]) => Some(Projection::Perspective { yfov }),
            ("orthographic", &[ymag]) => Some(Projection::Orthographic { ymag }),
            ("intrinsics", &[fx, fy, cx, cy, w, h]) => {
                size(w)
                    .zip(size(h))
                    .map(|(width, height)| Projection::Intrinsics {
                        fx,
                        fy,
                        cx,
                        cy,
                        width,
                        height,
                    })
            }
            _ => None,
        }
        .ok_or_else(|| parameter_error(format!("not a camera state: {kind} {numbers:?}")))?;
        Ok(PyCamera {
            inner: Camera::from_parts(pose, projection, near)?,
        })
    }

    /// The unit vector the camera looks along (its -Z axis in world space); z-depth is measured
    /// along it.
    #[getter]
    fn forward(&self) -> [f64; 3] {
        self.inner.forward().to_array()
    }

    fn __repr__(&self) -> String {
        format!(
            "<geomtex.Camera {} at {:?}>",
            self.kind(),
            self.inner.eye().to_array()
        )
    }
}

/// Geometry-texture sets and ordinary meshes, each placed by a world_from_object matrix.
#[pyclass(name = "Scene", module = "geomtex._core")]
#[derive(Default)]
pub struct PyScene {
    pub(crate) inner: Scene,
}

/// A scene object of any class the renderer draws (python/kinds.rs); anything else was the Python
/// package's to convert. `normals` is a mesh's normal rule (the default when None).
fn scene_object(
    obj: &Bound<'_, PyAny>,
    world_from_object: DMat4,
    normals: Option<NormalRule>,
) -> PyResult<SceneObject> {
    Ok(SceneObject {
        object: kinds::object_of(obj, normals)?,
        world_from_object,
    })
}

#[pymethods]
impl PyScene {
    #[new]
    fn new() -> Self {
        PyScene::default()
    }

    /// Adds a GeometryTextureSet or a Mesh placed by `world_from_object` (4x4, default identity).
    /// A mesh's normals follow `normals` ("crease" (default), "smooth" or "flat") with
    /// `crease_angle` (degrees, default 20), as in convert. Returns its index.
    #[pyo3(signature = (obj, world_from_object = None, *, normals = None, crease_angle = None))]
    fn add(
        &mut self,
        obj: &Bound<'_, PyAny>,
        world_from_object: Option<&Bound<'_, PyAny>>,
        normals: Option<&Bound<'_, PyAny>>,
        crease_angle: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<usize> {
        let world_from_object = affine_mat4(world_from_object, "world_from_object")?;
        let rule = match (normals, crease_angle) {
            (None, None) => None,
            _ => Some(NormalRule::from_keywords(
                opt_text(normals, "normals")?
                    .map(|s| s.parse())
                    .transpose()?,
                opt_real(crease_angle, "crease_angle")?,
            )?),
        };
        self.inner
            .objects
            .push(scene_object(obj, world_from_object, rule)?);
        Ok(self.inner.objects.len() - 1)
    }

    fn __len__(&self) -> usize {
        self.inner.objects.len()
    }

    /// The scene's objects in order, as pickling stores them: (object, world_from_object (4, 4),
    /// normals, crease_angle), the last two None for a set. An object added twice is the same
    /// Python object both times, so it is stored once.
    fn _objects<'py>(&self, py: Python<'py>) -> PyResult<Vec<ObjectState<'py>>> {
        let mut seen: Vec<(usize, Py<PyAny>)> = Vec::new();
        let mut states = Vec::with_capacity(self.inner.objects.len());
        for placed in &self.inner.objects {
            let (made, address, rule) = kinds::unbound(py, &placed.object)?;
            let obj = match seen.iter().find(|(a, _)| *a == address) {
                Some((_, obj)) => obj.clone_ref(py),
                None => {
                    seen.push((address, made.clone_ref(py)));
                    made
                }
            };
            let source = rule.map(|r| format!("{:?}", r.source).to_lowercase());
            let crease =
                rule.and_then(|r| (r.source == NormalSource::Crease).then_some(r.crease_angle));
            let pose = mat4_to_numpy(py, placed.world_from_object);
            states.push((obj, pose, source, crease));
        }
        Ok(states)
    }

    /// The objects counted by kind, e.g. `<geomtex.Scene 2 sets, 1 meshes>`.
    fn __repr__(&self) -> String {
        let mut counts: Vec<(&str, usize)> = Vec::new();
        for placed in &self.inner.objects {
            let label = kinds::label(&placed.object);
            match counts.iter_mut().find(|(l, _)| *l == label) {
                Some((_, n)) => *n += 1,
                None => counts.push((label, 1)),
            }
        }
        let parts: Vec<_> = counts.iter().map(|(l, n)| format!("{n} {l}")).collect();
        match parts.is_empty() {
            true => "<geomtex.Scene empty>".into(),
            false => format!("<geomtex.Scene {}>", parts.join(", ")),
        }
    }
}

/// A headless renderer of an image size (`resize` changes it). Every Renderer of the process
/// shares one GPU device, its pipelines and its uploads (`SHARED`): a second size or a ray query
/// costs no new device and no new upload.
#[pyclass(name = "Renderer", module = "geomtex._core", frozen)]
pub struct PyRenderer {
    backend: Backend,
    size: Mutex<(u32, u32)>,
    /// The adapter's description and largest image side, read once: what needs only them does
    /// not wait for a frame another thread is drawing.
    info: Vec<(&'static str, String)>,
    max_side: u32,
}

/// This process's renderer, made on first use and kept for its life. A failure to make one is not
/// kept: a later call tries again (and raises again).
static SHARED: Mutex<Option<Arc<Mutex<Renderer>>>> = Mutex::new(None);

/// This process's CPU renderer (its hierarchies kept per object), made on first use.
static CPU_SHARED: Mutex<Option<Arc<Mutex<CpuRenderer>>>> = Mutex::new(None);

fn cpu_shared() -> Arc<Mutex<CpuRenderer>> {
    let mut slot = CPU_SHARED
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    slot.get_or_insert_with(|| Arc::new(Mutex::new(CpuRenderer::new())))
        .clone()
}

/// Which backend a Renderer draws with (`device=`).
enum Backend {
    Gpu(Arc<Mutex<Renderer>>),
    /// The CPU backend (render/cpu); `no_gpu` says why there is no GPU backend when `auto`
    /// chose it, for the errors of kinds only the GPU draws.
    Cpu {
        cpu: Arc<Mutex<CpuRenderer>>,
        no_gpu: Option<String>,
    },
    /// `auto` on a CPU adapter (lavapipe, llvmpipe): what the CPU backend draws goes to it
    /// (faster there: bench/render.py, bench/rays.py), the rest to the adapter.
    Both {
        cpu: Arc<Mutex<CpuRenderer>>,
        gpu: Arc<Mutex<Renderer>>,
    },
}

/// Where one call runs.
enum Route<'a> {
    Gpu(&'a Arc<Mutex<Renderer>>),
    Cpu(&'a Arc<Mutex<CpuRenderer>>),
}

impl Backend {
    /// `device`: "gpu" (wgpu; a DeviceError without a usable adapter), "cpu", or "auto" (the
    /// GPU backend on a GPU; on a CPU adapter the CPU backend for what it draws and the adapter
    /// for the rest; the CPU backend alone without a usable adapter; the adapter alone when
    /// GEOMTEX_ADAPTER names one). Call without the GIL.
    fn choose(device: &str) -> crate::error::Result<Backend> {
        let cpu = |no_gpu| Backend::Cpu {
            cpu: cpu_shared(),
            no_gpu,
        };
        match device {
            "gpu" => Ok(Backend::Gpu(shared()?)),
            "cpu" => Ok(cpu(None)),
            // An adapter named in GEOMTEX_ADAPTER is asked for: no fallback past it.
            "auto" if std::env::var_os("GEOMTEX_ADAPTER").is_some() => Ok(Backend::Gpu(shared()?)),
            "auto" => match shared() {
                Ok(gpu) => {
                    let on_cpu = lock(&gpu)
                        .info()
                        .iter()
                        .any(|(k, v)| *k == "device_type" && v == "Cpu");
                    Ok(match on_cpu {
                        true => Backend::Both {
                            cpu: cpu_shared(),
                            gpu,
                        },
                        false => Backend::Gpu(gpu),
                    })
                }
                Err(GeomtexError::Device(why)) => Ok(cpu(Some(why))),
                Err(other) => Err(other),
            },
            other => Err(GeomtexError::Parameter(format!(
                "device must be \"auto\", \"cpu\" or \"gpu\", got {other:?}"
            ))),
        }
    }

    fn name(&self) -> &'static str {
        match self {
            Backend::Gpu(_) => "gpu",
            Backend::Cpu { .. } => "cpu",
            Backend::Both { .. } => "cpu+gpu",
        }
    }

    /// Where a call on `scene` runs; `gpu_only` when it asks for what only the GPU tracer does.
    fn route(&self, scene: &Scene, gpu_only: bool) -> Route<'_> {
        match self {
            Backend::Gpu(gpu) => Route::Gpu(gpu),
            Backend::Cpu { cpu, .. } => Route::Cpu(cpu),
            Backend::Both { cpu, gpu } => {
                let drawn = (scene.objects.iter()).all(|o| CpuRenderer::draws(&o.object));
                if drawn && !gpu_only {
                    Route::Cpu(cpu)
                } else {
                    Route::Gpu(gpu)
                }
            }
        }
    }

    /// A CPU backend's error, with why there is no GPU backend where `auto` chose it.
    fn explained(&self, e: GeomtexError) -> GeomtexError {
        match (self, e) {
            (
                Backend::Cpu {
                    no_gpu: Some(why), ..
                },
                GeomtexError::Device(msg),
            ) => GeomtexError::Device(format!("{msg}; no GPU backend here: {why}")),
            (_, e) => e,
        }
    }
}

/// The process's renderer, made now if there is none (call with the GIL released: making a
/// device takes seconds on a CPU adapter).
fn shared() -> crate::error::Result<Arc<Mutex<Renderer>>> {
    let mut slot = SHARED
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some(renderer) = &*slot {
        return Ok(renderer.clone());
    }
    let made = Arc::new(Mutex::new(Renderer::new()?));
    *slot = Some(made.clone());
    Ok(made)
}

/// What the process has made on the adapter so far: devices (one for the whole process),
/// target sets (one per image size drawn), the sizes kept, uploads of objects (each set once).
#[pyfunction]
pub fn device_counts(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("devices_made", crate::render::device::devices_made())?;
    let renderer = SHARED
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
        .clone();
    let counts = match renderer {
        // Waits for a frame another thread is drawing: without the GIL.
        Some(r) => py.detach(|| lock(&r).counts()),
        None => vec![
            ("target_sets_made", 0),
            ("target_sizes_kept", 0),
            ("kinds_made", 0),
        ],
    };
    for (k, v) in counts {
        d.set_item(k, v)?;
    }
    d.set_item("uploads", crate::render::uploads_made())?;
    Ok(d)
}

/// The renderer, even if an earlier call panicked while holding it (its state is rebuilt per
/// frame, so a poisoned lock holds nothing half-written that a later frame reads).
fn lock<R>(renderer: &Mutex<R>) -> MutexGuard<'_, R> {
    renderer
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A scene object, its placement and a mesh's normal rule (`Scene._objects`).
type ObjectState<'py> = (
    Py<PyAny>,
    Bound<'py, PyArray2<f64>>,
    Option<String>,
    Option<f64>,
);

/// A camera's kind, pose, projection numbers and near plane (`Camera._state`).
type CameraState<'py> = (
    &'static str,
    Bound<'py, PyArray2<f64>>,
    Vec<f64>,
    Option<f64>,
);

/// Distances, patch ids and normals of a ray query.
/// What `_intersects_first` returns: locations, distances, ids, normals, hit.
type FirstHitArrays<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<i32>>,
    Bound<'py, PyArray2<f32>>,
    Bound<'py, PyArray1<bool>>,
);

type RayHitArrays<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<i32>>,
    Bound<'py, PyArray2<f32>>,
);

/// Ray index, distance and id of every crossing (`list_intersections`).
type IntersectionArrays<'py> = (
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<i32>>,
);

/// A light from any object with a `direction` (parallel light) or a `position` (point light)
/// attribute, as geomtex.DirectionalLight and geomtex.PointLight have.
fn light_of(obj: &Bound<'_, PyAny>) -> PyResult<Light> {
    if let Ok(direction) = obj.getattr("direction") {
        return Ok(Light::Directional {
            direction: vec3(&direction, "light.direction")?,
        });
    }
    if let Ok(position) = obj.getattr("position") {
        return Ok(Light::Point {
            position: vec3(&position, "light.position")?,
        });
    }
    Err(parameter_error(format!(
        "light must be a geomtex.DirectionalLight or PointLight, got {}",
        obj.get_type().name().map_or("?".into(), |n| n.to_string())
    )))
}

/// `render`'s `outputs`: names (a str for one), every output when `None`.
fn outputs_of(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Outputs> {
    let Some(obj) = obj else {
        return Ok(Outputs::DEFAULT);
    };
    let names: Vec<String> = match obj.extract::<String>() {
        Ok(one) => vec![one],
        Err(_) => obj.extract().map_err(|_| {
            parameter_error(format!(
                "outputs must be a sequence of names among {}, got {}",
                Outputs::NAMES.join(", "),
                obj.get_type().name().map_or("?".into(), |n| n.to_string())
            ))
        })?,
    };
    Ok(Outputs::parse(&names)?)
}

/// A Scene as given, or a scene of one object placed at the origin.
fn scene_of(obj: &Bound<'_, PyAny>) -> PyResult<Scene> {
    Ok(match obj.cast::<PyScene>() {
        Ok(s) => s.borrow().inner.clone(),
        Err(_) => Scene {
            objects: vec![scene_object(obj, DMat4::IDENTITY, None)?],
        },
    })
}

impl PyRenderer {
    fn size(&self) -> (u32, u32) {
        *self
            .size
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

#[pymethods]
impl PyRenderer {
    #[new]
    #[pyo3(signature = (width, height, device = None))]
    fn new(
        py: Python<'_>,
        width: &Bound<'_, PyAny>,
        height: &Bound<'_, PyAny>,
        device: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let (w, h) = image_size(width, height)?;
        // Not given: GEOMTEX_DEVICE's, else "auto" (a process-wide default, as GEOMTEX_ADAPTER).
        let device = match opt_text(device, "device")? {
            Some(d) => d,
            None => std::env::var("GEOMTEX_DEVICE").unwrap_or_else(|_| "auto".into()),
        };
        let (backend, info, max_side) = heavy(py, "creating the renderer", move |_| {
            let backend = Backend::choose(&device)?;
            let (info, max_side) = match &backend {
                Backend::Gpu(gpu) | Backend::Both { gpu, .. } => {
                    let locked = lock(gpu);
                    (locked.info(), locked.max_image_side())
                }
                Backend::Cpu { no_gpu, .. } => {
                    let mut info = CpuRenderer::info();
                    if let Some(why) = no_gpu {
                        info.push(("gpu_unavailable", why.clone()));
                    }
                    (info, crate::render::cpu::MAX_IMAGE_SIDE)
                }
            };
            check_image_size(w, h, max_side)?;
            Ok((backend, info, max_side))
        })?;
        Ok(PyRenderer {
            backend,
            size: Mutex::new((w, h)),
            info,
            max_side,
        })
    }

    /// The backend frames and queries run on: "gpu" (wgpu) or "cpu" (the native tracer).
    #[getter]
    fn device(&self) -> &'static str {
        self.backend.name()
    }

    #[getter]
    fn width(&self) -> u32 {
        self.size().0
    }

    #[getter]
    fn height(&self) -> u32 {
        self.size().1
    }

    /// Makes later frames `width` x `height`; the device, pipelines and uploads are kept (every
    /// Renderer shares them), and so are the targets of sizes drawn lately.
    fn resize(&self, width: &Bound<'_, PyAny>, height: &Bound<'_, PyAny>) -> PyResult<()> {
        let (w, h) = image_size(width, height)?;
        check_image_size(w, h, self.max_side)?;
        *self
            .size
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner()) = (w, h);
        Ok(())
    }

    /// The GPU adapter in use: name, backend, device_type, driver, driver_info.
    #[getter]
    fn adapter_info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in &self.info {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    /// Renders a Scene, a GeometryTextureSet or a Mesh seen by `camera`.
    ///
    /// `quality` picks measured settings ("fast", "balanced" or "exact", the default); `method`
    /// and the step keywords override them. `count_fetches` uses a counting build of the pipeline
    /// and reports height fetches in `frame.stats`. `lod` (max-pyramid search only) stops each
    /// patch's descent where its nodes are about a pixel, or with `max_pixel_error` at its
    /// coarsest level whose error bound projects to at most that many pixels. `light` (a DirectionalLight or a
    /// PointLight) casts shadows: `frame.shadow`, and shadowed pixels at half brightness.
    /// `max_pixel_error` (Surfels only, default 1): a cut of each patch's tiles and the nodes
    /// above them is drawn, each part at its coarsest level whose perpendicular error projects to
    /// at most this many pixels of depth (1/16 of it where a silhouette may show). `primary` ("tiles", default, or
    /// "boxes") picks how camera rays meet the texture sets' boxes: per pixel nearest first,
    /// stopping behind the nearest hit, or every box over a pixel searched. `outputs` (names
    /// among "color", "albedo", "depth", "normal", "patch_id", "error_bound",
    /// "coverage_uncertain"; default all but "coverage_uncertain") are the arrays read back or
    /// computed: a frame's other arrays raise ParameterError when read, and a frame without
    /// "patch_id" reports no per-pixel figures in `stats`.
    #[pyo3(signature = (obj, camera, *, quality = None, method = None, steps_per_texel = None,
        min_linear_steps = None, max_linear_steps = None, binary_steps = None,
        max_traversal_steps = None, count_fetches = None, lod = None, background = None,
        light = None, max_pixel_error = None, primary = None, outputs = None))]
    #[allow(clippy::too_many_arguments)] // one per keyword of Renderer.render
    fn render(
        &self,
        py: Python<'_>,
        obj: &Bound<'_, PyAny>,
        camera: &Bound<'_, PyAny>,
        quality: Option<&Bound<'_, PyAny>>,
        method: Option<&Bound<'_, PyAny>>,
        steps_per_texel: Option<&Bound<'_, PyAny>>,
        min_linear_steps: Option<&Bound<'_, PyAny>>,
        max_linear_steps: Option<&Bound<'_, PyAny>>,
        binary_steps: Option<&Bound<'_, PyAny>>,
        max_traversal_steps: Option<&Bound<'_, PyAny>>,
        count_fetches: Option<&Bound<'_, PyAny>>,
        lod: Option<&Bound<'_, PyAny>>,
        background: Option<&Bound<'_, PyAny>>,
        light: Option<&Bound<'_, PyAny>>,
        max_pixel_error: Option<&Bound<'_, PyAny>>,
        primary: Option<&Bound<'_, PyAny>>,
        outputs: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyFrame> {
        let steps = 0..=i64::from(u32::MAX);
        let primary_named = primary.is_some_and(|p| !p.is_none());
        let search = SearchOverrides {
            quality: opt_text(quality, "quality")?
                .map(|q| q.parse())
                .transpose()?,
            method: opt_text(method, "method")?.map(|m| m.parse()).transpose()?,
            steps_per_texel: opt_real(steps_per_texel, "steps_per_texel")?.map(|v| v as f32),
            min_linear_steps: opt_u32(min_linear_steps, "min_linear_steps", steps.clone())?,
            max_linear_steps: opt_u32(max_linear_steps, "max_linear_steps", steps.clone())?,
            binary_steps: opt_u32(binary_steps, "binary_steps", steps.clone())?,
            max_traversal_steps: opt_u32(max_traversal_steps, "max_traversal_steps", steps)?,
            count_fetches: opt_flag(count_fetches, "count_fetches")?,
            lod: opt_flag(lod, "lod")?,
            max_pixel_error: opt_real(max_pixel_error, "max_pixel_error")?.map(|v| v as f32),
            primary: opt_text(primary, "primary")?
                .map(|p| p.parse())
                .transpose()?,
        }
        .resolve()?;
        let camera = camera
            .cast::<PyCamera>()
            .map_err(|_| {
                parameter_error(format!(
                    "camera must be a geomtex.Camera, got {}",
                    camera
                        .get_type()
                        .name()
                        .map_or("?".into(), |n| n.to_string())
                ))
            })?
            .get()
            .inner;
        let background = background.map(|b| rgba8(b, "background")).transpose()?;
        let scene = scene_of(obj)?;
        let light = light.map(light_of).transpose()?;
        let wanted = outputs_of(outputs)?;
        let (width, height) = self.size();
        let request = FrameRequest {
            width,
            height,
            // Shadow rays start from each pixel's depth and normal.
            outputs: match light {
                Some(_) => wanted.union(Outputs::parse(&["depth", "normal"])?),
                None => wanted,
            },
            background,
        };
        // Options only the GPU tracer has: a linear search, levels of detail, counted fetches,
        // a primary pass named.
        let gpu_only = search.lod
            || search.count_fetches
            || search.method == crate::render::Method::LinearBinary
            || primary_named;
        let route = self.backend.route(&scene, gpu_only);
        let frame = heavy(py, "rendering", |cancel| {
            let mut frame = match route {
                Route::Gpu(gpu) => {
                    let mut renderer = lock(gpu);
                    let mut frame = renderer.render(&scene, &camera, &search, &request)?;
                    if let Some(light) = &light {
                        renderer
                            .cast_shadows(&scene, &camera, &search, light, &mut frame, cancel)?;
                    }
                    frame
                }
                Route::Cpu(cpu) => {
                    let cpu_frame = || {
                        let mut renderer = lock(cpu);
                        let mut frame =
                            renderer.render(&scene, &camera, &search, &request, cancel)?;
                        if let Some(light) = &light {
                            renderer.cast_shadows(&scene, &camera, light, &mut frame, cancel)?;
                        }
                        Ok(frame)
                    };
                    cpu_frame().map_err(|e| self.backend.explained(e))?
                }
            };
            frame.keep_only(wanted);
            Ok(frame)
        })?;
        PyFrame::new(py, frame)
    }

    /// Ray queries on the GPU against a Scene, a GeometryTextureSet or a Mesh: per ray the
    /// distance to the nearest hit along its unit direction (+inf on a miss), the patch id (-1
    /// on a miss, -2 - k for the scene's k-th mesh) and the world normal. `any_hit` stops each
    /// ray at the first hit found (shadow-style visibility, not the nearest). `quality`
    /// defaults to "exact" here.
    #[pyo3(signature = (obj, origins, directions, *, any_hit = None, quality = None, method = None))]
    #[allow(clippy::too_many_arguments)] // one per keyword of Renderer.intersect
    fn intersect<'py>(
        &self,
        py: Python<'py>,
        obj: &Bound<'py, PyAny>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        any_hit: Option<&Bound<'py, PyAny>>,
        quality: Option<&Bound<'py, PyAny>>,
        method: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<RayHitArrays<'py>> {
        let any_hit = opt_flag(any_hit, "any_hit")?.unwrap_or(false);
        let (_, hits) = self.traced(py, obj, (origins, directions), any_hit, quality, method)?;
        let n = hits.patch_id.len();
        Ok((
            PyArray1::from_vec(py, hits.distance),
            PyArray1::from_vec(py, hits.patch_id),
            matrix(py, hits.normal, n, 3),
        ))
    }

    /// `intersect`'s nearest hits as `RayQueries.intersects_first` returns them: (locations
    /// (N, 3) float64, NaN on a miss; distances; ids; normals; hit (N,) bool), the locations
    /// made here in one pass rather than by numpy's several.
    #[pyo3(signature = (obj, origins, directions, *, quality = None, method = None))]
    fn _intersects_first<'py>(
        &self,
        py: Python<'py>,
        obj: &Bound<'py, PyAny>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        quality: Option<&Bound<'py, PyAny>>,
        method: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<FirstHitArrays<'py>> {
        let (rays, hits) = self.traced(py, obj, (origins, directions), false, quality, method)?;
        let n = hits.patch_id.len();
        let (locations, hit) = py.detach(|| {
            use rayon::prelude::*;
            let hit: Vec<bool> = hits.patch_id.par_iter().map(|&id| id != -1).collect();
            let locations: Vec<[f64; 3]> = (rays.par_iter().zip(&hits.distance).zip(&hit))
                .map(|((&(o, d), &t), &hit)| match hit {
                    true => (o + d.normalize() * t).to_array(),
                    false => [f64::NAN; 3],
                })
                .collect();
            (locations.into_flattened(), hit)
        });
        Ok((
            matrix(py, locations, n, 3),
            PyArray1::from_vec(py, hits.distance),
            PyArray1::from_vec(py, hits.patch_id),
            matrix(py, hits.normal, n, 3),
            PyArray1::from_vec(py, hit),
        ))
    }

    /// Every crossing of each ray with a Scene, a GeometryTextureSet or a Mesh, on the CPU
    /// backend whatever this renderer's device: (ray index (M,) int64, distance along the
    /// unit direction (M,) float64, id (M,) int32), grouped by ray, nearest first.
    fn list_intersections<'py>(
        &self,
        py: Python<'py>,
        obj: &Bound<'py, PyAny>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
    ) -> PyResult<IntersectionArrays<'py>> {
        let scene = scene_of(obj)?;
        let rays = rays(origins, directions)?;
        let lists = heavy(py, "listing intersections", |cancel| {
            lock(&cpu_shared()).list_intersections(&scene, &rays, cancel)
        })?;
        let total = lists.iter().map(Vec::len).sum();
        let (mut index, mut distance, mut id) = (
            Vec::with_capacity(total),
            Vec::with_capacity(total),
            Vec::with_capacity(total),
        );
        for (i, list) in lists.iter().enumerate() {
            for &(t, k) in list {
                index.push(i as i64);
                distance.push(t);
                id.push(k);
            }
        }
        Ok((
            PyArray1::from_vec(py, index),
            PyArray1::from_vec(py, distance),
            PyArray1::from_vec(py, id),
        ))
    }

    fn __repr__(&self) -> String {
        let name = &self.info[0].1;
        let (width, height) = self.size();
        format!("<geomtex.Renderer {width}x{height} on {name}>")
    }
}

/// A copy of array `a` that no caller holds, as the array type it was checked to be.
fn owned<T: pyo3::type_object::PyTypeCheck>(a: &Bound<'_, PyAny>) -> PyResult<Py<T>> {
    Ok(a.call_method0("copy")?.cast_into::<T>()?.unbind())
}

/// An array that may be absent, bound to the GIL.
fn bound<'py, T>(py: Python<'py>, a: &Option<Py<T>>) -> Option<Bound<'py, T>> {
    a.as_ref().map(|a| a.bind(py).clone())
}

/// `owned` of an array that may be absent.
fn owned_opt<T: pyo3::type_object::PyTypeCheck, A>(
    a: &Option<Bound<'_, A>>,
) -> PyResult<Option<Py<T>>> {
    a.as_ref().map(|a| owned(a.as_any())).transpose()
}

/// One rendered image: numpy arrays, row 0 at the top; the outputs its render asked for.
#[pyclass(name = "Frame", module = "geomtex._core", frozen)]
pub struct PyFrame {
    width: usize,
    height: usize,
    shadow: Option<Py<PyArray2<bool>>>,
    face_id: Option<Py<PyArray2<i32>>>,
    barycentric: Option<Py<PyArray3<f32>>>,
    color: Option<Py<PyArray3<u8>>>,
    albedo: Option<Py<PyArray3<u8>>>,
    depth: Option<Py<PyArray2<f32>>>,
    normal: Option<Py<PyArray3<f32>>>,
    patch_id: Option<Py<PyArray2<i32>>>,
    error_bound: Option<Py<PyArray2<f32>>>,
    coverage_uncertain: Option<Py<PyArray2<bool>>>,
    stats: Py<PyDict>,
}

/// A frame's per-pixel outputs as `Frame._from_arrays` takes them (None where not asked for).
type FrameArrays<'py> = (
    Option<Bound<'py, PyArray3<u8>>>,
    Option<Bound<'py, PyArray3<u8>>>,
    Option<Bound<'py, PyArray2<f32>>>,
    Option<Bound<'py, PyArray3<f32>>>,
    Option<Bound<'py, PyArray2<i32>>>,
    Option<Bound<'py, PyArray2<f32>>>,
    Option<Bound<'py, PyArray2<bool>>>,
);

impl PyFrame {
    fn new(py: Python<'_>, frame: crate::render::Frame) -> PyResult<Self> {
        let (h, w) = (frame.height as usize, frame.width as usize);
        let stats = PyDict::new(py);
        set_stats(&stats, &frame.stats())?;
        if let Some((levels, _)) = &frame.lod_levels {
            stats.set_item("lod_levels", levels.clone())?;
        }
        Ok(PyFrame {
            width: w,
            height: h,
            shadow: (frame.shadow).map(|s| matrix(py, s.mask, h, w).unbind()),
            face_id: (frame.face_id).map(|f| matrix(py, f, h, w).unbind()),
            barycentric: (frame.barycentric).map(|b| image(py, b, (h, w, 3)).unbind()),
            color: (frame.color).map(|c| image(py, c, (h, w, 4)).unbind()),
            albedo: (frame.albedo).map(|a| image(py, a, (h, w, 4)).unbind()),
            depth: (frame.depth).map(|d| matrix(py, d, h, w).unbind()),
            normal: (frame.normal).map(|n| image(py, n, (h, w, 3)).unbind()),
            patch_id: (frame.patch_id).map(|p| matrix(py, p, h, w).unbind()),
            error_bound: (frame.error_bound).map(|b| matrix(py, b, h, w).unbind()),
            coverage_uncertain: (frame.coverage_uncertain).map(|c| matrix(py, c, h, w).unbind()),
            stats: stats.unbind(),
        })
    }

    /// Output `name`, or a ParameterError saying the render did not ask for it.
    fn output<T>(&self, py: Python<'_>, array: &Option<Py<T>>, name: &str) -> PyResult<Py<T>> {
        array.as_ref().map(|a| a.clone_ref(py)).ok_or_else(|| {
            parameter_error(format!(
                "this frame holds no {name}: its render asked for outputs=({}); add '{name}' to \
                 render(..., outputs=...)",
                self.outputs()
                    .iter()
                    .map(|n| format!("'{n}', "))
                    .collect::<String>()
                    .trim_end()
            ))
        })
    }
}

#[pymethods]
impl PyFrame {
    /// A frame from arrays of the shapes and dtypes a render gives (how a pickled frame is made
    /// again), None for outputs not asked for; ParameterError when they do not fit together.
    #[staticmethod]
    #[pyo3(signature = (color, albedo, depth, normal, patch_id, shadow, stats, face_id = None,
        barycentric = None, width = None, height = None, error_bound = None,
        coverage_uncertain = None))]
    #[allow(clippy::too_many_arguments)] // one per output of a frame
    fn _from_arrays(
        color: Option<Bound<'_, PyArray3<u8>>>,
        albedo: Option<Bound<'_, PyArray3<u8>>>,
        depth: Option<Bound<'_, PyArray2<f32>>>,
        normal: Option<Bound<'_, PyArray3<f32>>>,
        patch_id: Option<Bound<'_, PyArray2<i32>>>,
        shadow: Option<Bound<'_, PyArray2<bool>>>,
        stats: Bound<'_, PyDict>,
        face_id: Option<Bound<'_, PyArray2<i32>>>,
        barycentric: Option<Bound<'_, PyArray3<f32>>>,
        width: Option<usize>,
        height: Option<usize>,
        error_bound: Option<Bound<'_, PyArray2<f32>>>,
        coverage_uncertain: Option<Bound<'_, PyArray2<bool>>>,
    ) -> PyResult<Self> {
        let known = depth.as_ref().map(|d| (d.shape()[0], d.shape()[1]));
        let (h, w) = match (height, width, known) {
            (Some(h), Some(w), _) => (h, w),
            (_, _, Some(hw)) => hw,
            _ => {
                return Err(parameter_error(
                    "a frame without depth needs its width and height".into(),
                ))
            }
        };
        let fits = |shape: Option<&[usize]>, channels: Option<usize>| {
            shape.is_none_or(|s| match channels {
                Some(c) => s == [h, w, c],
                None => s == [h, w],
            })
        };
        let fits = fits(color.as_ref().map(|a| a.shape()), Some(4))
            && fits(albedo.as_ref().map(|a| a.shape()), Some(4))
            && fits(depth.as_ref().map(|a| a.shape()), None)
            && fits(normal.as_ref().map(|a| a.shape()), Some(3))
            && fits(patch_id.as_ref().map(|a| a.shape()), None)
            && fits(shadow.as_ref().map(|a| a.shape()), None)
            && fits(face_id.as_ref().map(|a| a.shape()), None)
            && fits(barycentric.as_ref().map(|a| a.shape()), Some(3))
            && fits(error_bound.as_ref().map(|a| a.shape()), None)
            && fits(coverage_uncertain.as_ref().map(|a| a.shape()), None)
            && face_id.is_some() == barycentric.is_some();
        if !fits {
            return Err(parameter_error(format!(
                "frame arrays do not fit a {w}x{h} frame"
            )));
        }
        Ok(PyFrame {
            width: w,
            height: h,
            shadow: owned_opt(&shadow)?,
            face_id: owned_opt(&face_id)?,
            barycentric: owned_opt(&barycentric)?,
            color: owned_opt(&color)?,
            albedo: owned_opt(&albedo)?,
            depth: owned_opt(&depth)?,
            normal: owned_opt(&normal)?,
            patch_id: owned_opt(&patch_id)?,
            error_bound: owned_opt(&error_bound)?,
            coverage_uncertain: owned_opt(&coverage_uncertain)?,
            stats: stats.copy()?.unbind(),
        })
    }

    /// The per-pixel outputs in `Outputs::NAMES` order: color, albedo, depth, normal, patch_id,
    /// error_bound and coverage_uncertain, None for those the render did not ask for (the first
    /// five are `_from_arrays`' first arguments, the last two its keywords of those names).
    fn _arrays<'py>(&self, py: Python<'py>) -> FrameArrays<'py> {
        (
            bound(py, &self.color),
            bound(py, &self.albedo),
            bound(py, &self.depth),
            bound(py, &self.normal),
            bound(py, &self.patch_id),
            bound(py, &self.error_bound),
            bound(py, &self.coverage_uncertain),
        )
    }

    /// The names of the per-pixel outputs this frame holds (`render`'s `outputs`).
    #[getter]
    fn outputs(&self) -> Vec<&'static str> {
        let held = [
            self.color.is_some(),
            self.albedo.is_some(),
            self.depth.is_some(),
            self.normal.is_some(),
            self.patch_id.is_some(),
            self.error_bound.is_some(),
            self.coverage_uncertain.is_some(),
        ];
        (Outputs::NAMES.iter().zip(held))
            .filter_map(|(n, h)| h.then_some(*n))
            .collect()
    }

    /// Image width in pixels.
    #[getter]
    fn width(&self) -> usize {
        self.width
    }

    /// Image height in pixels.
    #[getter]
    fn height(&self) -> usize {
        self.height
    }

    /// (H, W) bool, true where the render's light cannot see the surface; None without a light.
    #[getter]
    fn shadow(&self, py: Python<'_>) -> Option<Py<PyArray2<bool>>> {
        self.shadow.as_ref().map(|s| s.clone_ref(py))
    }

    /// (H, W) int32: the detailed mesh's face each pixel shows through an IgtMesh, -1 elsewhere;
    /// None when the scene holds no IgtMesh.
    #[getter]
    fn face_id(&self, py: Python<'_>) -> Option<Py<PyArray2<i32>>> {
        self.face_id.as_ref().map(|f| f.clone_ref(py))
    }

    /// (H, W, 3) float32 barycentric coordinates of each pixel's point in its `face_id` face (0
    /// where there is none); None when the scene holds no IgtMesh.
    #[getter]
    fn barycentric(&self, py: Python<'_>) -> Option<Py<PyArray3<f32>>> {
        self.barycentric.as_ref().map(|b| b.clone_ref(py))
    }

    /// (H, W, 4) uint8 RGBA, headlight-shaded; the background on a miss.
    #[getter]
    fn color(&self, py: Python<'_>) -> PyResult<Py<PyArray3<u8>>> {
        self.output(py, &self.color, "color")
    }

    /// (H, W, 4) uint8 RGBA unshaded base color (the surface's own color: no light, no
    /// shadow); 0 (transparent black) on a miss, whatever the background.
    #[getter]
    fn albedo(&self, py: Python<'_>) -> PyResult<Py<PyArray3<u8>>> {
        self.output(py, &self.albedo, "albedo")
    }

    /// (H, W) float32 z-depth: distance along the camera's forward axis in world units, +inf on
    /// a miss.
    #[getter]
    fn depth(&self, py: Python<'_>) -> PyResult<Py<PyArray2<f32>>> {
        self.output(py, &self.depth, "depth")
    }

    /// (H, W, 3) float32 world-space unit normals, 0 on a miss.
    #[getter]
    fn normal(&self, py: Python<'_>) -> PyResult<Py<PyArray3<f32>>> {
        self.output(py, &self.normal, "normal")
    }

    /// (H, W) int32: patch index (numbered across the scene's texture sets), -1 on a miss,
    /// -2 - k for the scene's k-th mesh.
    #[getter]
    fn patch_id(&self, py: Python<'_>) -> PyResult<Py<PyArray2<i32>>> {
        self.output(py, &self.patch_id, "patch_id")
    }

    /// (H, W) float32: per drawn pixel a bound (world units) on the distance from the point it
    /// shows to the source mesh; NaN where nothing is drawn or no bound is known.
    #[getter]
    fn error_bound(&self, py: Python<'_>) -> PyResult<Py<PyArray2<f32>>> {
        self.output(py, &self.error_bound, "error_bound")
    }

    /// (H, W) bool: true where the pixel's coverage (drawn or not) could differ from the source
    /// mesh's.
    #[getter]
    fn coverage_uncertain(&self, py: Python<'_>) -> PyResult<Py<PyArray2<bool>>> {
        self.output(py, &self.coverage_uncertain, "coverage_uncertain")
    }

    /// gpu_ms (GPU timestamps, None where unsupported), cpu_ms (the whole call), patches_drawn,
    /// patches_culled (boxes outside the view), meshes_drawn, texture_bytes (the drawn sets' maps
    /// and pyramids on the adapter), setup_ms (of cpu_ms, the one-off a set's first frame pays:
    /// upload, ownership, tile pieces; 0 after), near, method, primary, covered_pixels, searches,
    /// searches_per_pixel (covered_pixels and the per-pixel figures are None without
    /// "patch_id" in `outputs`); with a light
    /// the shadow figures; with surfels their counts; with count_fetches also fetches,
    /// fetches_per_pixel, fetches_per_search and piece_tests_per_pixel.
    #[getter]
    fn stats(&self, py: Python<'_>) -> Py<PyDict> {
        self.stats.clone_ref(py)
    }

    fn __repr__(&self) -> String {
        format!("<geomtex.Frame {}x{}>", self.width, self.height)
    }
}

impl PyRenderer {
    /// The rays of a query and their hits (nearest, or with `any_hit` the first found), on
    /// the backend the scene routes to; `quality` defaults to "exact".
    fn traced(
        &self,
        py: Python<'_>,
        obj: &Bound<'_, PyAny>,
        (origins, directions): (&Bound<'_, PyAny>, &Bound<'_, PyAny>),
        any_hit: bool,
        quality: Option<&Bound<'_, PyAny>>,
        method: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<(Vec<(DVec3, DVec3)>, crate::render::RayHits)> {
        let quality = opt_text(quality, "quality")?;
        let method = opt_text(method, "method")?;
        let search = SearchOverrides {
            quality: Some(
                quality
                    .as_deref()
                    .map(str::parse)
                    .transpose()?
                    .unwrap_or(Quality::Exact),
            ),
            method: method.as_deref().map(str::parse).transpose()?,
            ..Default::default()
        }
        .resolve()?;
        let scene = scene_of(obj)?;
        let rays = rays(origins, directions)?;
        let gpu_only = search.method == crate::render::Method::LinearBinary;
        let route = self.backend.route(&scene, gpu_only);
        let hits = heavy(py, "tracing rays", |cancel| match route {
            Route::Gpu(gpu) => lock(gpu).intersect(&scene, &rays, &search, any_hit, cancel),
            Route::Cpu(cpu) => (lock(cpu).intersect(&scene, &rays, any_hit, cancel))
                .map_err(|e| self.backend.explained(e)),
        })?;
        Ok((rays, hits))
    }
}
