//! The reordered primitive array the BVH leaves point into, and the leaf
//! intersection loops shared by every traversal.

use glam::Vec3;

use crate::geometry::triangle::WatertightRay;
use crate::geometry::{Hit, Prim, Primitives, Ray, Sphere, TriangleKernel};

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
    /// The spheres in id order (sphere `i` is primitive `num_triangles + i`):
    /// the leaf loops offer sphere hits by distance alone, and [`Self::finish`]
    /// adds the winner's `(u, v)`.
    pub spheres: Vec<Sphere>,
}

impl LeafPrims {
    /// Gather `prims` in the order `order` (a permutation of `0..prims.len()`).
    pub fn new(prims: &Primitives, order: &[u32]) -> Self {
        let nt = prims.triangles.len();
        let entries = order
            .iter()
            .map(|&id| {
                let i = id as usize;
                let v = match prims.get(i) {
                    Prim::Triangle(t) => t.v,
                    Prim::Sphere(s) => [s.center, Vec3::new(s.radius, 0.0, 0.0), Vec3::ZERO],
                };
                LeafEntry { v, id }
            })
            .collect();
        Self { entries, num_triangles: nt as u32, spheres: prims.spheres.clone() }
    }

    /// The closest hit `hit` of `ray` as the traversals return it: a sphere
    /// hit gets its `(u, v)` here, computed once for the winner (the leaf
    /// loops offered it by distance; the tie rule looks at nothing else), with
    /// the bits [`Sphere::intersect`] gives.
    #[inline]
    pub fn finish(&self, hit: Option<Hit>, ray: &Ray) -> Option<Hit> {
        let mut h = hit?;
        if let Some(s) = h.prim.checked_sub(self.num_triangles).and_then(|i| self.spheres.get(i as usize)) {
            (h.u, h.v) = s.uv_at(ray, h.t);
        }
        Some(h)
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
    /// on the same primitive, so results are bit-identical to brute force
    /// (a sphere's `(u, v)` are left 0 for [`Self::finish`]).
    #[inline(always)]
    pub fn intersect<K: TriangleKernel>(&self, k: usize, ray: &Ray, wr: &WatertightRay) -> Option<(f32, f32, f32)> {
        let e = &self.entries[k];
        if e.id < self.num_triangles {
            K::intersect(ray, wr, e.v[0], e.v[1], e.v[2])
        } else {
            // Distance only: `finish` adds the winner's (u, v).
            Sphere { center: e.v[0], radius: e.v[1].x }.intersect_t(ray).map(|t| (t, 0.0, 0.0))
        }
    }

    /// Closest-hit test of entries `first .. first + count`.
    ///
    /// Tie rule (the same as [`crate::accel::BruteForce`]): among hits at the
    /// same distance the lowest primitive id wins. `ray.t_max` is lowered to
    /// the best distance (the interval is closed, so equal-distance hits are
    /// still reported and compared by id). Returns true when `best` changed.
    #[inline(always)]
    pub fn intersect_leaf<K: TriangleKernel>(
        &self,
        first: u32,
        count: u32,
        ray: &mut Ray,
        wr: &WatertightRay,
        best: &mut Option<Hit>,
    ) -> bool {
        let mut changed = false;
        for k in first as usize..(first + count) as usize {
            if let Some((t, u, v)) = self.intersect::<K>(k, ray, wr) {
                let id = self.entries[k].id;
                changed |= Hit::offer(best, ray, Hit { t, prim: id, u, v });
            }
        }
        changed
    }

    /// Any-hit test of entries `first .. first + count`.
    #[inline(always)]
    pub fn occluded_leaf<K: TriangleKernel>(&self, first: u32, count: u32, ray: &Ray, wr: &WatertightRay) -> bool {
        (first as usize..(first + count) as usize).any(|k| self.intersect::<K>(k, ray, wr).is_some())
    }
}

/// The reference watertight test itself ([`crate::geometry::triangle::intersect_watertight`],
/// declared `#[inline(always)]`): one implementation, so the traversals stay bit-identical to brute force.
pub(crate) use crate::geometry::triangle::intersect_watertight as watertight;
