//! Geometric primitives and the exact, robust tests on them: rays, boxes,
//! triangles, spheres, and the offsets that keep secondary rays off the surface
//! they start from.

pub mod aabb;
pub mod hit;
pub mod interaction;
pub mod normalize;
pub mod offset;
pub mod primitives;
pub mod ray;
pub mod sphere;
pub mod triangle;

pub use aabb::Aabb;
pub use hit::{Hit, HitFault};
pub use interaction::SurfaceInteraction;
pub use normalize::{normalize_to_unit_sphere, scaled_length, unit_or_zero};
pub use primitives::{Prim, Primitives, Triangle};
pub use ray::Ray;
pub use sphere::Sphere;
pub use triangle::{TriangleKernel, TriangleTest};
