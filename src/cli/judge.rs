//! `rtdiff judge SCENE --rays rays.csv --hits hits.csv`: another tracer's hits judged like
//! `rtdiff parity` judges a linked one (bounds, classes, exact arbiter, the same verdict);
//! the disputed rays written as a ray file; exit status 2 when a hit is wrong.

use std::path::PathBuf;

use crate::error::{Error, Result};
use crate::rays::file::{read_hits, read_rays, read_tags, tags_path};
use crate::verify::hits::judge::{JudgeInput, disputes_file, judge};
use crate::verify::hits::{Reference, format_report, format_verdict};

/// Arguments of `rtdiff judge`.
#[derive(clap::Args, Debug)]
pub struct JudgeArgs {
    /// Scene: a scene .json file, or a mesh (.obj, .ply, optionally .gz) in the file's own coordinates.
    pub scene: PathBuf,
    /// The rays (CSV: ox,oy,oz,dx,dy,dz,tnear,tfar), e.g. written by `rtdiff rays`.
    #[arg(long)]
    pub rays: PathBuf,
    /// The tracer's hits, one line per ray (CSV: hit,t,prim,u,v; a miss is 0,,,,).
    #[arg(long)]
    pub hits: PathBuf,
    /// The rays' tags (default: RAYS.tags.csv when it exists): sets, crossings, spawned rays.
    #[arg(long)]
    pub tags: Option<PathBuf>,
    /// The reference the hits are compared with before the arbiter judges the differences.
    #[arg(long, value_enum, default_value = "embree")]
    pub reference: Reference,
    /// Where to write the disputed rays (default: HITS.disputes.csv).
    #[arg(long)]
    pub disputes: Option<PathBuf>,
    /// Name of the judged tracer in the report.
    #[arg(long, default_value = "hits")]
    pub name: String,
    /// Skip the exact arbiter.
    #[arg(long)]
    pub no_arbiter: bool,
    /// Wrong rays to print (0 to 10000).
    #[arg(long, default_value_t = 3, value_parser = crate::limits::ranged::<usize>(0, crate::limits::MAX_EXAMPLES as u64))]
    pub examples: usize,
    /// Print every table, as `rtdiff parity --verbose`.
    #[arg(long, short)]
    pub verbose: bool,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Run `rtdiff judge`.
pub fn run(args: &JudgeArgs) -> Result<()> {
    let (ctx, zero_area) = crate::rays::load_context_file_coordinates(&args.scene)?;
    super::warnings::degenerate(&args.scene, &ctx.prims, zero_area);
    let rays = read_rays(&args.rays)?;
    let hits = read_hits(&args.hits)?;
    let tags_file = match &args.tags {
        Some(p) => Some(p.clone()),
        None => Some(tags_path(&args.rays)).filter(|p| p.is_file()),
    };
    let tags = tags_file.as_deref().map(read_tags).transpose()?;
    if tags.is_none() {
        eprintln!(
            "rtdiff: no tags file beside {}: leaks and false self-intersections are not counted",
            args.rays.display()
        );
    }
    let input = JudgeInput { rays, tags, hits, tracer: args.name.clone() };
    let (report, disputes) = judge(&ctx, &input, args.reference, !args.no_arbiter, args.examples)
        .map_err(|e| Error::Invalid(format!("{} and {}: {e}", args.rays.display(), args.hits.display())))?;
    let out = args.disputes.clone().unwrap_or_else(|| {
        let stem = args.hits.file_stem().and_then(|s| s.to_str()).unwrap_or("hits");
        args.hits.with_file_name(format!("{stem}.disputes.csv"))
    });
    if !disputes.is_empty() {
        std::fs::write(&out, disputes_file(&disputes)).map_err(|e| Error::file(&out, format!("cannot write: {e}")))?;
    }
    if args.json {
        let s = serde_json::to_string_pretty(&report)
            .map_err(|e| Error::Invalid(format!("cannot serialise the report: {e}")))?;
        println!("{s}");
    } else if args.verbose {
        print!("{}", format_report(&report));
    } else {
        print!("{}", format_verdict(&report, &args.reference.config().label(), args.examples.max(1)));
    }
    if !args.json {
        if disputes.is_empty() {
            println!("{}: no disputed ray", args.hits.display());
        } else {
            println!(
                "{} disputed rays (verdict and ray, replayable with rtdiff trace) -> {}",
                disputes.len(),
                out.display()
            );
        }
    }
    super::exit_on_fail(report.verdict.passed)
}
