//! The reordered primitive array the BVH leaves point into, and the leaf
//! intersection loops shared by every traversal.

use glam::Vec3;

use crate::geometry::triangle::{WatertightRay, intersect_moller_trumbore, intersect_watertight};
use crate::geometry::{Hit, Primitives, Ray, Sphere, TriangleTest};

/// Primitives in BVH leaf order, holding everything intersection needs.
///
/// Entry `k` is primitive `ids[k]` of the original [`Primitives`]. Triangles
/// keep their three vertices in `data[k]`; a sphere keeps its centre in
/// `data[k][0]` and its radius in `data[k][1].x`. Primitive ids below
/// `num_triangles` are triangles (the id order of [`Primitives`]).
#[derive(Clone, Debug, Default)]
pub struct LeafPrims {
    /// Original primitive id of each entry.
    pub ids: Vec<u32>,
    /// Vertices (triangle) or centre and radius (sphere) of each entry.
    pub data: Vec<[Vec3; 3]>,
    /// Number of triangles in the original primitive list.
    pub num_triangles: u32,
}

impl LeafPrims {
    /// Gather `prims` in the order `order` (a permutation of `0..prims.len()`).
    pub fn new(prims: &Primitives, order: &[u32]) -> Self {
        let nt = prims.triangles.len();
        let data = order
            .iter()
            .map(|&id| {
                let id = id as usize;
                if id < nt {
                    prims.triangles[id].v
                } else {
                    let s = prims.spheres[id - nt];
                    [s.center, Vec3::new(s.radius, 0.0, 0.0), Vec3::ZERO]
                }
            })
            .collect();
        Self { ids: order.to_vec(), data, num_triangles: nt as u32 }
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Memory held, in bytes.
    pub fn bytes(&self) -> usize {
        self.ids.len() * 4 + self.data.len() * std::mem::size_of::<[Vec3; 3]>()
    }

    /// Intersect entry `k`: exactly the computation of [`Primitives::intersect_prim`]
    /// on the same primitive, so results are bit-identical to brute force.
    #[inline(always)]
    pub fn intersect(&self, k: usize, ray: &Ray, wr: &WatertightRay, test: TriangleTest) -> Option<(f32, f32, f32)> {
        let d = &self.data[k];
        if self.ids[k] < self.num_triangles {
            match test {
                TriangleTest::Watertight => intersect_watertight(ray, wr, d[0], d[1], d[2]),
                TriangleTest::MollerTrumbore => intersect_moller_trumbore(ray, d[0], d[1], d[2]),
            }
        } else {
            Sphere { center: d[0], radius: d[1].x }.intersect(ray)
        }
    }

    /// Closest-hit test of entries `first .. first + count`.
    ///
    /// Tie rule (the same as [`crate::accel::BruteForce`]): among hits at the
    /// same distance the lowest primitive id wins. `ray.t_max` is lowered to
    /// the best distance (the interval is closed, so equal-distance hits are
    /// still reported and compared by id). Returns true when `best` changed.
    #[inline(always)]
    pub fn intersect_leaf(
        &self,
        first: u32,
        count: u32,
        ray: &mut Ray,
        wr: &WatertightRay,
        test: TriangleTest,
        best: &mut Option<Hit>,
    ) -> bool {
        let mut changed = false;
        for k in first as usize..(first + count) as usize {
            if let Some((t, u, v)) = self.intersect(k, ray, wr, test) {
                let id = self.ids[k];
                if best.is_none_or(|b| t < b.t || (t == b.t && id < b.prim)) {
                    *best = Some(Hit { t, prim: id, u, v });
                    ray.t_max = t;
                    changed = true;
                }
            }
        }
        changed
    }

    /// Any-hit test of entries `first .. first + count`.
    #[inline(always)]
    pub fn occluded_leaf(&self, first: u32, count: u32, ray: &Ray, wr: &WatertightRay, test: TriangleTest) -> bool {
        (first as usize..(first + count) as usize).any(|k| self.intersect(k, ray, wr, test).is_some())
    }
}
