//! The slab test of the binary traversals: [`RayPre`], [`cull_bound`] and
//! [`far_scale`] are defined once, in [`crate::geometry::aabb`] (the crate's
//! one scalar ray/box test); the 8-wide traversal (`wide.rs`) repeats its
//! arithmetic lane by lane, in AVX2 and in a scalar fallback.

pub use crate::geometry::aabb::{RayPre, cull_bound, far_scale};
