//! Cameras, in the pyrender/trimesh convention: `world_from_camera` is an OpenGL-style pose
//! (the camera looks down its -Z axis, +Y up). OpenCV intrinsics are accepted too (their pose looks
//! down +Z with +Y down and is converted on the way in).
//!
//! Pixels: pixel (column x, row y) covers [x, x+1] x [y, y+1], centre at +0.5, row 0 at the top.
//! An OpenCV principal point (cx, cy) refers to pixel centres at integers, as OpenCV does.
//! Depth: reversed Z; perspective cameras have an infinite far plane.

use glam::{DMat4, DVec3, DVec4};

use crate::error::{GeomtexError, Result};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Vertical field of view in radians; square pixels, principal point at the image centre.
    Perspective { yfov: f64 },
    /// OpenCV intrinsics for an image of exactly this size.
    Intrinsics {
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        width: u32,
        height: u32,
    },
    /// Half the view's height in world units; the width follows the image's aspect.
    Orthographic { ymag: f64 },
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub world_from_camera: DMat4,
    pub projection: Projection,
    /// Near plane distance; `None` chooses one from the scene's bounds at render time.
    pub near: Option<f64>,
}

/// World rays through pixel centres: origins and unit directions, one per pixel.
pub type PixelRays = (Vec<[f64; 3]>, Vec<[f64; 3]>);

/// A camera's world rays as affine functions of the pixel centre (`Camera::pixel_lines`): at
/// (x, y), `v[0] + x v[1] + y v[2]` for the origin and for the direction (not of unit length).
pub struct PixelLines {
    origin: [DVec3; 3],
    direction: [DVec3; 3],
}

impl PixelLines {
    /// The world origin and direction (not unit) of the ray through pixel centre (x, y).
    pub fn at(&self, x: f64, y: f64) -> (DVec3, DVec3) {
        let affine = |v: &[DVec3; 3]| v[0] + x * v[1] + y * v[2];
        (affine(&self.origin), affine(&self.direction))
    }
}

/// Per-render projection numbers derived from a camera and an image size.
#[derive(Clone, Copy, Debug)]
pub struct Lens {
    pub orthographic: bool,
    /// Pixel centre (px, py) → a = (px * ray[0] + ray[2], py * ray[1] + ray[3]) (see the shader).
    pub ray: [f64; 4],
    pub clip_from_view: DMat4,
    pub near: f64,
    pub far: f64,
}

impl Projection {
    /// "perspective", "intrinsics" or "orthographic".
    pub fn kind(&self) -> &'static str {
        match self {
            Projection::Perspective { .. } => "perspective",
            Projection::Intrinsics { .. } => "intrinsics",
            Projection::Orthographic { .. } => "orthographic",
        }
    }
}

fn check_finite(what: &str, v: &[f64]) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(GeomtexError::Parameter(format!(
            "{what} must be finite, got {v:?}"
        )))
    }
}

fn check_pose(m: &DMat4) -> Result<()> {
    check_finite("world_from_camera", &m.to_cols_array())?;
    let r = [
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    ];
    let orthonormal = (0..3).all(|i| (r[i].length() - 1.0).abs() < 1e-6)
        && r[0].dot(r[1]).abs() < 1e-6
        && r[0].dot(r[2]).abs() < 1e-6
        && r[1].dot(r[2]).abs() < 1e-6;
    if !orthonormal || m.row(3) != DVec4::new(0.0, 0.0, 0.0, 1.0) {
        return Err(GeomtexError::Parameter(
            "world_from_camera must be a rigid transform (orthonormal rotation, last row 0 0 0 1)"
                .into(),
        ));
    }
    Ok(())
}

impl Camera {
    /// The up direction `look_at` callers get when they give none.
    pub const DEFAULT_UP: DVec3 = DVec3::Y;
    /// The vertical field of view `look_at` callers get when they give none.
    pub const DEFAULT_YFOV_DEG: f64 = 45.0;

    /// The camera with a fixed near plane distance (any projection), or `None` to choose one
    /// from the scene's bounds at render time.
    pub fn with_near(self, near: Option<f64>) -> Result<Camera> {
        if let Some(n) = near {
            if !(n.is_finite() && n > 0.0) {
                return Err(GeomtexError::Parameter(format!(
                    "near must be positive, got {n}"
                )));
            }
        }
        Ok(Camera { near, ..self })
    }

    /// A perspective camera at `eye` looking at `target`.
    pub fn look_at(eye: DVec3, target: DVec3, up: DVec3, yfov_deg: f64) -> Result<Camera> {
        check_finite(
            "eye, target and up",
            &[eye.to_array(), target.to_array(), up.to_array()].concat(),
        )?;
        if !(yfov_deg > 0.0 && yfov_deg < 180.0) {
            return Err(GeomtexError::Parameter(format!(
                "yfov_deg must be in (0, 180), got {yfov_deg}"
            )));
        }
        let pose = Self::pose(eye, target, up)?;
        Ok(Camera {
            world_from_camera: pose,
            projection: Projection::Perspective {
                yfov: yfov_deg.to_radians(),
            },
            near: None,
        })
    }

    /// The OpenGL pose at `eye` looking at `target` with `up` roughly up.
    pub fn pose(eye: DVec3, target: DVec3, up: DVec3) -> Result<DMat4> {
        let forward = (target - eye).try_normalize().ok_or_else(|| {
            GeomtexError::Parameter("look_at: eye and target are the same point".into())
        })?;
        let right = forward
            .cross(up)
            .try_normalize()
            .filter(|r| r.is_finite())
            .ok_or_else(|| {
                GeomtexError::Parameter("look_at: up is parallel to the viewing direction".into())
            })?;
        let true_up = right.cross(forward);
        Ok(DMat4::from_cols(
            right.extend(0.0),
            true_up.extend(0.0),
            (-forward).extend(0.0),
            eye.extend(1.0),
        ))
    }

    /// OpenCV intrinsics `k` (3x3, row-major) with an OpenCV pose (camera looks down +Z, +Y down),
    /// for an image of `width` x `height`.
    pub fn from_intrinsics(
        k: [[f64; 3]; 3],
        world_from_camera_cv: DMat4,
        width: u32,
        height: u32,
    ) -> Result<Camera> {
        check_finite("K", &k.concat())?;
        check_pose(&world_from_camera_cv)?;
        let (fx, fy, cx, cy) = (k[0][0], k[1][1], k[0][2], k[1][2]);
        if !(fx > 0.0 && fy > 0.0) || k[0][1] != 0.0 || k[1][0] != 0.0 || k[2] != [0.0, 0.0, 1.0] {
            return Err(GeomtexError::Parameter(format!(
                "K must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0, got {k:?}"
            )));
        }
        // OpenCV camera axes (x right, y down, z forward) → OpenGL (x right, y up, z backward).
        let flip = DMat4::from_diagonal(DVec4::new(1.0, -1.0, -1.0, 1.0));
        Ok(Camera {
            world_from_camera: world_from_camera_cv * flip,
            projection: Projection::Intrinsics {
                fx,
                fy,
                cx,
                cy,
                width,
                height,
            },
            near: None,
        })
    }

    /// A camera from the parts another camera was made of (as pickling stores them), checked
    /// as the constructors check them.
    pub fn from_parts(
        world_from_camera: DMat4,
        projection: Projection,
        near: Option<f64>,
    ) -> Result<Camera> {
        check_pose(&world_from_camera)?;
        let valid = match projection {
            Projection::Perspective { yfov } => yfov > 0.0 && yfov < std::f64::consts::PI,
            Projection::Intrinsics {
                fx,
                fy,
                cx,
                cy,
                width,
                height,
            } => {
                [fx, fy, cx, cy].iter().all(|v| v.is_finite())
                    && fx > 0.0
                    && fy > 0.0
                    && width > 0
                    && height > 0
            }
            Projection::Orthographic { ymag } => ymag.is_finite() && ymag > 0.0,
        };
        if !valid {
            return Err(GeomtexError::Parameter(format!(
                "not a valid projection: {projection:?}"
            )));
        }
        Camera {
            world_from_camera,
            projection,
            near: None,
        }
        .with_near(near)
    }

    /// An orthographic camera with an OpenGL pose; `ymag` is half the view's height in world units.
    pub fn orthographic(world_from_camera: DMat4, ymag: f64) -> Result<Camera> {
        check_pose(&world_from_camera)?;
        if !(ymag.is_finite() && ymag > 0.0) {
            return Err(GeomtexError::Parameter(format!(
                "ymag must be positive, got {ymag}"
            )));
        }
        Ok(Camera {
            world_from_camera,
            projection: Projection::Orthographic { ymag },
            near: None,
        })
    }

    pub fn view_from_world(&self) -> DMat4 {
        self.world_from_camera.inverse()
    }

    pub fn eye(&self) -> DVec3 {
        self.world_from_camera.w_axis.truncate()
    }

    /// The unit vector the camera looks along (its -Z axis in world space); z-depth is measured
    /// along it.
    pub fn forward(&self) -> DVec3 {
        (-self.world_from_camera.z_axis.truncate()).normalize()
    }

    /// (fx, fy, cx, cy) in OpenCV pixel units for a perspective camera and this image size.
    pub fn intrinsics(&self, width: u32, height: u32) -> Result<Option<[f64; 4]>> {
        match self.projection {
            Projection::Perspective { yfov } => {
                let f = 0.5 * height as f64 / (0.5 * yfov).tan();
                Ok(Some([
                    f,
                    f,
                    0.5 * width as f64 - 0.5,
                    0.5 * height as f64 - 0.5,
                ]))
            }
            Projection::Intrinsics {
                fx,
                fy,
                cx,
                cy,
                width: w,
                height: h,
            } => {
                if (w, h) != (width, height) {
                    return Err(GeomtexError::Parameter(format!(
                        "the camera's intrinsics are for a {w}x{h} image but the renderer is {width}x{height}"
                    )));
                }
                Ok(Some([fx, fy, cx, cy]))
            }
            Projection::Orthographic { .. } => Ok(None),
        }
    }

    /// Projection numbers for an image size and the view-space depth range [z_min, z_max]
    /// (distances along the view direction) that the scene occupies.
    pub fn lens(&self, width: u32, height: u32, z_min: f64, z_max: f64) -> Result<Lens> {
        let lens = self.lens_unchecked(width, height, z_min, z_max)?;
        check_f32_range(&lens, z_min, z_max)?;
        Ok(lens)
    }

    /// `lens` without the float32 range check: for the CPU backend, which works in f64.
    pub(crate) fn lens_unchecked(
        &self,
        width: u32,
        height: u32,
        z_min: f64,
        z_max: f64,
    ) -> Result<Lens> {
        let (w, h) = (width as f64, height as f64);
        match self.intrinsics(width, height)? {
            Some([fx, fy, cx, cy]) => {
                // Near: half-way to the nearest scene point, never 0 (camera inside the scene).
                let scale = z_max.abs().max(z_min.abs()).max(f64::MIN_POSITIVE);
                let near = self.near.unwrap_or_else(|| (0.5 * z_min).max(scale * 1e-7));
                // See camera_functions.wgsl: pixel centre px = u + 0.5 for OpenCV column u.
                let ray = [1.0 / fx, -1.0 / fy, -(cx + 0.5) / fx, (cy + 0.5) / fy];
                let clip_from_view = DMat4::from_cols(
                    DVec4::new(2.0 * fx / w, 0.0, 0.0, 0.0),
                    DVec4::new(0.0, 2.0 * fy / h, 0.0, 0.0),
                    DVec4::new(
                        -((2.0 * cx + 1.0) / w - 1.0),
                        -(1.0 - (2.0 * cy + 1.0) / h),
                        0.0,
                        -1.0,
                    ),
                    DVec4::new(0.0, 0.0, near, 0.0),
                );
                Ok(Lens {
                    orthographic: false,
                    ray,
                    clip_from_view,
                    near,
                    far: f64::INFINITY,
                })
            }
            None => {
                let Projection::Orthographic { ymag } = self.projection else {
                    unreachable!()
                };
                let xmag = ymag * w / h;
                let margin = 1e-3 * (z_max - z_min).abs().max(ymag);
                let near = self.near.unwrap_or(z_min - margin);
                let far = (z_max + margin).max(near + margin);
                let ray = [2.0 * xmag / w, -2.0 * ymag / h, -xmag, ymag];
                let clip_from_view = DMat4::from_cols(
                    DVec4::new(1.0 / xmag, 0.0, 0.0, 0.0),
                    DVec4::new(0.0, 1.0 / ymag, 0.0, 0.0),
                    DVec4::new(0.0, 0.0, 1.0 / (far - near), 0.0),
                    DVec4::new(0.0, 0.0, far / (far - near), 1.0),
                );
                Ok(Lens {
                    orthographic: true,
                    ray,
                    clip_from_view,
                    near,
                    far,
                })
            }
        }
    }

    /// World-space ray through the centre of pixel (x, y): (origin, unit direction). The one
    /// definition the shader mirrors and the reference ray caster uses.
    pub fn pixel_ray(&self, lens: &Lens, x: f64, y: f64) -> (DVec3, DVec3) {
        let (o, d) = self.pixel_lines(lens).at(x, y);
        (o, d.normalize())
    }

    /// The pixel rays as affine functions of the pixel centre (for making many: no matrix per
    /// pixel). Camera space a = (x * ray[0] + ray[2], y * ray[1] + ray[3]) is the ray's origin
    /// (a, 0) along -Z (orthographic) or its direction (a, -1) from the eye (perspective), and
    /// world space is one affine map away.
    pub fn pixel_lines(&self, lens: &Lens) -> PixelLines {
        let m = self.world_from_camera;
        let [sx, sy, ox, oy] = lens.ray;
        let per_x = m.transform_vector3(DVec3::new(sx, 0.0, 0.0));
        let per_y = m.transform_vector3(DVec3::new(0.0, sy, 0.0));
        if lens.orthographic {
            PixelLines {
                origin: [m.transform_point3(DVec3::new(ox, oy, 0.0)), per_x, per_y],
                direction: [m.transform_vector3(DVec3::NEG_Z), DVec3::ZERO, DVec3::ZERO],
            }
        } else {
            PixelLines {
                origin: [m.transform_point3(DVec3::ZERO), DVec3::ZERO, DVec3::ZERO],
                direction: [m.transform_vector3(DVec3::new(ox, oy, -1.0)), per_x, per_y],
            }
        }
    }

    /// World rays through every pixel centre of a `width` x `height` image: origins and unit
    /// directions, row-major with row 0 at the top. The renderer's own rays.
    pub fn pixel_rays(&self, width: u32, height: u32) -> Result<PixelRays> {
        // Rays do not depend on the depth range; any valid one will do.
        let lines = self.pixel_lines(&self.lens(width, height, 1.0, 2.0)?);
        let n = width as usize * height as usize;
        let (mut origins, mut directions) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for y in 0..height {
            for x in 0..width {
                let (o, d) = lines.at(x as f64 + 0.5, y as f64 + 0.5);
                origins.push(o.to_array());
                directions.push(d.normalize().to_array());
            }
        }
        Ok((origins, directions))
    }

    /// View-space z distance (along the camera's forward axis) from a reversed-Z depth value.
    pub fn distance_from_depth(lens: &Lens, depth: f32) -> f32 {
        if depth <= 0.0 {
            return f32::INFINITY;
        }
        if lens.orthographic {
            (lens.far - depth as f64 * (lens.far - lens.near)) as f32
        } else {
            (lens.near / depth as f64) as f32
        }
    }
}

/// The farthest (world units) the scene may reach from the camera: the GPU passes work in f32
/// relative to the camera and square distances, so past ~1e19 (f32's largest value is 3.4e38) a
/// set's tracer overflowed and drew nothing (a set scaled to 1e30: a blank frame, while the mesh
/// it came from rasterized). 1e15 keeps squares and their sums far inside f32.
pub const MAX_VIEW_DISTANCE: f64 = 1e15;

/// Refuses a scene (or rays) reaching `far` from the origin of the frame the GPU works in (the
/// camera, or a ray query's rays) past MAX_VIEW_DISTANCE.
pub(crate) fn check_view_distance(far: f64, from: &str) -> Result<()> {
    if far > MAX_VIEW_DISTANCE {
        return Err(GeomtexError::Parameter(format!(
            "the scene reaches {far:e} (world units) from {from}, past the {MAX_VIEW_DISTANCE:e} \
             the GPU passes hold in float32; scale the scene (or its placement) and the camera \
             or rays together"
        )));
    }
    Ok(())
}

/// Refuses a lens the GPU would read as something else: a scene farther from the camera than
/// MAX_VIEW_DISTANCE, or a pixel footprint outside f32's normal range (an orthographic view
/// 1e-300 tall became 0 in f32 and drew nothing).
fn check_f32_range(lens: &Lens, z_min: f64, z_max: f64) -> Result<()> {
    check_view_distance(z_min.abs().max(z_max.abs()), "the camera")?;
    let footprint = [lens.ray[0].abs(), lens.ray[1].abs()];
    if footprint
        .iter()
        .any(|&v| !(f64::from(f32::MIN_POSITIVE)..=1e30).contains(&v))
    {
        return Err(GeomtexError::Parameter(format!(
            "a pixel of this camera spans {:e} x {:e} (world units for an orthographic camera, \
             tangent of the angle for a perspective one), outside what float32 holds \
             ({:e} to 1e30): choose a field of view or view height within range",
            footprint[0],
            footprint[1],
            f32::MIN_POSITIVE
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_puts_pixel_rays_back_on_their_pixels() {
        let cam = Camera::look_at(DVec3::new(1.0, 2.0, 5.0), DVec3::ZERO, DVec3::Y, 50.0).unwrap();
        let k = [[300.0, 0.0, 150.0], [0.0, 310.0, 90.0], [0.0, 0.0, 1.0]];
        let cv = Camera::from_intrinsics(k, DMat4::IDENTITY, 320, 200).unwrap();
        for (c, w, h) in [(cam, 64, 48), (cv, 320, 200)] {
            let lens = c.lens(w, h, 1.0, 10.0).unwrap();
            let view_from_world = c.view_from_world();
            for (x, y) in [(0.5, 0.5), (10.5, 30.5), (w as f64 - 0.5, h as f64 - 0.5)] {
                let (o, d) = c.pixel_ray(&lens, x, y);
                let p = view_from_world.transform_point3(o + d * 3.0);
                let clip = lens.clip_from_view * p.extend(1.0);
                let ndc = clip.truncate() / clip.w;
                let px = (ndc.x + 1.0) * 0.5 * w as f64;
                let py = (1.0 - ndc.y) * 0.5 * h as f64;
                assert!(
                    (px - x).abs() < 1e-9 && (py - y).abs() < 1e-9,
                    "{px},{py} vs {x},{y}"
                );
                let depth = ndc.z as f32;
                let back = Camera::distance_from_depth(&lens, depth);
                assert!((back as f64 - (-p.z)).abs() < 1e-5 * -p.z);
            }
        }
    }

    #[test]
    fn opencv_principal_point_is_the_pixel_centre() {
        // A ray through OpenCV pixel (cx, cy) goes straight down the optical axis (+Z in OpenCV).
        let k = [[500.0, 0.0, 99.0], [0.0, 500.0, 49.0], [0.0, 0.0, 1.0]];
        let cam = Camera::from_intrinsics(k, DMat4::IDENTITY, 200, 100).unwrap();
        let lens = cam.lens(200, 100, 1.0, 2.0).unwrap();
        let (_, d) = cam.pixel_ray(&lens, 99.5, 49.5);
        assert!((d - DVec3::Z).length() < 1e-12, "{d:?}");
        // Pixel to the right (+x) and below (+y in OpenCV).
        let (_, d) = cam.pixel_ray(&lens, 100.5, 50.5);
        assert!(d.x > 0.0 && d.y > 0.0);
    }

    #[test]
    fn near_is_checked_for_every_projection() {
        let cam = Camera::orthographic(DMat4::IDENTITY, 1.0).unwrap();
        assert_eq!(cam.with_near(Some(0.5)).unwrap().near, Some(0.5));
        assert_eq!(cam.with_near(None).unwrap().near, None);
        let e = cam.with_near(Some(-1.0)).unwrap_err().to_string();
        assert_eq!(e, "near must be positive, got -1");
        assert!(cam.with_near(Some(f64::NAN)).is_err());
        assert_eq!(cam.projection.kind(), "orthographic");
        assert_eq!(cam.forward(), DVec3::NEG_Z);
    }

    #[test]
    fn pixel_rays_are_row_major_from_the_top() {
        let cam = Camera::look_at(DVec3::Z * 5.0, DVec3::ZERO, Camera::DEFAULT_UP, 45.0).unwrap();
        let (origins, directions) = cam.pixel_rays(4, 3).unwrap();
        assert_eq!((origins.len(), directions.len()), (12, 12));
        // Row 0 looks up (+Y), the last row down; column 0 looks left.
        assert!(directions[0][1] > 0.0 && directions[11][1] < 0.0);
        assert!(directions[0][0] < 0.0 && directions[3][0] > 0.0);
        assert!(origins.iter().all(|o| *o == [0.0, 0.0, 5.0]));
    }

    #[test]
    fn bad_cameras_are_parameter_errors() {
        assert!(Camera::look_at(DVec3::ONE, DVec3::ONE, DVec3::Y, 45.0).is_err());
        assert!(Camera::look_at(DVec3::ZERO, DVec3::Y, DVec3::Y, 45.0).is_err());
        assert!(Camera::look_at(DVec3::ZERO, DVec3::Z, DVec3::Y, 180.0).is_err());
        assert!(Camera::orthographic(DMat4::from_scale(DVec3::splat(2.0)), 1.0).is_err());
        let cam = Camera::from_intrinsics(
            [[1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [0.0, 0.0, 1.0]],
            DMat4::IDENTITY,
            4,
            4,
        )
        .unwrap();
        assert!(cam.lens(8, 8, 1.0, 2.0).is_err());
    }
}
