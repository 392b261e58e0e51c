//! What ray sets are generated from: primitives, a camera and lights.

use std::sync::Arc;

use glam::Vec3;

use crate::camera::Camera;
use crate::geometry::{Primitives, Ray};

/// The default point light of a mesh without a scene file (and of `bench`'s shadow rays).
pub const DEFAULT_LIGHT: Vec3 = Vec3::new(-1.0, 1.0, -1.0);

/// The default image size of a mesh without a scene file (the scene files' default).
pub const DEFAULT_IMAGE: (u32, u32) = (800, 800);

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
    /// The default camera ([`Camera::default_view`]) and point light ([`DEFAULT_LIGHT`]) around `prims`
    /// (meant for meshes normalised to the unit sphere).
    pub fn with_defaults(prims: Arc<Primitives>) -> Self {
        let cam = Camera::default_view(DEFAULT_IMAGE.0, DEFAULT_IMAGE.1);
        Self {
            prims,
            camera: Arc::new(move |x, y| cam.ray(x, y)),
            image: DEFAULT_IMAGE,
            lights: vec![Arc::new(move |_, _| DEFAULT_LIGHT)],
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
