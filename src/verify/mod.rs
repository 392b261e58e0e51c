//! The differential harness: proofs that hits and images are right.

pub mod hits;
