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
enum Command {
    /// Hit parity of every native builder x traversal against Embree or brute force.
    Parity(rtdiff::cli::parity::ParityArgs),
    /// Trace rays from a CSV file and write the hits as CSV.
    Trace(rtdiff::cli::trace::TraceArgs),
}

fn main() {
    let cli = Cli::parse();
    let result: rtdiff::Result<()> = match &cli.command {
        Command::Parity(a) => rtdiff::cli::parity::run(a),
        Command::Trace(a) => rtdiff::cli::trace::run(a),
    };
    if let Err(e) = result {
        eprintln!("rtdiff: error: {e}");
        std::process::exit(1);
    }
}
