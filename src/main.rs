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
    /// Render a scene file to a PNG or EXR image.
    #[command(after_help = rtdiff::limits::HELP)]
    Render(rtdiff::cli::render::RenderArgs),
    /// Visual debugging: one pixel's ray tree, overlays drawn over the render, heatmaps.
    Debug(rtdiff::cli::debug::DebugArgs),
    /// Print BVH statistics (nodes, leaves, levels, leaf sizes, SAH cost, memory, build time) per builder.
    BvhStats(rtdiff::cli::bvh_stats::BvhStatsArgs),
    /// Time BVH builds and traversals (and Embree, when built with it) on primary, incoherent and shadow rays.
    #[command(after_help = rtdiff::limits::HELP)]
    Bench(rtdiff::cli::bench::BenchArgs),
    /// Hit parity of every native builder x traversal against Embree or brute force.
    #[command(after_help = rtdiff::limits::HELP)]
    Parity(rtdiff::cli::parity::ParityArgs),
    /// Trace rays from a CSV file and write the hits as CSV.
    #[command(after_help = rtdiff::limits::HELP)]
    Trace(rtdiff::cli::trace::TraceArgs),
    /// Write rtdiff's ray sets (adversarial ones too) as a ray file for a tracer it cannot link.
    #[command(after_help = rtdiff::limits::HELP)]
    Rays(rtdiff::cli::rays::RaysArgs),
    /// Judge another tracer's hits for a ray file (bounds, exact arbiter, verdict; exit 2 on a wrong hit).
    #[command(after_help = rtdiff::limits::HELP)]
    Judge(rtdiff::cli::judge::JudgeArgs),
    /// Export a scene for Mitsuba 3 (the image oracle): scene.xml, PLY meshes, textures.
    Export(rtdiff::cli::export::ExportArgs),
    /// Write the performance table, convergence and stability reports (JSON, Markdown, SVG, index.html).
    Report(rtdiff::cli::report::ReportArgs),
    /// Check another renderer's image of a reference scene against reference/ (exit 2 when it fails).
    CheckImage(rtdiff::cli::check_image::CheckImageArgs),
    /// Compare two images (EXR or PNG): MAE, RMSE, relMSE, PSNR, max error, pixels over thresholds, FLIP.
    Compare(rtdiff::cli::compare::CompareArgs),
    /// Run a campaign (meshes x ray sets x tracers) or one shard of it, resumably; merge shard folders.
    Campaign(rtdiff::cli::campaign::CampaignArgs),
}

fn main() {
    // Rust starts with SIGPIPE ignored, so printing to a pipe whose reader has
    // gone (`rtdiff compare a.exr b.exr | head -1`) fails, and `println!`
    // panics on the failure. Restore the default action instead: the
    // process ends quietly on a closed pipe, like any Unix filter. Only
    // stdout and stderr are pipes here (no child's stdin is written).
    // SAFETY: called first, before any thread exists; SIG_DFL is a valid action.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Render(a) => rtdiff::cli::render::run(a),
        Command::Debug(a) => rtdiff::cli::debug::run(a),
        Command::BvhStats(a) => rtdiff::cli::bvh_stats::run(a),
        Command::Bench(a) => rtdiff::cli::bench::run(a),
        Command::Parity(a) => rtdiff::cli::parity::run(a),
        Command::Trace(a) => rtdiff::cli::trace::run(a),
        Command::Rays(a) => rtdiff::cli::rays::run(a),
        Command::Judge(a) => rtdiff::cli::judge::run(a),
        Command::Export(a) => rtdiff::cli::export::run(a),
        Command::Report(a) => rtdiff::cli::report::run(a),
        Command::Compare(a) => rtdiff::cli::compare::run(a),
        Command::CheckImage(a) => rtdiff::cli::check_image::run(a),
        Command::Campaign(a) => rtdiff::cli::campaign::run(a),
    };
    if let Err(e) = result {
        eprintln!("rtdiff: error: {e}");
        std::process::exit(1);
    }
}
