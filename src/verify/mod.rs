//! Verification against independent oracles, beside the rendering pipeline
//! and never inside it: [`hits`] compares ray hits with Embree or brute force.
//! Image comparison with Mitsuba 3 (metrics, FLIP, statistical tests) goes in
//! `verify/image/`.

pub mod hits;
