//! `rtdiff report perf|convergence|stability|all`: parses the arguments and
//! prints what [`crate::report::generate()`] wrote.

use std::path::PathBuf;

use crate::error::Result;
use crate::report::{ReportKind, ReportOptions, generate};

/// Arguments of `rtdiff report`.
#[derive(clap::Args, Debug)]
pub struct ReportArgs {
    /// Which report: perf, convergence, stability, or all (with index.html).
    #[arg(value_enum)]
    pub kind: ReportKind,
    /// Output folder.
    #[arg(short, long, default_value = "reports")]
    pub output: PathBuf,
    /// Small images and few runs (a minute or two; CI).
    #[arg(long)]
    pub quick: bool,
    /// Runs per performance figure (default 3).
    #[arg(long)]
    pub runs: Option<usize>,
    /// Image width and height of the performance table (default 800, the reports'; 64 with --quick).
    #[arg(long)]
    pub size: Option<u32>,
    /// No progress bars.
    #[arg(short, long)]
    pub quiet: bool,
    /// Add a tracer's build and render rows to the performance table (repeatable): plugin:PATH
    /// (a shared library implementing include/rtdiff_tracer.h), native, brute or embree.
    #[arg(long)]
    pub tracer: Vec<crate::backends::TracerArg>,
}

/// Run `rtdiff report`.
pub fn run(args: &ReportArgs) -> Result<()> {
    let opts = ReportOptions {
        kind: args.kind,
        out: args.output.clone(),
        root: PathBuf::from(env!("CARGO_MANIFEST_DIR")),
        quick: args.quick,
        runs: args.runs,
        size: args.size,
        quiet: args.quiet,
        tracers: args.tracer.iter().map(|t| t.backend()).collect::<Result<_>>()?,
    };
    let g = generate(&opts)?;
    if !args.quiet {
        print!("{}", g.markdown);
    }
    eprintln!("rtdiff report: {} files in {} ({:.1} s)", g.files.len(), args.output.display(), g.seconds);
    Ok(())
}
