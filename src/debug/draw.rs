//! `rtdiff debug --draw`: render the scene, compute an overlay's lines and
//! draw them over the render, depth-tested against its first hits.

use super::lines::Lines;
use super::overlay::{Context, Overlay};
use super::raster::{DepthBuffer, draw_lines};
use crate::backends::{self, AccelConfig};
use crate::camera::Camera;
use crate::error::Result;
use crate::film::Image;
use crate::pipeline::render_with;
use crate::render::RenderOptions;
use crate::scene::Scene;

/// What [`draw`] made.
#[derive(Clone, Debug)]
pub struct DrawOutput {
    /// The render under the overlay (after bloom, when the scene uses it),
    /// exactly what `rtdiff render` writes for the same view.
    pub render: Image,
    /// The render with the overlay drawn over it.
    pub image: Image,
    /// Pixels the overlay changed (row-major); every other pixel of
    /// [`Self::image`] equals [`Self::render`].
    pub mask: Vec<bool>,
    /// The overlay's lines (world space), for [`super::obj`].
    pub lines: Lines,
    /// The overlay's name.
    pub name: String,
}

/// `camera` turned by `degrees` about its up axis around the point it
/// looks at (`focus_distance` ahead): the same scene seen from the side, so
/// that rays along the view direction (the camera ray) become visible.
pub fn orbit(camera: &Camera, degrees: f32) -> Camera {
    let target = camera.position + camera.focus_distance * camera.forward;
    let rot = glam::Quat::from_axis_angle(camera.up, degrees.to_radians());
    let position = target + rot * (camera.position - target);
    let fov = 2.0 * camera.tan_half_fov.atan().to_degrees();
    Camera {
        aperture_radius: camera.aperture_radius,
        focus_distance: camera.focus_distance,
        ..Camera::look_at(position, target, camera.up, fov, camera.width, camera.height)
    }
}

/// Render `scene` and draw `overlay` over it. The overlay's BVH is built as
/// `accel` says; the render uses the scene's own tracer. The overlay is
/// computed with the scene's camera (its pixels are the scene's); `view`,
/// when given, is the camera the picture is rendered and drawn from (same
/// image size; e.g. [`orbit`]). The scene's camera is restored before
/// returning.
pub fn draw(
    scene: &mut Scene,
    overlay: &dyn Overlay,
    accel: &AccelConfig,
    view: Option<Camera>,
    opts: &RenderOptions,
) -> Result<DrawOutput> {
    let tracer = backends::build_tracer(scene.prims.clone(), &scene.accel)?;
    let lines = overlay.lines(&Context { scene, tracer: tracer.as_ref(), accel: *accel })?;
    let original = scene.camera.clone();
    if let Some(v) = view {
        scene.camera = v;
    }
    let result = render_with(scene, tracer.as_ref(), opts);
    let depth = DepthBuffer::trace(&scene.camera, tracer.as_ref());
    let camera = std::mem::replace(&mut scene.camera, original);
    let render = result?.image;
    let mut image = render.clone();
    let mask = draw_lines(&mut image, &depth, &camera, &lines);
    Ok(DrawOutput { render, image, mask, lines, name: overlay.name() })
}

/// True when every pixel outside `mask` is identical in `a` and `b`.
pub fn same_outside(a: &Image, b: &Image, mask: &[bool]) -> bool {
    a.width == b.width
        && a.height == b.height
        && a.pixels.iter().zip(&b.pixels).zip(mask).all(|((p, q), &m)| m || p == q)
}
