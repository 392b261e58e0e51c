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
    /// Print BVH statistics (nodes, leaves, levels, leaf sizes, SAH cost, memory, build time) per builder.
    BvhStats(rtdiff::cli::bvh_stats::BvhStatsArgs),
    /// Time BVH builds and traversals (and Embree, when built with it) on primary, incoherent and shadow rays.
    Bench(rtdiff::cli::bench::BenchArgs),
}

fn main() {
    let cli = Cli::parse();
    let result: rtdiff::Result<()> = match cli.command {
        Command::BvhStats(args) => rtdiff::cli::bvh_stats::run(&args),
        Command::Bench(args) => rtdiff::cli::bench::run(&args),
    };
    if let Err(e) = result {
        eprintln!("rtdiff: error: {e}");
        std::process::exit(1);
    }
}
