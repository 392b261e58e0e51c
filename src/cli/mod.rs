//! Command-line subcommands: each parses nothing itself (clap does that in
//! `main.rs`) and calls into the library.

pub mod bench;
pub mod bvh_stats;
