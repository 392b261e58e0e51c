//! What ray sets are generated from: primitives, a camera and lights.

use std::sync::Arc;

use glam::Vec3;

use crate::geometry::{Primitives, Ray};

/// A pinhole camera (vertical field of view, square pixels), used until a
/// scene file supplies one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinholeCamera {
    /// Eye position.
    pub eye: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up hint.
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y_deg: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl Default for PinholeCamera {
    /// The project's default view of a mesh normalised to the unit sphere.
    fn default() -> Self {
        Self {
            eye: Vec3::new(-0.964, 1.026, -2.649),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y_deg: 50.0,
            width: 800,
            height: 800,
        }
    }
}

impl PinholeCamera {
    /// The ray through continuous pixel position `(px, py)`, `(0, 0)` being
    /// the top-left corner of the image (pixel centres at `+0.5`).
    pub fn ray(&self, px: f32, py: f32) -> Ray {
        let fwd = (self.target - self.eye).normalize();
        let right = fwd.cross(self.up).normalize();
        let up2 = right.cross(fwd);
        let tan = (0.5 * self.fov_y_deg.to_radians()).tan();
        let aspect = self.width as f32 / self.height as f32;
        let ndc_x = 2.0 * px / self.width as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * py / self.height as f32;
        let d = (fwd + ndc_x * tan * aspect * right + ndc_y * tan * up2).normalize();
        Ray::new(self.eye, d)
    }
}

/// Camera rays by continuous pixel position.
pub type CameraFn = Arc<dyn Fn(f32, f32) -> Ray + Send + Sync>;
/// A light's sample point at `(u, v)` in `[0, 1)^2` (a point light ignores both).
pub type LightFn = Arc<dyn Fn(f32, f32) -> Vec3 + Send + Sync>;

/// What ray sets are generated from: the primitives, a camera and lights.
#[derive(Clone)]
pub struct RayContext {
    /// The scene's primitives.
    pub prims: Arc<Primitives>,
    /// Camera rays.
    pub camera: CameraFn,
    /// Image size `(width, height)` in pixels.
    pub image: (u32, u32),
    /// Light sample points (shadow rays go to these).
    pub lights: Vec<LightFn>,
}

impl RayContext {
    /// The default camera and point light `(-1, 1, -1)` around `prims`
    /// (meant for meshes normalised to the unit sphere).
    pub fn with_defaults(prims: Arc<Primitives>) -> Self {
        let cam = PinholeCamera::default();
        let light = Vec3::new(-1.0, 1.0, -1.0);
        Self {
            prims,
            camera: Arc::new(move |x, y| cam.ray(x, y)),
            image: (cam.width, cam.height),
            lights: vec![Arc::new(move |_, _| light)],
        }
    }

    /// The same scene with every point mapped by `p -> scale * p + offset`
    /// (camera origins and lights too; directions are unchanged).
    pub fn transformed(&self, scale: f32, offset: Vec3) -> Self {
        let f = move |p: Vec3| scale * p + offset;
        let prims = Primitives {
            triangles: self.prims.triangles.iter().map(|t| crate::geometry::Triangle { v: t.v.map(f) }).collect(),
            spheres: self
                .prims
                .spheres
                .iter()
                .map(|s| crate::geometry::Sphere { center: f(s.center), radius: scale * s.radius })
                .collect(),
        };
        let cam = self.camera.clone();
        let camera: CameraFn = Arc::new(move |x, y| {
            let r = cam(x, y);
            Ray::with_range(f(r.origin), r.dir, r.t_min * scale, r.t_max * scale)
        });
        let lights = self
            .lights
            .iter()
            .map(|l| {
                let l = l.clone();
                Arc::new(move |u, v| f(l(u, v))) as LightFn
            })
            .collect();
        Self { prims: Arc::new(prims), camera, image: self.image, lights }
    }
}
