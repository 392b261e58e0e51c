//! Hit parity: native tracers against Embree, brute force and the exact arbiter.

pub mod arbiter;
pub mod exact;
