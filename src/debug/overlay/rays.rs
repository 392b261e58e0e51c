//! `rays --pixel X Y`: the ray tree of one pixel (the integrator's own
//! events, [`crate::integrator::debug::RayTree`]) drawn as the reports drew
//! it: camera, reflection, glossy and transmission rays in the colour they
//! computed (lifted to at least 20% grey so that a black result stays
//! visible; a ray that leaves the scene in red, drawn to the scene's size),
//! shadow rays in the light sample's colour, or red up to the blocker when
//! blocked; a white cross at every hit.

use glam::Vec3;

use super::{Context, Overlay};
use crate::debug::lines::{Lines, color};
use crate::error::Result;
use crate::integrator::debug::RayNode;

/// The ray tree of one pixel.
pub struct RayTreeLines {
    /// The pixel whose centre the camera ray goes through.
    pub pixel: (u32, u32),
}

fn add_node(ctx: &Context, n: &RayNode, lines: &mut Lines) {
    let o = Vec3::from(n.origin);
    match &n.hit {
        Some(h) => {
            let p = Vec3::from(h.position);
            lines.segment(o, p, Vec3::from(n.color).max(Vec3::splat(0.2)));
            lines.cross(p, ctx.world_size(p, 10.0), color::WHITE);
            for l in &n.lights {
                if l.shadow_rays.is_empty() {
                    // Shadows off: the sample is seen as unblocked.
                    lines.segment(p, Vec3::from(l.position), Vec3::from(l.color));
                }
                for s in &l.shadow_rays {
                    let (a, b) = (Vec3::from(s.origin), Vec3::from(s.target));
                    match s.blocked_by {
                        Some((_, t)) => lines.segment(a, a + t * (b - a), color::RED),
                        None => lines.segment(a, b, Vec3::from(l.color)),
                    }
                }
            }
        }
        None => lines.segment(o, o + 2.0 * ctx.scene_size() * Vec3::from(n.direction), color::RED),
    }
    for c in &n.children {
        add_node(ctx, c, lines);
    }
}

impl Overlay for RayTreeLines {
    fn name(&self) -> String {
        format!("rays --pixel {} {}", self.pixel.0, self.pixel.1)
    }

    fn lines(&self, ctx: &Context) -> Result<Lines> {
        let (x, y) = self.pixel;
        let traced = crate::debug::pixel::trace_pixel_with(ctx.scene, ctx.tracer, x, y)?;
        let mut lines = Lines::default();
        add_node(ctx, &traced.root, &mut lines);
        Ok(lines)
    }
}
