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

/// Why a hit reported by a tracer rtdiff did not write is no hit at all (see
/// [`Hit::fault`]): the harness judges such an answer wrong and names the ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum HitFault {
    /// The primitive id names no primitive of the scene.
    NoSuchPrimitive,
    /// The distance is NaN or infinite.
    DistanceNotFinite,
    /// The distance lies outside the ray's interval `[t_min, t_max]`.
    OutsideInterval,
    /// `u` or `v` is NaN or infinite.
    BarycentricsNotFinite,
}

impl HitFault {
    /// Lower-case name, the class of the verdict.
    pub fn name(self) -> &'static str {
        match self {
            HitFault::NoSuchPrimitive => "no-such-primitive",
            HitFault::DistanceNotFinite => "t-not-finite",
            HitFault::OutsideInterval => "t-outside-interval",
            HitFault::BarycentricsNotFinite => "uv-not-finite",
        }
    }
}

impl Hit {
    /// What is wrong with this hit of `ray` in a scene of `prim_count`
    /// primitives, if anything: an id out of range, a distance that is not
    /// finite or lies outside `[t_min, t_max]` (closed; compared exactly), `u` or
    /// `v` not finite. rtdiff's own tracers never return such a hit.
    pub fn fault(&self, ray: &super::Ray, prim_count: usize) -> Option<HitFault> {
        if self.prim as usize >= prim_count {
            Some(HitFault::NoSuchPrimitive)
        } else if !self.t.is_finite() {
            Some(HitFault::DistanceNotFinite)
        } else if self.t < ray.t_min || self.t > ray.t_max {
            Some(HitFault::OutsideInterval)
        } else if !self.u.is_finite() || !self.v.is_finite() {
            Some(HitFault::BarycentricsNotFinite)
        } else {
            None
        }
    }
}
