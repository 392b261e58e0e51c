//! Measurement: clocks ([`clock`]), the builder x traversal benchmark
//! ([`bench`]) and the interleaved race against Embree ([`race`]). Each
//! returns a typed, serialisable report; `cli/` prints them and `report/`
//! (future) turns them into tables and plots.

pub mod bench;
pub mod clock;
pub mod race;

pub use bench::{BenchOptions, BenchReport};
pub use race::RaceReport;
