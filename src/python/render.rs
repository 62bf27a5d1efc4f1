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
use super::gdm::PyGdmShell;
use super::gtex::set_stats;
use super::igt::PyIgtMesh;
use super::mesh::PyMesh;
use super::set::PyGeometryTextureSet;
use super::surfels::PySurfels;
use crate::mesh::{NormalRule, NormalSource};
use crate::render::{
    Camera, Light, Object, Projection, Quality, Renderer, Scene, SceneObject, SearchOverrides,
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
#[pyclass(name = "Scene", module = "geomtex._core", subclass)]
#[derive(Default)]
pub struct PyScene {
    pub(crate) inner: Scene,
}

/// A set or a mesh as a scene object; anything else was the Python package's to convert.
/// `normals` is a mesh's normal rule (the default when None); a set's normals are in its maps.
fn scene_object(
    obj: &Bound<'_, PyAny>,
    world_from_object: DMat4,
    normals: Option<NormalRule>,
) -> PyResult<SceneObject> {
    let object = if let Ok(s) = obj.cast::<PyGeometryTextureSet>() {
        if normals.is_some() {
            return Err(parameter_error(
                "normals and crease_angle apply to meshes; a GeometryTextureSet's normals were \
                 chosen by convert(..., normals=...)"
                    .into(),
            ));
        }
        Object::Textures(s.get().inner.clone())
    } else if let Ok(m) = obj.cast::<PyMesh>() {
        Object::Mesh(m.get().inner.clone(), normals.unwrap_or_default())
    } else if let Ok(s) = obj.cast::<PySurfels>() {
        if normals.is_some() {
            return Err(parameter_error(
                "normals and crease_angle apply to meshes; Surfels take their set's normals".into(),
            ));
        }
        Object::Surfels(s.get().inner.clone())
    } else if let Ok(s) = obj.cast::<PyGdmShell>() {
        if normals.is_some() {
            return Err(parameter_error(
                "normals and crease_angle apply to meshes; a shell's normals come from its volume"
                    .into(),
            ));
        }
        Object::Gdm(s.get().inner.clone())
    } else if let Ok(s) = obj.cast::<PyIgtMesh>() {
        if normals.is_some() {
            return Err(parameter_error(
                "normals and crease_angle apply to meshes; an IgtMesh takes its detailed mesh's \
                 normals (geomtex.igt.build(..., normals=...))"
                    .into(),
            ));
        }
        Object::Igt(s.get().inner.clone())
    } else {
        return Err(parameter_error(format!(
            "expected a GeometryTextureSet, Surfels, an IgtMesh, a Mesh or a trimesh, got {}",
            obj.get_type().name()?
        )));
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
        let mut seen: Vec<(*const (), Py<PyAny>)> = Vec::new();
        let mut shared =
            |ptr: *const (), make: &dyn Fn() -> PyResult<Py<PyAny>>| -> PyResult<Py<PyAny>> {
                if let Some((_, obj)) = seen.iter().find(|(p, _)| *p == ptr) {
                    return Ok(obj.clone_ref(py));
                }
                let obj = make()?;
                seen.push((ptr, obj.clone_ref(py)));
                Ok(obj)
            };
        self.inner
            .objects
            .iter()
            .map(|placed| {
                let pose = mat4_to_numpy(py, placed.world_from_object);
                Ok(match &placed.object {
                    Object::Textures(set) => {
                        let make =
                            || {
                                Ok(Py::new(py, PyGeometryTextureSet { inner: set.clone() })?
                                    .into_any())
                            };
                        (shared(Arc::as_ptr(set).cast(), &make)?, pose, None, None)
                    }
                    Object::Surfels(h) => {
                        let make = || Ok(Py::new(py, PySurfels { inner: h.clone() })?.into_any());
                        (shared(Arc::as_ptr(h).cast(), &make)?, pose, None, None)
                    }
                    Object::Gdm(g) => {
                        let make = || Ok(Py::new(py, PyGdmShell { inner: g.clone() })?.into_any());
                        (shared(Arc::as_ptr(g).cast(), &make)?, pose, None, None)
                    }
                    Object::Igt(m) => {
                        let make = || Ok(Py::new(py, PyIgtMesh { inner: m.clone() })?.into_any());
                        (shared(Arc::as_ptr(m).cast(), &make)?, pose, None, None)
                    }
                    Object::Mesh(mesh, rule) => {
                        let make = || {
                            Ok(Py::new(
                                py,
                                PyMesh {
                                    inner: mesh.clone(),
                                },
                            )?
                            .into_any())
                        };
                        let crease =
                            (rule.source == NormalSource::Crease).then_some(rule.crease_angle);
                        let source = format!("{:?}", rule.source).to_lowercase();
                        (
                            shared(Arc::as_ptr(mesh).cast(), &make)?,
                            pose,
                            Some(source),
                            crease,
                        )
                    }
                })
            })
            .collect()
    }

    fn __repr__(&self) -> String {
        let objects = &self.inner.objects;
        let sets = objects
            .iter()
            .filter(|o| matches!(o.object, Object::Textures(_)))
            .count();
        format!(
            "<geomtex.Scene {sets} texture sets, {} meshes>",
            objects.len() - sets
        )
    }
}

/// A headless renderer of a fixed image size. Reuse it: the GPU device, render targets and
/// uploaded textures are kept between frames.
#[pyclass(name = "Renderer", module = "geomtex._core", subclass, frozen)]
pub struct PyRenderer {
    inner: Mutex<Renderer>,
    width: u32,
    height: u32,
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
type RayHitArrays<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<i32>>,
    Bound<'py, PyArray2<f32>>,
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
    /// The renderer, even if an earlier call panicked while holding it (its state is rebuilt per
    /// frame, so a poisoned lock holds nothing half-written that a later frame reads).
    fn renderer(&self) -> MutexGuard<'_, Renderer> {
        self.inner
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

#[pymethods]
impl PyRenderer {
    #[new]
    fn new(py: Python<'_>, width: &Bound<'_, PyAny>, height: &Bound<'_, PyAny>) -> PyResult<Self> {
        let (w, h) = image_size(width, height)?;
        let renderer = heavy(py, "creating the renderer", move |_| Renderer::new(w, h))?;
        Ok(PyRenderer {
            inner: Mutex::new(renderer),
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
        for (k, v) in self.renderer().info() {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    /// Renders a Scene, a GeometryTextureSet or a Mesh seen by `camera`.
    ///
    /// `quality` picks measured settings ("fast", "balanced" or "exact", the default); `method`
    /// and the step keywords override them. `count_fetches` uses a counting build of the pipeline
    /// and reports height fetches in `frame.stats`. `lod` (max-pyramid search only) stops each
    /// patch's descent where its nodes are about a pixel. `light` (a DirectionalLight or a
    /// PointLight) casts shadows: `frame.shadow`, and shadowed pixels at half brightness.
    /// `max_pixel_error` (Surfels only, default 1): a cut of each patch's tiles and the nodes
    /// above them is drawn, each part at its coarsest level whose perpendicular error projects to
    /// at most this many pixels of depth (1/16 of it where a silhouette may show). `primary` ("tiles", default, or
    /// "boxes") picks how camera rays meet the texture sets' boxes: per pixel nearest first,
    /// stopping behind the nearest hit, or every box over a pixel searched.
    #[pyo3(signature = (obj, camera, *, quality = None, method = None, steps_per_texel = None,
        min_linear_steps = None, max_linear_steps = None, binary_steps = None,
        max_traversal_steps = None, count_fetches = None, lod = None, background = None,
        light = None, max_pixel_error = None, primary = None))]
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
    ) -> PyResult<PyFrame> {
        let steps = 0..=i64::from(u32::MAX);
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
        let frame = heavy(py, "rendering", |cancel| {
            let mut renderer = self.renderer();
            renderer.set_background(background);
            let mut frame = renderer.render(&scene, &camera, &search)?;
            if let Some(light) = &light {
                renderer.cast_shadows(&scene, &camera, &search, light, &mut frame, cancel)?;
            }
            Ok(frame)
        })?;
        PyFrame::new(py, frame)
    }

    /// Ray queries on the GPU against a Scene or a GeometryTextureSet (no meshes): per ray the
    /// distance to the nearest hit along its unit direction (+inf on a miss), the patch id (-1)
    /// and the world normal. `any_hit` stops each ray at the first hit found (shadow-style
    /// visibility, not the nearest). `quality` defaults to "exact" here.
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
        let any_hit = opt_flag(any_hit, "any_hit")?.unwrap_or(false);
        let scene = scene_of(obj)?;
        let rays = rays(origins, directions)?;
        let hits = heavy(py, "tracing rays", |cancel| {
            self.renderer()
                .intersect(&scene, &rays, &search, any_hit, cancel)
        })?;
        let n = hits.patch_id.len();
        Ok((
            PyArray1::from_vec(py, hits.distance),
            PyArray1::from_vec(py, hits.patch_id),
            matrix(py, hits.normal, n, 3),
        ))
    }

    fn __repr__(&self) -> String {
        let name = self.renderer().info()[0].1.clone();
        format!(
            "<geomtex.Renderer {}x{} on {name}>",
            self.width, self.height
        )
    }
}

/// A copy of array `a` that no caller holds, as the array type it was checked to be.
fn owned<T: pyo3::type_object::PyTypeCheck>(a: &Bound<'_, PyAny>) -> PyResult<Py<T>> {
    Ok(a.call_method0("copy")?.cast_into::<T>()?.unbind())
}

/// One rendered image: numpy arrays, row 0 at the top.
#[pyclass(name = "Frame", module = "geomtex._core", frozen)]
pub struct PyFrame {
    shadow: Option<Py<PyArray2<bool>>>,
    face_id: Option<Py<PyArray2<i32>>>,
    barycentric: Option<Py<PyArray3<f32>>>,
    color: Py<PyArray3<u8>>,
    albedo: Py<PyArray3<u8>>,
    depth: Py<PyArray2<f32>>,
    normal: Py<PyArray3<f32>>,
    patch_id: Py<PyArray2<i32>>,
    stats: Py<PyDict>,
}

impl PyFrame {
    fn new(py: Python<'_>, frame: crate::render::Frame) -> PyResult<Self> {
        let (h, w) = (frame.height as usize, frame.width as usize);
        let stats = PyDict::new(py);
        set_stats(&stats, &frame.stats())?;
        Ok(PyFrame {
            shadow: (frame.shadow).map(|s| matrix(py, s, h, w).unbind()),
            face_id: (frame.face_id).map(|f| matrix(py, f, h, w).unbind()),
            barycentric: (frame.barycentric).map(|b| image(py, b, (h, w, 3)).unbind()),
            color: image(py, frame.color, (h, w, 4)).unbind(),
            albedo: image(py, frame.albedo, (h, w, 4)).unbind(),
            depth: matrix(py, frame.depth, h, w).unbind(),
            normal: image(py, frame.normal, (h, w, 3)).unbind(),
            patch_id: matrix(py, frame.patch_id, h, w).unbind(),
            stats: stats.unbind(),
        })
    }
}

#[pymethods]
impl PyFrame {
    /// A frame from arrays of the shapes and dtypes a render gives (how a pickled frame is made
    /// again); ParameterError when they do not fit together.
    #[staticmethod]
    #[pyo3(signature = (color, albedo, depth, normal, patch_id, shadow, stats, face_id = None,
        barycentric = None))]
    #[allow(clippy::too_many_arguments)] // one per output of a frame
    fn _from_arrays(
        color: Bound<'_, PyArray3<u8>>,
        albedo: Bound<'_, PyArray3<u8>>,
        depth: Bound<'_, PyArray2<f32>>,
        normal: Bound<'_, PyArray3<f32>>,
        patch_id: Bound<'_, PyArray2<i32>>,
        shadow: Option<Bound<'_, PyArray2<bool>>>,
        stats: Bound<'_, PyDict>,
        face_id: Option<Bound<'_, PyArray2<i32>>>,
        barycentric: Option<Bound<'_, PyArray3<f32>>>,
    ) -> PyResult<Self> {
        let (h, w) = (depth.shape()[0], depth.shape()[1]);
        let fits = [(color.shape(), 4), (albedo.shape(), 4), (normal.shape(), 3)]
            .iter()
            .all(|(shape, channels)| *shape == [h, w, *channels])
            && patch_id.shape() == [h, w]
            && shadow.as_ref().is_none_or(|s| s.shape() == [h, w])
            && face_id.as_ref().is_none_or(|f| f.shape() == [h, w])
            && barycentric.as_ref().is_none_or(|b| b.shape() == [h, w, 3])
            && face_id.is_some() == barycentric.is_some();
        if !fits {
            return Err(parameter_error(format!(
                "frame arrays do not fit a {w}x{h} frame"
            )));
        }
        Ok(PyFrame {
            shadow: shadow.map(|s| owned(s.as_any())).transpose()?,
            face_id: face_id.map(|f| owned(f.as_any())).transpose()?,
            barycentric: barycentric.map(|b| owned(b.as_any())).transpose()?,
            color: owned(color.as_any())?,
            albedo: owned(albedo.as_any())?,
            depth: owned(depth.as_any())?,
            normal: owned(normal.as_any())?,
            patch_id: owned(patch_id.as_any())?,
            stats: stats.copy()?.unbind(),
        })
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
    fn color(&self, py: Python<'_>) -> Py<PyArray3<u8>> {
        self.color.clone_ref(py)
    }

    /// (H, W, 4) uint8 RGBA unshaded base color (the surface's own color: no light, no
    /// shadow); 0 (transparent black) on a miss, whatever the background.
    #[getter]
    fn albedo(&self, py: Python<'_>) -> Py<PyArray3<u8>> {
        self.albedo.clone_ref(py)
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

    /// gpu_ms (GPU timestamps, None where unsupported), cpu_ms (the whole call), patches_drawn,
    /// patches_culled (boxes outside the view), meshes_drawn, texture_bytes (the drawn sets' maps
    /// and pyramids on the adapter), near, method; with count_fetches
    /// also fetches, raycast_fragments and fetches_per_pixel.
    #[getter]
    fn stats(&self, py: Python<'_>) -> Py<PyDict> {
        self.stats.clone_ref(py)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let shape = self.depth.bind(py).shape().to_vec();
        format!("<geomtex.Frame {}x{}>", shape[1], shape[0])
    }
}
