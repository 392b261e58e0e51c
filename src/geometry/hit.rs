//! The result of a closest-hit query, and the tie rule every tracer shares.

/// A ray hit, in the layout every tracer (brute force, BVH, Embree) reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Global primitive index: triangles first, then spheres (see [`crate::geometry::Primitives`]).
    pub prim: u32,
    /// Barycentric weight of vertex 1 (Embree's `u`); for spheres the longitude in [0, 1].
    pub u: f32,
    /// Barycentric weight of vertex 2 (Embree's `v`); for spheres the colatitude in [0, 1].
    pub v: f32,
}

impl Hit {
    /// The tie rule of every rtdiff tracer (brute force and each BVH
    /// traversal): offer candidate `c` (already within `ray`'s interval); it
    /// becomes the best when nearer, or equally near with a lower primitive
    /// id, and `ray.t_max` follows it (the interval is closed, so later hits at
    /// the same distance are still offered and compared by id). Returns true
    /// when `best` changed.
    #[inline(always)]
    pub fn offer(best: &mut Option<Hit>, ray: &mut super::Ray, c: Hit) -> bool {
        if best.is_none_or(|b| c.t < b.t || (c.t == b.t && c.prim < b.prim)) {
            *best = Some(c);
            ray.t_max = c.t;
            true
        } else {
            false
        }
    }
}
