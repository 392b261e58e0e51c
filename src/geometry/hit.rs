//! The result of a closest-hit query.

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
