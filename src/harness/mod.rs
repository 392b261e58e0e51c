//! The differential harness: deterministic ray sets and hit-parity reports
//! comparing rtdiff's tracers with a reference (Embree or brute force).

pub mod parity;
pub mod raysets;
