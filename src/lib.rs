//! rtdiff: a ray tracer that proves itself against Embree (ray hits) and
//! Mitsuba 3 (images).
//!
//! Data flows one way: scene file -> [`scene`] -> acceleration structure
//! ([`accel`]) -> [`integrator`] -> film -> [`post`] -> output, with the
//! differential harness beside it.

pub mod accel;
pub mod bvh;
pub mod cli;
pub mod error;
pub mod geometry;
pub mod mesh;
pub mod rng;

pub use error::{Error, Result};
