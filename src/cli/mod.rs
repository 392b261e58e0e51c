//! Command-line subcommands: clap parses the arguments in `main.rs`; each
//! module here turns them into library calls.

pub mod bench;
pub mod bvh_stats;
pub mod campaign;
pub mod check_image;
pub mod compare;
pub mod debug;
pub mod export;
pub mod judge;
pub mod parity;
pub mod rays;
pub mod render;
pub mod report;
pub mod trace;
pub mod warnings;

/// End the process with status 2 when a tracer failed its verdict (`parity`, `judge`), after
/// the report is printed: 0 means pass, 1 an error, 2 a failing tracer.
pub fn exit_on_fail(passed: bool) -> crate::error::Result<()> {
    if !passed {
        use std::io::Write;
        let _ = std::io::stdout().flush();
        std::process::exit(2);
    }
    Ok(())
}
