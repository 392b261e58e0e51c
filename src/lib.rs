//! rtdiff: a ray tracer that proves itself against Embree (ray hits) and
//! Mitsuba 3 (images).
//!
//! Data flows one way: scene file -> [`scene`] -> acceleration structure
//! ([`accel`]) -> [`integrator`] -> film -> [`post`] -> output, with the
//! differential harness beside it.

pub mod accel;
pub mod cli;
#[cfg(feature = "embree")]
pub mod embree;
pub mod error;
pub mod geometry;
pub mod harness;
pub mod mesh;

pub use error::{Error, Result};
