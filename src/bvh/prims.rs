//! The reordered primitive array the BVH leaves point into, and the leaf
//! intersection loops shared by every traversal.

use glam::Vec3;

use crate::geometry::triangle::{WatertightRay, intersect_moller_trumbore};
use crate::geometry::{Hit, Primitives, Ray, Sphere, TriangleTest};

/// One primitive in leaf order: its data and its original id, 40 bytes,
/// so a leaf's primitives are read as one contiguous stream.
///
/// A triangle keeps its three vertices in `v`; a sphere keeps its centre in
/// `v[0]` and its radius in `v[1].x`.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct LeafEntry {
    /// Vertices (triangle) or centre and radius (sphere).
    pub v: [Vec3; 3],
    /// Original primitive id.
    pub id: u32,
}

/// Primitives in BVH leaf order, holding everything intersection needs.
///
/// Entry `k` is primitive `entries[k].id` of the original [`Primitives`];
/// ids below `num_triangles` are triangles (the id order of [`Primitives`]).
#[derive(Clone, Debug, Default)]
pub struct LeafPrims {
    /// The primitives in leaf order.
    pub entries: Vec<LeafEntry>,
    /// Number of triangles in the original primitive list.
    pub num_triangles: u32,
}

impl LeafPrims {
    /// Gather `prims` in the order `order` (a permutation of `0..prims.len()`).
    pub fn new(prims: &Primitives, order: &[u32]) -> Self {
        let nt = prims.triangles.len();
        let entries = order
            .iter()
            .map(|&id| {
                let i = id as usize;
                let v = if i < nt {
                    prims.triangles[i].v
                } else {
                    let s = prims.spheres[i - nt];
                    [s.center, Vec3::new(s.radius, 0.0, 0.0), Vec3::ZERO]
                };
                LeafEntry { v, id }
            })
            .collect();
        Self { entries, num_triangles: nt as u32 }
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Memory held, in bytes.
    pub fn bytes(&self) -> usize {
        self.entries.len() * std::mem::size_of::<LeafEntry>()
    }

    /// Intersect entry `k`: exactly the computation of [`Primitives::intersect_prim`]
    /// on the same primitive, so results are bit-identical to brute force.
    #[inline(always)]
    pub fn intersect(&self, k: usize, ray: &Ray, wr: &WatertightRay, test: TriangleTest) -> Option<(f32, f32, f32)> {
        let e = &self.entries[k];
        if e.id < self.num_triangles {
            match test {
                TriangleTest::Watertight => watertight(ray, wr, e.v[0], e.v[1], e.v[2]),
                TriangleTest::MollerTrumbore => intersect_moller_trumbore(ray, e.v[0], e.v[1], e.v[2]),
            }
        } else {
            Sphere { center: e.v[0], radius: e.v[1].x }.intersect(ray)
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
                let id = self.entries[k].id;
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

/// [`crate::geometry::triangle::intersect_watertight`], operation for
/// operation (so bit-identical), forced inline into the traversal loops.
#[inline(always)]
pub(crate) fn watertight(ray: &Ray, wr: &WatertightRay, v0: Vec3, v1: Vec3, v2: Vec3) -> Option<(f32, f32, f32)> {
    let [kx, ky, kz] = wr.k;
    let s = wr.s;
    let a = v0 - ray.origin;
    let b = v1 - ray.origin;
    let c = v2 - ray.origin;
    let ax = a[kx] - s.x * a[kz];
    let ay = a[ky] - s.y * a[kz];
    let bx = b[kx] - s.x * b[kz];
    let by = b[ky] - s.y * b[kz];
    let cx = c[kx] - s.x * c[kz];
    let cy = c[ky] - s.y * c[kz];
    let mut e0 = cx * by - cy * bx;
    let mut e1 = ax * cy - ay * cx;
    let mut e2 = bx * ay - by * ax;
    if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
        let (ax, ay, bx, by, cx, cy) = (ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64);
        e0 = (cx * by - cy * bx) as f32;
        e1 = (ax * cy - ay * cx) as f32;
        e2 = (bx * ay - by * ax) as f32;
    }
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 {
        return None;
    }
    let az = s.z * a[kz];
    let bz = s.z * b[kz];
    let cz = s.z * c[kz];
    let t_scaled = e0 * az + e1 * bz + e2 * cz;
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    if !(t >= ray.t_min && t <= ray.t_max) {
        return None;
    }
    // As in the reference: reject a distance not provably positive (pbrt-v4 6.8.7).
    if t <= crate::geometry::triangle::watertight_t_error(
        [ax, ay, az],
        [bx, by, bz],
        [cx, cy, cz],
        [e0, e1, e2],
        inv_det,
    ) {
        return None;
    }
    Some((t, e1 * inv_det, e2 * inv_det))
}
