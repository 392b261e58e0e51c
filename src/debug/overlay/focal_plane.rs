//! `focal-plane`: the depth-of-field focus: the plane at
//! `camera.focus_distance` along the view axis, where the thin-lens rays of
//! [`crate::camera::Camera::lens_ray`] converge, drawn as a grid across the
//! view. Depth-tested like every overlay: grid lines in full colour lie in
//! front of the geometry (that geometry is behind the focus), dimmed ones
//! behind it (in front of the focus); where they change, the surface is in
//! focus. (The reports drew a sphere of radius "focal length" around the
//! camera; rtdiff's lens, like Mitsuba's, focuses on a plane.)

use super::{Context, Overlay};
use crate::debug::lines::{Lines, color};
use crate::error::Result;

/// Grid cells across each direction of the view.
const CELLS: usize = 16;

/// The plane in focus.
pub struct FocalPlane;

impl Overlay for FocalPlane {
    fn name(&self) -> String {
        "focal-plane".into()
    }

    fn lines(&self, ctx: &Context) -> Result<Lines> {
        let cam = &ctx.scene.camera;
        let half = ctx.projector().half_extent();
        let d = cam.focus_distance;
        let centre = cam.position + d * cam.forward;
        // Slightly inside the view so the border lines are drawn.
        let (hx, hy) = (0.995 * half.x * d, 0.995 * half.y * d);
        let mut lines = Lines::default();
        for k in 0..=CELLS {
            let s = 2.0 * k as f32 / CELLS as f32 - 1.0;
            let (x, y) = (s * hx * cam.right, s * hy * cam.up);
            lines.segment(centre + x - hy * cam.up, centre + x + hy * cam.up, color::YELLOW);
            lines.segment(centre + y - hx * cam.right, centre + y + hx * cam.right, color::YELLOW);
        }
        Ok(lines)
    }
}
