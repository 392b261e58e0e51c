//! The `rtdiff` command: parses arguments and calls the library.

use clap::{Parser, Subcommand};

/// rtdiff: a ray tracer checked against Embree and Mitsuba 3.
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {}

fn main() {
    let cli = Cli::parse();
    let result: rtdiff::Result<()> = match cli.command {};
    if let Err(e) = result {
        eprintln!("rtdiff: error: {e}");
        std::process::exit(1);
    }
}
