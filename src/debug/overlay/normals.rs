//! `normals --pixel X Y`: at the first hit through one pixel, the hit
//! triangle (white), its three vertex normals (blue) and the shading normal
//! the renderer uses there (yellow: the barycentric interpolation of the
//! vertex normals with `normal_interpolation` on, the geometric normal
//! otherwise), as the reports' normal-interpolation debug. A sphere shows
//! its normal only.

use glam::Vec3;

use super::{Context, Overlay};
use crate::debug::lines::{Lines, color};
use crate::error::{Error, Result};
use crate::integrator::Whitted;

/// The normals at one pixel's hit.
pub struct Normals {
    /// The pixel whose centre the camera ray goes through.
    pub pixel: (u32, u32),
}

impl Overlay for Normals {
    fn name(&self) -> String {
        format!("normals --pixel {} {}", self.pixel.0, self.pixel.1)
    }

    fn lines(&self, ctx: &Context) -> Result<Lines> {
        let (x, y) = self.pixel;
        let (ray, hit) = ctx.pixel_hit(x, y)?;
        let hit =
            hit.ok_or_else(|| Error::Invalid(format!("normals: the ray through pixel ({x}, {y}) hits nothing")))?;
        let scene = ctx.scene;
        let it = Whitted::new(scene, ctx.tracer, scene.plan()).interaction(&ray, &hit);
        let mut lines = Lines::default();
        let p = it.si.p;
        let len = ctx.world_size(p, 60.0);
        if let Some(t) = scene.prims.triangles.get(hit.prim as usize) {
            lines.triangle(t.v, color::WHITE);
            let sh = &scene.triangle_shading[hit.prim as usize];
            for (v, n) in t.v.iter().zip(sh.normals) {
                lines.segment(*v, *v + ctx.world_size(*v, 60.0) * n.normalize_or(Vec3::ZERO), color::BLUE);
            }
        }
        lines.cross(p, ctx.world_size(p, 8.0), color::YELLOW);
        lines.segment(p, p + len * it.ns, color::YELLOW);
        Ok(lines)
    }
}
