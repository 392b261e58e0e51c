//! One pixel's camera ray and the ray tree it causes: what `rtdiff debug
//! --pixel` prints and the `rays` overlay draws.

use crate::accel::Tracer;
use crate::error::{Error, Result};
use crate::geometry::Ray;
use crate::integrator::debug::{RayKind, RayNode, RayTree};
use crate::integrator::{Counters, Whitted};
use crate::rng::Pcg32;
use crate::scene::Scene;

/// The pinhole camera ray through the centre of pixel `(x, y)` of `scene`,
/// after checking the pixel is in the image.
pub fn pixel_ray(scene: &Scene, x: u32, y: u32) -> Result<Ray> {
    if x >= scene.width || y >= scene.height {
        return Err(Error::Invalid(format!("pixel ({x}, {y}) is outside the {}x{} image", scene.width, scene.height)));
    }
    Ok(scene.camera.pixel_centre_ray(x, y))
}

/// The ray tree of one pixel and what it cost.
#[derive(Clone, Debug)]
pub struct PixelTrace {
    /// The camera ray and every ray it caused.
    pub root: RayNode,
    /// The work counters of that one tree.
    pub counters: Counters,
}

/// Trace the centre ray of pixel `(x, y)` through the Whitted integrator over
/// `tracer`, with the pixel's own random stream (as the render's first sample
/// of that pixel draws it), recording every ray.
pub fn trace_pixel_with(scene: &Scene, tracer: &dyn Tracer, x: u32, y: u32) -> Result<PixelTrace> {
    let ray = pixel_ray(scene, x, y)?;
    let integ = Whitted::new(scene, tracer, scene.plan());
    let mut tree = RayTree::default();
    let mut counters = Counters::default();
    let mut rng = Pcg32::for_pixel(scene.seed, x, y);
    integ.trace_as(RayKind::Camera, &ray, 0, &mut rng, &mut counters, &mut tree);
    let root = tree.roots.into_iter().next().ok_or_else(|| Error::Invalid("no ray was traced".into()))?;
    Ok(PixelTrace { root, counters })
}

/// [`trace_pixel_with`] the tracer the scene's `accel` asks for.
pub fn trace_pixel(scene: &Scene, x: u32, y: u32) -> Result<PixelTrace> {
    pixel_ray(scene, x, y)?;
    let tracer = crate::backends::build_tracer(scene.prims.clone(), &scene.accel)?;
    trace_pixel_with(scene, tracer.as_ref(), x, y)
}
