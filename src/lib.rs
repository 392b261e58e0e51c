//! rtdiff: a ray tracer that proves itself against Embree (ray hits) and
//! Mitsuba 3 (images).
//!
//! Data flows one way: scene file -> [`scene`] -> acceleration structure
//! ([`accel`]) -> [`integrator`] -> [`film`] -> [`post`] -> output, with the
//! differential harness beside it.

pub mod accel;
pub mod backends;
pub mod bvh;
pub mod camera;
pub mod campaign;
pub mod cli;
pub mod debug;
pub mod embree;
pub mod error;
pub mod features;
pub mod film;
pub mod fuzz;
pub mod geometry;
pub mod integrator;
pub mod light;
pub mod limits;
pub mod material;
pub mod mesh;
pub mod output;
pub mod perf;
pub mod pipeline;
pub mod plugin;
pub mod post;
pub mod rays;
pub mod render;
pub mod report;
pub mod rng;
pub mod sampler;
pub mod scene;
pub mod shading;
pub mod texture;
pub mod verify;

pub use error::{Error, Result};
