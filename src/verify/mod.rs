//! Verification against independent oracles, beside the rendering pipeline
//! and never inside it: [`hits`] compares ray hits with Embree or brute force;
//! [`image`] compares images (metrics, FLIP, the statistical test for noisy
//! renders) with reference renderers such as Mitsuba 3.

pub mod hits;
pub mod image;
