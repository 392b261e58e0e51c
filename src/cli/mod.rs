//! Command-line subcommands: clap parses the arguments in `main.rs`; each
//! module here turns them into library calls.

pub mod bench;
pub mod bvh_stats;
pub mod campaign;
pub mod compare;
pub mod debug;
pub mod export;
pub mod parity;
pub mod render;
pub mod report;
pub mod trace;
pub mod warnings;
