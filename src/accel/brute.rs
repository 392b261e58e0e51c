//! The brute-force tracer: every primitive against every ray. The oracle the
//! BVH variants are tested against.

use std::sync::Arc;

use crate::geometry::triangle::WatertightRay;
use crate::geometry::{Hit, Primitives, Ray, TriangleKernel, TriangleTest};

use super::Tracer;

/// Tests every primitive; ties at equal distance keep the lowest primitive id.
pub struct BruteForce {
    prims: Arc<Primitives>,
    test: TriangleTest,
}

impl BruteForce {
    /// A brute-force tracer over `prims` using the given triangle test.
    pub fn new(prims: Arc<Primitives>, test: TriangleTest) -> Self {
        Self { prims, test }
    }
}

impl Tracer for BruteForce {
    fn name(&self) -> String {
        format!("brute{}", self.test.label_suffix())
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !ray.is_traceable() {
            return None;
        }
        crate::with_triangle_kernel!(self.test, K => closest::<K>(&self.prims, ray))
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if !ray.is_traceable() {
            return false;
        }
        crate::with_triangle_kernel!(self.test, K => any::<K>(&self.prims, ray))
    }
}

/// Closest hit over every primitive with the triangle test `K`.
fn closest<K: TriangleKernel>(prims: &Primitives, ray: &Ray) -> Option<Hit> {
    let wr = WatertightRay::new(ray.dir);
    let mut r = *ray;
    let mut best = None;
    for i in 0..prims.len() {
        if let Some((t, u, v)) = prims.intersect_prim_with::<K>(i, &r, &wr) {
            Hit::offer(&mut best, &mut r, Hit { t, prim: i as u32, u, v });
        }
    }
    best
}

/// Whether any primitive is hit, with the triangle test `K`.
fn any<K: TriangleKernel>(prims: &Primitives, ray: &Ray) -> bool {
    let wr = WatertightRay::new(ray.dir);
    (0..prims.len()).any(|i| prims.intersect_prim_with::<K>(i, ray, &wr).is_some())
}
