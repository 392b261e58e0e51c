//! The brute-force tracer: every primitive against every ray. The oracle the
//! BVH variants are tested against.

use std::sync::Arc;

use crate::geometry::triangle::WatertightRay;
use crate::geometry::{Hit, Primitives, Ray, TriangleTest};

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
        let wr = WatertightRay::new(ray.dir);
        let mut r = *ray;
        let mut best = None;
        for i in 0..self.prims.len() {
            if let Some((t, u, v)) = self.prims.intersect_prim(i, &r, &wr, self.test) {
                Hit::offer(&mut best, &mut r, Hit { t, prim: i as u32, u, v });
            }
        }
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if !ray.is_traceable() {
            return false;
        }
        let wr = WatertightRay::new(ray.dir);
        (0..self.prims.len()).any(|i| self.prims.intersect_prim(i, ray, &wr, self.test).is_some())
    }
}
