//! obvhs 0.4 (PLOC builder, compressed wide BVH8) as an rtdiff tracer plugin: the
//! library's `build_cwbvh_from_tris` with `BvhBuildParams::medium_build()`,
//! `CwBvh::ray_traverse` and `ray_traverse_anyhit`, and its `Triangle::intersect`
//! (Moller-Trumbore). docs/plugins.md.
//!
//! obvhs's triangle test returns the distance only: this wrapper computes the
//! barycentrics of the hit point in double precision (so `u`, `v` are the
//! wrapper's, not the library's).

use std::time::Duration;

use glam::{DVec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::{Ray as ORay, RayHit};
use obvhs::triangle::Triangle;
use rtdiff_plugin_abi::{Hit, Ray, Tracer};

/// An obvhs CWBVH over the triangles.
struct ObvhsScene {
    tris: Vec<Triangle>,
    bvh: Option<CwBvh>,
}

fn oray(r: &Ray) -> ORay {
    ORay::new(Vec3A::from(r.org), Vec3A::from(r.dir), r.tnear, r.tfar)
}

/// Barycentric weights of vertices 1 and 2 at the point `p` of triangle `t` (double precision).
fn barycentrics(t: &Triangle, p: DVec3) -> (f32, f32) {
    let [a, b, c] = [t.v0, t.v1, t.v2].map(|v| DVec3::new(v.x as f64, v.y as f64, v.z as f64));
    let n = (b - a).cross(c - a);
    let nn = n.length_squared();
    if nn == 0.0 {
        return (0.0, 0.0);
    }
    let u = (p - a).cross(c - a).dot(n) / nn;
    let v = (b - a).cross(p - a).dot(n) / nn;
    (u as f32, v as f32)
}

impl Tracer for ObvhsScene {
    const NAME: &'static std::ffi::CStr = c"obvhs 0.4.0";
    const FEATURES: u32 = 0;

    fn build(triangles: Vec<[[f32; 3]; 3]>, _spheres: Vec<[f32; 4]>) -> Result<Self, String> {
        let tris: Vec<Triangle> = triangles
            .iter()
            .map(|t| Triangle { v0: Vec3A::from(t[0]), v1: Vec3A::from(t[1]), v2: Vec3A::from(t[2]) })
            .collect();
        let bvh = (!tris.is_empty())
            .then(|| build_cwbvh_from_tris(&tris, BvhBuildParams::medium_build(), &mut Duration::default()));
        Ok(Self { tris, bvh })
    }

    fn intersect(&self, ray: &Ray) -> Hit {
        let Some(bvh) = &self.bvh else { return Hit::MISS };
        let mut hit = RayHit::none();
        if !bvh.ray_traverse(oray(ray), &mut hit, |r, id| self.tris[bvh.primitive_indices[id] as usize].intersect(r)) {
            return Hit::MISS;
        }
        let prim = bvh.primitive_indices[hit.primitive_id as usize];
        let o = DVec3::new(ray.org[0] as f64, ray.org[1] as f64, ray.org[2] as f64);
        let d = DVec3::new(ray.dir[0] as f64, ray.dir[1] as f64, ray.dir[2] as f64);
        let (u, v) = barycentrics(&self.tris[prim as usize], o + hit.t as f64 * d);
        Hit { t: hit.t, prim, u, v }
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let Some(bvh) = &self.bvh else { return false };
        let mut any = false;
        bvh.ray_traverse_anyhit(oray(ray), |r, id| {
            any |= self.tris[bvh.primitive_indices[id] as usize].intersect(r) != f32::INFINITY;
        });
        any
    }
}

rtdiff_plugin_abi::export_tracer!(ObvhsScene);
